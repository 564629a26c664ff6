"""Benchmark of the scenario fuzzer: the acceptance run's 500 scenarios on local worker processes.

Runs ``experiments/fuzz/acceptance.toml`` (500 scenarios; by default only its first controller, the default pose
controller, as the speed goal counts) through :func:`agvctl.fuzz.run.fuzz` with ``--jobs`` spawned worker
processes, and prints the wall time, scenarios/s and runs/s, the simulated time per wall second, and where a run's
time goes (the per-run wall time spent in the workers). Goal: the 500 scenarios in ≤ 4 min with 2 jobs on a
2-core machine (``--goal-s``: another, e.g. 15 s for the compiled laws below). With ``--qp-solver osqp_c`` (or
``osqp_c_float``), the LTV MPC's QP is solved by its generated C (``[controller] qp_solver``) in a second fuzz run
of the same scenarios, and the ratio of the two wall times is printed (the first, with OSQP in Python, the peer).

With ``--controllers ramsete_c --wheel-loops pi_c`` (or ``ltv_lqr_c``) every part of each run has a compiled step
and the closed loop runs in C (:mod:`agvctl.sim.compiled_loop`). ``--peer ramsete,pi`` also runs the same scenarios
with that pose controller and those wheel loops (here the same laws in Python) and prints the ratio of the wall times.

Run:  python experiments/benchmarks/fuzz.py [--jobs 2] [--scenarios 500] [--controllers mpc,ramsete]
                                            [--qp-solver osqp_c]  (with the LTV MPC, ``mpc``, alone)
                                            [--wheel-loops pi_c] [--peer ramsete,pi]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import FuzzSpec, load_fuzz_config, override_fuzz_config

CONFIG = Path(__file__).resolve().parent.parent / "fuzz" / "acceptance.toml"
GOAL_S = 240.0


def _timed(spec: FuzzSpec, jobs: int) -> tuple[float, int]:
    """The wall time of a fuzz of ``spec`` (s) and how many of its runs passed."""
    t0 = time.perf_counter()
    report = fuzz(spec, jobs=jobs)
    return time.perf_counter() - t0, sum(s["passed"] for s in report.statistics().values())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--scenarios", type=int, default=None, help="default: the configuration's 500")
    ap.add_argument("--controllers", default=None, help="comma-separated (default: the configuration's first)")
    ap.add_argument("--qp-solver", default=None, choices=("osqp_c", "osqp_c_float"), help="also with this solver")
    ap.add_argument("--wheel-loops", default=None, help='[controller] wheel_loops of every run (e.g. "pi_c")')
    ap.add_argument("--goal-s", type=float, default=GOAL_S, help="the goal for 500 scenarios of one controller, s")
    ap.add_argument("--peer", default=None, help='"POSE,WHEEL_LOOPS": the same scenarios with these, and the ratio')
    args = ap.parse_args()

    spec = load_fuzz_config(CONFIG)
    controllers = args.controllers.split(",") if args.controllers else [spec.controllers[0]]
    spec = override_fuzz_config(spec, scenarios=args.scenarios, controllers=controllers)
    if args.wheel_loops:
        spec = dataclasses.replace(spec, controller={**spec.controller, "wheel_loops": args.wheel_loops})
    t0 = time.perf_counter()
    report = fuzz(spec, jobs=args.jobs)
    wall = time.perf_counter() - t0
    if args.qp_solver:
        generated = dataclasses.replace(spec, controller={**spec.controller, "qp_solver": args.qp_solver})
        generated_wall, passed = _timed(generated, args.jobs)
        print(
            f"with qp_solver = {args.qp_solver!r}: wall time {generated_wall:.1f} s, {passed} of "
            f"{len(report.outcomes)} runs passed; ratio to OSQP in Python {generated_wall / wall:.2f}"
        )
    runs = len(report.outcomes)
    simulated = sum(o.simulated_s for o in report.outcomes)
    per_run = [o.wall_time_s for o in report.outcomes]
    print(f"fuzz benchmark: {spec.scenarios} scenarios × {', '.join(spec.controllers)} = {runs} runs, jobs {args.jobs}")
    print(f"  wall time        {wall:.1f} s   ({spec.scenarios / wall:.2f} scenarios/s, {runs / wall:.2f} runs/s)")
    print(f"  simulated        {simulated:.0f} s ({simulated / wall:.0f} s simulated per wall second)")
    print(
        f"  per run          median {statistics.median(per_run):.2f} s, max {max(per_run):.2f} s "
        f"(load, plan, loop, metrics in a worker)"
    )
    for c, s in report.statistics().items():
        print(f"  {c:<16} {s['passed']} of {s['runs']} passed ({s['crashed']} crashed)")
    goal = spec.scenarios / 500 * args.goal_s * len(spec.controllers)
    print(
        f"  goal             {spec.scenarios} scenarios × {len(spec.controllers)} in ≤ {goal:.0f} s: "
        f"{'met' if wall <= goal else 'NOT met'}"
    )
    if args.peer:
        pose, wheel_loops = args.peer.split(",")
        peer = override_fuzz_config(spec, controllers=[pose])
        peer_wall, passed = _timed(
            dataclasses.replace(peer, controller={**peer.controller, "wheel_loops": wheel_loops}), args.jobs
        )
        print(
            f"peer {pose} with {wheel_loops}: wall time {peer_wall:.1f} s, {passed} of {runs} runs passed; "
            f"ratio of this run to the peer {wall / peer_wall:.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
