"""Benchmark of ``agvctl tune --pose``: the search of the MPC's settings on the heavy-load envelope.

Runs :func:`agvctl.tuning.tune_pose` on ``experiments/fuzz/heavy.toml`` (60 trials over its 40 training scenarios,
validated on 200 scenarios of another seed) with ``--jobs`` spawned worker processes, in a fresh in-memory study.
The peer, measured in the same run first: one fuzz of the same 40 training scenarios with the defaults, the cost
of one trial without pruning. The ratio search / (trials × peer) shows what pruning and the shared executor save.
Goal: 60 trials × 40 scenarios, the validation included, in ≤ 15 minutes with 2 jobs on a 2-core machine.

Run:  python experiments/benchmarks/pose_tuning.py [--jobs 2] [--trials 60] [--controller mpc]
      [--scenarios 40] [--validation-scenarios 200]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config
from agvctl.tuning import summary_text, tune_pose

CONFIG = Path(__file__).resolve().parent.parent / "fuzz" / "heavy.toml"
GOAL_S = 15 * 60.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--controller", default="mpc")
    ap.add_argument("--scenarios", type=int, default=None, help="training scenarios (default: the file's 40)")
    ap.add_argument("--validation-scenarios", type=int, default=200)
    args = ap.parse_args()

    spec = override_fuzz_config(load_fuzz_config(CONFIG), scenarios=args.scenarios, controllers=[args.controller])
    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
    t0 = time.perf_counter()
    fuzz(spec, jobs=args.jobs)
    peer = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = tune_pose(spec, trials=args.trials, validation_scenarios=args.validation_scenarios, jobs=args.jobs)
    wall = time.perf_counter() - t0
    counts = result.trial_counts()
    runs = args.trials * spec.scenarios + 2 * args.validation_scenarios
    print(
        f"pose tuning benchmark: {args.controller}, {args.trials} trials × {spec.scenarios} scenarios, "
        f"validation {args.validation_scenarios} × 2, jobs {args.jobs} (load average at the start {load})"
    )
    print(f"  peer: one fuzz of the {spec.scenarios} training scenarios   {peer:7.1f} s")
    print(
        f"  search and validation                          {wall:7.1f} s  ({counts['complete']} finished, "
        f"{counts['pruned']} pruned; at most {runs} runs)"
    )
    print(f"  ratio search / ({args.trials} × peer)                  {wall / (args.trials * peer):7.3f}")
    goal = GOAL_S * args.trials / 60 * spec.scenarios / 40
    print(f"  goal ≤ {goal:.0f} s: {'met' if wall <= goal else 'NOT met'}")
    print(summary_text(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
