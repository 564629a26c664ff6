"""Benchmark of ``agvctl falsify``: the search's own time against the time of the runs it proposes.

Runs :func:`agvctl.falsify.falsify` on ``experiments/fuzz/acceptance.toml`` with the default controller, one job
(every run in this process, one after another, so the search's time is the wall time less the runs' own), batches of
4 and no stop at a falsification. The overhead is everything that is not a run: TPE's proposals and the local
moves, drawing and writing the scenario files, the journal, the importances. Goal: overhead ≤ 10 % of the runs'
own time.

Run:  python experiments/benchmarks/falsify.py [--budget 100] [--seed 1]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from agvctl.falsify import falsify
from agvctl.fuzz.spec import load_fuzz_config

CONFIG = Path(__file__).resolve().parent.parent / "fuzz" / "acceptance.toml"
GOAL_RATIO = 0.10


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--budget", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    spec = load_fuzz_config(CONFIG)
    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
    with tempfile.TemporaryDirectory(prefix="agvctl-falsify-bench-") as tmp:
        t0 = time.perf_counter()
        result = falsify(
            spec,
            budget_runs=args.budget,
            seed=args.seed,
            controller="mpc",
            jobs=1,
            stop_at_first=False,
            storage=Path(tmp) / "search.journal",
        )
        wall_s = time.perf_counter() - t0
    runs_s = result.run_time_s
    ratio = (wall_s - runs_s) / runs_s
    print(f"falsify {spec.name}: {len(result.runs)} runs, seed {args.seed}, 1 job (load before: {load})")
    print(f"  wall {wall_s:.1f} s, the runs' own {runs_s:.1f} s, the search's {wall_s - runs_s:.1f} s")
    print(f"  overhead ratio {ratio:.3f} (goal <= {GOAL_RATIO:.2f}): {'met' if ratio <= GOAL_RATIO else 'NOT met'}")
    return 0 if ratio <= GOAL_RATIO else 1


if __name__ == "__main__":
    sys.exit(main())
