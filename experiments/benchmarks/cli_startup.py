"""Benchmark of the command line's start: ``agvctl --help`` against ``python -c pass``, and each subcommand's help.

The goal: ``agvctl --help`` within 0.25 s of the bare interpreter's start (median of 10 runs each, measured in the
same run, interleaved, so both see the same load on the machine). ``agvctl COMMAND --help`` imports that command's
module and the libraries it uses, so it costs more; its medians are printed for reference.

Prints the two medians, their difference and whether the goal is met (exit 1 when not).

Run:  python experiments/benchmarks/cli_startup.py [--runs N] [--commands]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

GOAL_S = 0.25
ROOT = Path(__file__).resolve().parents[2]


def agvctl_command() -> list[str]:
    """The installed ``agvctl`` script when there is one, else ``python -m agvctl`` (the same entry point)."""
    script = shutil.which("agvctl", path=str(Path(sys.executable).parent)) or shutil.which("agvctl")
    return [script] if script else [sys.executable, "-m", "agvctl"]


def wall_s(argv: list[str], env: dict[str, str]) -> float:
    """The wall time of one run of ``argv`` to its exit (its output discarded)."""
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=True)
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10, help="runs of each (default 10)")
    ap.add_argument("--commands", action="store_true", help="also time `agvctl COMMAND --help` for every command")
    args = ap.parse_args()

    # this checkout's package first, as the tests run it
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}
    agvctl = agvctl_command()
    wall_s([*agvctl, "--help"], env)  # one run first, so the byte-code cache is written before the timed runs
    bare, help_ = [], []
    for _ in range(args.runs):
        bare.append(wall_s([sys.executable, "-c", "pass"], env))
        help_.append(wall_s([*agvctl, "--help"], env))
    bare_s, help_s = statistics.median(bare), statistics.median(help_)
    print(f"median of {args.runs} runs ({' '.join(Path(a).name for a in agvctl)})")
    print(f"  python -c pass          {bare_s:7.3f} s")
    print(f"  agvctl --help           {help_s:7.3f} s")
    print(f"  difference              {help_s - bare_s:7.3f} s   (goal: <= {GOAL_S:.2f} s)")
    met = help_s - bare_s <= GOAL_S
    print("  goal met" if met else "  goal NOT met")

    if args.commands:
        from agvctl.cli.commands import COMMANDS

        for name in COMMANDS:
            times = [wall_s([*agvctl, name, "--help"], env) for _ in range(max(3, args.runs // 3))]
            print(f"  agvctl {name + ' --help':<16} {statistics.median(times):7.3f} s")
    return 0 if met else 1


if __name__ == "__main__":
    sys.exit(main())
