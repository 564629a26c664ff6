"""What ``--html`` costs a check: ``agvctl check experiments/*.toml`` timed with and without ``--html``, and the
page's size.

The goals: the page adds at most 20 % to the check's wall time, and the page of the shipped experiments stays under
5 MB. Each variant runs ``--repeats`` times, alternating, in a fresh process as CI runs it; the fastest of each is
compared (the machine's other load only ever adds time). Exit 1 when a goal is missed.

Run:  python experiments/benchmarks/html_report.py [--jobs N] [--repeats R]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXPERIMENTS = sorted(str(p) for p in (Path(__file__).resolve().parent.parent).glob("*.toml"))
TIME_GOAL = 1.20
"""The check's wall time with ``--html`` over its time without, at most."""
SIZE_GOAL_BYTES = 5_000_000


def _check(jobs: int, out: Path, html: bool) -> float:
    """The wall time (s) of one ``agvctl check`` of the shipped experiments, in a new process."""
    argv = [sys.executable, "-m", "agvctl", "check", *EXPERIMENTS, "--jobs", str(jobs), "--json", str(out / "r.json")]
    if html:
        argv += ["--html", str(out / "report.html")]
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    elapsed = time.perf_counter() - t0
    if done.returncode not in (0, 1):
        raise SystemExit(f"agvctl check failed ({done.returncode}): {done.stderr.strip()}")
    return elapsed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: all)")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each variant (default 3)")
    args = parser.parse_args()
    times: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory(prefix="agvctl-html-bench-") as tmp:
        out = Path(tmp)
        for _ in range(args.repeats):
            for html in (False, True):
                times[html].append(_check(args.jobs, out, html))
        size = (out / "report.html").stat().st_size
    plain, paged = min(times[False]), min(times[True])
    ratio = paged / plain
    print(f"agvctl check of {len(EXPERIMENTS)} shipped experiments, --jobs {args.jobs}, fastest of {args.repeats}:")
    print(f"  without --html  {plain:7.1f} s   (all: {', '.join(f'{t:.1f}' for t in times[False])})")
    print(f"  with --html     {paged:7.1f} s   (all: {', '.join(f'{t:.1f}' for t in times[True])})")
    print(f"  ratio           {ratio:7.3f}     goal <= {TIME_GOAL:.2f}: {'met' if ratio <= TIME_GOAL else 'MISSED'}")
    met_size = size < SIZE_GOAL_BYTES
    verdict = "met" if met_size else "MISSED"
    print(f"  page size       {size / 1e6:7.2f} MB  goal < {SIZE_GOAL_BYTES / 1e6:.0f} MB: {verdict}")
    return 0 if ratio <= TIME_GOAL and met_size else 1


if __name__ == "__main__":
    sys.exit(main())
