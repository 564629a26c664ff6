"""Benchmark of the MPC's QP solve per step: OSQP in Python against the generated C solver, on the same steps.

The figure-8 experiment's closed loop is run once with its MPC's OSQP solver recorded: every update (q, l, u and the
varying entries of P and A), warm start, step-size change and solve. The recorded steps are then replayed, from the
state just after set-up, into three solvers of the same QP:

* Python: ``osqp.OSQP`` set up as the controller sets it up, a step being ``update(...)`` and ``solve()`` as the
  controller calls them (``perf_counter_ns`` around both);
* C through ctypes: :class:`~agvctl.controllers.mpc.c_solver.CompiledQp`, a step being one call of the entry point
  (update and solve), numpy arrays in and out (``perf_counter_ns`` around the call), interleaved step by step with
  the Python solver so both see the same machine load;
* C alone: the same entry point called in a loop in C over all the steps, each timed with
  ``clock_gettime(CLOCK_MONOTONIC)``, a small timing file compiled with the generated code.

A pass starts as the controller's ``reset`` does (both iterates to zero, ρ to its setting). Prints the median and
p99 step time of each in µs, the ratios, and whether the three agree on every step's iterations in the first pass.

Run:  python experiments/benchmarks/mpc_qp_c.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import ctypes
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np
import osqp

from agvctl.controllers.mpc.c_qp import STRICT_C_FLAGS, QpC, generate_qp_c
from agvctl.controllers.mpc.c_solver import CompiledQp
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.plant.codegen import compiled_library
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENT = Path(__file__).parents[1] / "figure8.toml"

TIMING_C = """\
#include <time.h>
#include "{prefix}.h"

/* Replay `steps` recorded steps (row-major: step k's q at q + k n, ...; P's or A's values absent where has_* is 0)
   through {prefix}_solve, each timed with the monotonic clock. */
int {prefix}_time_steps(int steps, const double *q, const double *l, const double *u, const double *p,
                        const int *has_p, const double *a, const int *has_a, double *seconds, int *iterations)
{{
    static double z[{macro}_N_VARIABLES], y[{macro}_N_CONSTRAINTS];
    {prefix}_info info;
    struct timespec t0, t1;
    int k;
    const int n = {macro}_N_VARIABLES, m = {macro}_N_CONSTRAINTS;
    const int n_p = {macro}_N_P_VARYING, n_a = {macro}_N_A_VARYING;

    for (k = 0; k < steps; ++k) {{
        clock_gettime(CLOCK_MONOTONIC, &t0);
        {prefix}_solve(q + (long)k * n, l + (long)k * m, u + (long)k * m, has_p[k] ? p + (long)k * n_p : 0,
                       has_a[k] ? a + (long)k * n_a : 0, z, y, &info);
        clock_gettime(CLOCK_MONOTONIC, &t1);
        seconds[k] = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
        iterations[k] = info.iterations;
        if (info.error) {{
            return info.error;
        }}
    }}
    return 0;
}}
"""


class Recording:
    """The controller's OSQP solver, recording every call in order."""

    def __init__(self, solver: Any) -> None:
        self.solver = solver
        self.events: list[tuple[str, Any]] = []

    def update(self, **arguments: Any) -> None:
        self.events.append(("update", {k: np.array(v) for k, v in arguments.items()}))
        self.solver.update(**arguments)

    def warm_start(self, x: Any, y: Any) -> None:
        self.events.append(("warm_start", (np.array(x), np.array(y))))
        self.solver.warm_start(x=x, y=y)

    def update_settings(self, **settings: Any) -> None:
        self.events.append(("rho", float(settings["rho"])))
        self.solver.update_settings(**settings)

    def solve(self, raise_error: bool = False) -> Any:
        self.events.append(("solve", None))
        return self.solver.solve(raise_error=raise_error)


def record(experiment: Any) -> tuple[Recording, LtvMpcController, tuple[Any, ...]]:
    """Run the closed loop with the MPC's solver recorded; the QP's data as OSQP was set up with it."""
    controller = LtvMpcController(experiment.controller_vehicle, experiment.spec.controller.pose_settings)
    qp = controller._qp
    setup = (qp.P.copy(), qp.q.copy(), qp.A.copy(), qp.lower.copy(), qp.upper.copy())
    recording = Recording(controller._solver)
    controller._solver = recording
    run_experiment(experiment, pose_controller=controller)
    return recording, controller, setup


