"""What ``--html`` costs a check: ``agvctl check experiments/*.toml`` timed with and without ``--html``, and the
page's size.

The goals: the page adds at most 20 % to the check's wall time, and the page of the shipped experiments stays under
5 MB. Each variant runs ``--repeats`` times, alternating, in a fresh process as CI runs it; the fastest of each is
compared (the machine's other load only ever adds time). The CPU time of the check and its workers is printed
beside it: on a shared machine it varies less with the others' load than the wall time does. Exit 1 when a goal
is missed.

Run:  python experiments/benchmarks/html_report.py [--jobs N] [--repeats R]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXPERIMENTS = sorted(str(p) for p in (Path(__file__).resolve().parent.parent).glob("*.toml"))
TIME_GOAL = 1.20
"""The check's wall time with ``--html`` over its time without, at most."""
SIZE_GOAL_BYTES = 5_000_000


def _cpu_s() -> float:
    """The CPU time (s) of this process's finished children and theirs (the check's workers)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _check(jobs: int, out: Path, html: bool) -> tuple[float, float]:
    """The wall time and CPU time (s) of one ``agvctl check`` of the shipped experiments, in a new process."""
    argv = [sys.executable, "-m", "agvctl", "check", *EXPERIMENTS, "--jobs", str(jobs), "--json", str(out / "r.json")]
    if html:
        argv += ["--html", str(out / "report.html")]
    t0, cpu0 = time.perf_counter(), _cpu_s()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    elapsed, cpu = time.perf_counter() - t0, _cpu_s() - cpu0
    if done.returncode not in (0, 1):
        raise SystemExit(f"agvctl check failed ({done.returncode}): {done.stderr.strip()}")
    return elapsed, cpu


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes (default: all)")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each variant (default 3)")
    args = parser.parse_args()
    times: dict[bool, list[float]] = {False: [], True: []}
    cpu: dict[bool, list[float]] = {False: [], True: []}
    with tempfile.TemporaryDirectory(prefix="agvctl-html-bench-") as tmp:
        out = Path(tmp)
        for _ in range(args.repeats):
            for html in (False, True):
                wall_s, cpu_s = _check(args.jobs, out, html)
                times[html].append(wall_s)
                cpu[html].append(cpu_s)
        size = (out / "report.html").stat().st_size
    plain, paged = min(times[False]), min(times[True])
    ratio = paged / plain
    print(f"agvctl check of {len(EXPERIMENTS)} shipped experiments, --jobs {args.jobs}, fastest of {args.repeats}:")
    for label, html in (("without --html", False), ("with --html   ", True)):
        all_s = ", ".join(f"{t:.1f}" for t in times[html])
        print(f"  {label}  {min(times[html]):7.1f} s   (all: {all_s}; CPU {min(cpu[html]):.1f} s)")
    print(f"  ratio           {ratio:7.3f}     goal <= {TIME_GOAL:.2f}: {'met' if ratio <= TIME_GOAL else 'MISSED'}")
    print(f"  CPU time ratio  {min(cpu[True]) / min(cpu[False]):7.3f}")
    met_size = size < SIZE_GOAL_BYTES
    verdict = "met" if met_size else "MISSED"
    print(f"  page size       {size / 1e6:7.2f} MB  goal < {SIZE_GOAL_BYTES / 1e6:.0f} MB: {verdict}")
    return 0 if ratio <= TIME_GOAL and met_size else 1


if __name__ == "__main__":
    sys.exit(main())
