"""Planning time and path duration summed over every path file in a folder: the same files planned by two versions
of the package give the cost of a planner change (it uses only ``load_path`` and ``plan``, which every version has).

    PYTHONPATH=. python experiments/benchmarks/plan_folder.py DIR [--repeat 3]

Each file's planning time is the best of ``--repeat`` plans (the machine is shared; the best is the least disturbed).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from agvctl.params import load_vehicle
from agvctl.planning import load_path, plan


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    vehicle = load_vehicle()
    planning, duration, files = 0.0, 0.0, sorted(args.folder.glob("*.toml"))
    for file in files:
        spec = load_path(file)
        best = float("inf")
        for _ in range(args.repeat):
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ref = plan(spec, vehicle)
            best = min(best, time.perf_counter() - start)
        planning += best
        duration += ref.duration_s
    print(f"{len(files)} paths: planning {planning:.3f} s in all ({1e3 * planning / len(files):.1f} ms a path)")
    print(f"path duration {duration:.2f} s in all")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