def split(events: list[tuple[str, Any]]) -> tuple[list[tuple[str, Any]], list[dict[str, Any]]]:
    """The events before the first update (the reset), and each step's update (each followed by one solve)."""
    first = next(i for i, (kind, _) in enumerate(events) if kind == "update")
    steps = events[first:]
    if [kind for kind, _ in steps] != ["update", "solve"] * (len(steps) // 2):
        raise SystemExit("the recorded run warm-starts or changes rho between steps (a solver failure?): not replayed")
    return events[:first], [arguments for kind, arguments in steps if kind == "update"]


class CAlone:
    """The generated solver called in C over all the steps of a pass, with a small timing file compiled beside it
    (its own library, so its own workspace)."""

    def __init__(self, code: QpC, steps: list[dict[str, Any]]) -> None:
        timing = {"bench_timing.c": TIMING_C.format(prefix=code.prefix, macro=code.prefix.upper())}
        flags = (*STRICT_C_FLAGS, "-D_POSIX_C_SOURCE=199309L", "-fPIC", "-shared")
        lib = compiled_library({**code.files, **timing}, f"{code.prefix}_timing", flags=flags)
        self._run = getattr(lib, f"{code.prefix}_time_steps")
        self._run.argtypes = [ctypes.c_int, *[ctypes.c_void_p] * 9]
        self._set_rho = getattr(lib, f"{code.prefix}_set_rho")
        self._set_rho.argtypes = [ctypes.c_double]
        self._warm_start = getattr(lib, f"{code.prefix}_warm_start")
        self._warm_start.argtypes = [ctypes.c_void_p] * 2
        self.k = k = len(steps)
        self.data = (
            np.array([s["q"] for s in steps]),
            np.array([s["l"] for s in steps]),
            np.array([s["u"] for s in steps]),
            np.array([s.get("Px", np.zeros(code.n_p_varying)) for s in steps]),
            np.array([int("Px" in s) for s in steps], dtype=np.intc),
            np.array([s.get("Ax", np.zeros(code.n_a_varying)) for s in steps]),
            np.array([int("Ax" in s) for s in steps], dtype=np.intc),
            np.empty(k),
            np.empty(k, dtype=np.intc),
        )

    def run(self, reset: list[tuple[str, Any]]) -> tuple[list[float], list[int]]:
        """One pass from ``reset``: each step's nanoseconds and iterations."""
        for kind, value in reset:
            if kind == "warm_start":
                self._warm_start(value[0].ctypes.data, value[1].ctypes.data)
            else:
                self._set_rho(value)
        if self._run(self.k, *(x.ctypes.data for x in self.data)):
            raise SystemExit("the generated solver failed in C")
        seconds, iterations = self.data[-2], self.data[-1]
        return (seconds * 1e9).tolist(), iterations.tolist()


def interleaved(
    solvers: tuple[Any, CompiledQp], reset: list[tuple[str, Any]], steps: list[dict[str, Any]]
) -> tuple[dict[str, list[int]], dict[str, list[int]]]:
    """One pass, step by step: each step's nanoseconds and iterations in the Python solver and in the C one
    through ctypes."""
    python, c = solvers
    times: dict[str, list[int]] = {"python": [], "c_ctypes": []}
    iterations: dict[str, list[int]] = {"python": [], "c_ctypes": []}
    clock = time.perf_counter_ns
    for kind, value in reset:
        if kind == "warm_start":
            python.warm_start(x=value[0], y=value[1])
            c.warm_start(*value)
        else:
            python.update_settings(rho=value)
            c.set_rho(value)
    for s in steps:
        t0 = clock()
        python.update(**s)
        result = python.solve(raise_error=False)
        t1 = clock()
        solution = c.solve(s["q"], s["l"], s["u"], s.get("Px"), s.get("Ax"))
        t2 = clock()
        times["python"].append(t1 - t0)
        times["c_ctypes"].append(t2 - t1)
        iterations["python"].append(result.info.iter)
        iterations["c_ctypes"].append(solution.iterations)
    return times, iterations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="passes over the recorded steps")
    args = parser.parse_args()
    experiment = load_experiment(EXPERIMENT)
    recording, controller, (P, q, A, lower, upper) = record(experiment)
    reset, steps = split(recording.events)
    settings = controller.osqp_settings
    # the generated solvers start from the state of a solver just set up on the QP as the controller set it up
    qp = controller._qp
    qp.q[:], qp.lower[:], qp.upper[:] = q, lower, upper
    python = osqp.OSQP()
    python.setup(P, q, A, lower, upper, **settings)
    code = generate_qp_c(qp, settings, origin=f"{EXPERIMENT.name} (benchmark)", generator="agvctl benchmark")
    solvers = (python, CompiledQp(code))
    alone = CAlone(code, steps)
    times: dict[str, list[float]] = {"python": [], "c_ctypes": [], "c_alone": []}
    for i in range(args.repeat):  # the passes alternate, so that all three see the same machine load
        pass_times, pass_iterations = interleaved(solvers, reset, steps)
        pass_times["c_alone"], pass_iterations["c_alone"] = alone.run(reset)
        for name, values in pass_times.items():
            times[name] += values
        if i == 0:
            iterations = pass_iterations
    median = {k: statistics.median(v) / 1e3 for k, v in times.items()}
    p99 = {k: float(np.percentile(v, 99)) / 1e3 for k, v in times.items()}
    print(f"QP update and solve over {len(steps)} steps of {EXPERIMENT.name} x {args.repeat} passes:")
    for name, label in (("python", "Python OSQP"), ("c_ctypes", "C via ctypes"), ("c_alone", "C, timed in C")):
        print(f"  {label:<14} median {median[name]:7.2f} µs   p99 {p99[name]:7.2f} µs")
    print(f"  ratio   Python / C via ctypes {median['python'] / median['c_ctypes']:.2f}x")
    print(f"  ratio   Python / C timed in C {median['python'] / median['c_alone']:.2f}x")
    same = iterations["python"] == iterations["c_ctypes"] == iterations["c_alone"]
    total = sum(iterations["python"])
    print(f"  first pass: {total} ADMM iterations in Python; the same on every step in C: {same}")


if __name__ == "__main__":
    main()
