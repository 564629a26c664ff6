"""Back-to-back of the generated C against the Python over the acceptance fuzz's scenarios: the wheel loops, the
MPC's QP solver, or the whole cascade of a unicycle law.

For each of the first N scenarios of ``experiments/fuzz/acceptance.toml`` and each of its pose controllers, the
closed loop runs with the Python PI wheel loops driving the plant and the generated C loops (``wheel_loops =
"pi_c"``, compiled once) stepped beside them on the same setpoints and measurements; then with the C loops driving
alone (:func:`agvctl.codegen.back_to_back`). Prints the largest DA voltage difference over every sample, the
samples where the two disagree on which loops were clamped, and whether every limit's verdict is the same in the two
runs. Warnings of a scenario (a path near the voltage headroom) are noted, as ``agvctl fuzz`` notes them.

With ``--part qp``, each scenario's LTV MPC (the ``mpc`` runs only) runs with OSQP in Python and with the C generated
for its QP (``qp_solver = "osqp_c"``), each in its own closed loop (:func:`agvctl.codegen.qp_back_to_back`): the
largest difference of the commanded DA voltages, sample by sample, and the verdicts. ``--part qp_float`` does the
same with the C in single precision (``qp_solver = "osqp_c_float"``), and prints the largest difference of the
tracking errors' RMS too. ``--part cascade`` runs each scenario with the Ramsete law and with the LTV unicycle LQR,
each cascade in Python and as generated C (the law, ``pose = "ramsete_c"`` or ``"ltv_lqr_c"``, and the loops,
``wheel_loops = "pi_c"``), each in its own closed loop (:func:`agvctl.codegen.cascade_back_to_back`).

Run:  python experiments/codegen_back_to_back.py [--part loops|qp|qp_float|cascade] [--scenarios 100] [--jobs 2]
                                               [--seed S]
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import tempfile
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.codegen import back_to_back, cascade_back_to_back, qp_back_to_back
from agvctl.controllers.baselines.c_unicycle import COMPILED_LAWS
from agvctl.controllers.mpc.config import QpSolver
from agvctl.fuzz.report import FuzzTask
from agvctl.fuzz.run import fuzz_tasks
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config

FUZZ_FILE = Path(__file__).parent / "fuzz" / "acceptance.toml"
SOLVERS: dict[str, QpSolver] = {"qp": "osqp_c", "qp_float": "osqp_c_float"}
"""The generated QP solver each ``--part`` compares with OSQP in Python."""


def compare(task: FuzzTask) -> tuple[int, str, int, float, int, bool, bool, bool]:
    """One scenario with one pose controller, its wheel loops: (scenario, controller, samples, largest DA difference
    in V, clamped mismatches, same verdicts, Python passed, C passed)."""
    with tempfile.TemporaryDirectory(prefix="agvctl-b2b-") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, text in task.files:
            Path(tmp, name).write_text(text, encoding="utf-8")
        r = back_to_back(Path(tmp, task.files[-1][0]))
    return (
        task.scenario,
        task.controller,
        r.samples,
        r.max_da_difference_v,
        r.limited_mismatches,
        r.same_verdicts,
        r.python.passed,
        r.c.passed,
    )


def compare_runs(task: FuzzTask, part: str) -> tuple[int, str, int, float, float, bool, bool, bool]:
    """One scenario run in Python and as generated C, each in its own closed loop (``part``: ``"qp"``, ``"qp_float"``
    or ``"cascade"``): as :func:`compare`, with the difference of the tracking errors' RMS in m in place of the
    clamped mismatches, and the samples negative where the two runs' counts differ."""
    with tempfile.TemporaryDirectory(prefix="agvctl-b2b-") as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, text in task.files:
            Path(tmp, name).write_text(text, encoding="utf-8")
        experiment = Path(tmp, task.files[-1][0])
        r = cascade_back_to_back(experiment) if part == "cascade" else qp_back_to_back(experiment, SOLVERS[part])
    rms = abs(r.python.metrics["tracking_error_rms_m"] - r.c.metrics["tracking_error_rms_m"])
    samples = r.samples if r.samples == r.samples_c else -r.samples
    return (
        task.scenario,
        task.controller,
        samples,
        r.max_da_difference_v,
        rms,
        r.same_verdicts,
        r.python.passed,
        r.c.passed,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=100)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--part", choices=("loops", "qp", "qp_float", "cascade"), default="loops")
    parser.add_argument("--seed", type=int, default=None, help="the scenarios' seed (default: the file's)")
    args = parser.parse_args()
    spec = load_fuzz_config(FUZZ_FILE)
    if args.seed is not None:
        spec = override_fuzz_config(spec, seed=args.seed)
    if args.part != "loops":
        spec = dataclasses.replace(spec, controllers=tuple(COMPILED_LAWS) if args.part == "cascade" else ("mpc",))
    tasks = fuzz_tasks(spec, list(range(args.scenarios))).tasks
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        if args.part == "loops":
            rows: list[tuple[int, str, int, float, Any, bool, bool, bool]] = list(pool.map(compare, tasks))
        else:
            rows = list(pool.map(functools.partial(compare_runs, part=args.part), tasks))
    wall = time.perf_counter() - t0
    print(
        f"{len(rows)} runs ({args.scenarios} scenarios of {FUZZ_FILE.name}, seed {spec.seed}, x "
        f"{', '.join(spec.controllers)}), "
        f"{wall:.1f} s on {args.jobs} jobs"
    )
    for controller in spec.controllers:
        mine = [r for r in rows if r[1] == controller]
        verdicts = (
            f"verdicts differ in {sum(not r[5] for r in mine)} runs   "
            f"passed: Python {sum(r[6] for r in mine)}, C {sum(r[7] for r in mine)} of {len(mine)}"
        )
        if args.part == "loops":
            print(
                f"  {controller:<8} samples {sum(r[2] for r in mine):>7}   largest DA difference "
                f"{max(r[3] for r in mine):.3g} V   clamped mismatches {sum(r[4] for r in mine)}   {verdicts}"
            )
            continue
        da = np.array([r[3] for r in mine])
        rms_mm = np.array([r[4] for r in mine]) * 1e3
        print(
            f"  {controller:<8} samples {sum(abs(r[2]) for r in mine):>7}   DA difference per run: median "
            f"{np.median(da):.3g} V, largest {da.max():.3g} V   RMS tracking difference: median "
            f"{np.median(rms_mm):.3g} mm, largest {rms_mm.max():.3g} mm   runs ending at another sample: "
            f"{sum(r[2] < 0 for r in mine)}   {verdicts}"
        )


if __name__ == "__main__":
    main()
