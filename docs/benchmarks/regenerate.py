"""Regenerate ``docs/benchmarks/results.md`` from the benchmark scripts in ``experiments/benchmarks/``.

Each script runs in a subprocess of this interpreter; its standard output goes into the page verbatim, under the
command that produced it, the date and the machine. The tables are never edited by hand: run this again instead.

    python docs/benchmarks/regenerate.py            # the quick settings below (a few minutes)
    python docs/benchmarks/regenerate.py --full     # each script's own defaults (much longer)
    python docs/benchmarks/regenerate.py --only plant,mpc   # those sections again, the others kept

The docs build does not run the benchmarks; it shows the committed results file.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(__file__).resolve().parent / "results.md"

# TOPP-RA is the planning benchmark's optional peer (the bench extra): skipped when it is not installed.
NO_TOPPRA = [] if importlib.util.find_spec("toppra") else ["--no-toppra"]

_FUZZ_C = ["--controllers", "ramsete_c", "--wheel-loops", "pi_c", "--goal-s", "15", "--peer", "ramsete,pi"]

# name: (script, quick arguments, full arguments, what it measures)
BENCHMARKS: dict[str, tuple[str, list[str], list[str], str]] = {
    "plant": ("plant.py", ["--quick"], [], "The open-loop simulator against python-control, and a batch."),
    "planning": (
        "planning.py",
        ["--repeat", "20", *NO_TOPPRA],
        NO_TOPPRA,
        "Planning times, durations against TOPP-RA.",
    ),
    "closed_loop": ("closed_loop.py", ["--repeat", "2"], [], "The closed loop on the figure-8 with the OSQP MPC."),
    "mpc": ("mpc.py", ["--repeat", "1"], [], "The OSQP MPC, the CasADi NMPC and do-mpc on one tracking problem."),
    "baselines": ("baselines.py", [], [], "Ramsete and the LTV unicycle law against the MPC."),
    "estimation": ("estimation.py", ["--repeat", "2"], [], "EKF, Kalman wheel speeds, sensors, loop on estimates."),
    "shipped": ("shipped.py", [], [], "The shipped experiments, each run once as `agvctl run` runs it."),
    "fuzz": ("fuzz.py", ["--scenarios", "40"], [], "The scenario fuzzer on local worker processes."),
    "fuzz_c": (
        "fuzz.py",
        _FUZZ_C,
        _FUZZ_C,
        "The scenario fuzzer with a compiled pose controller and wheel loops (the loop in C), against the same laws "
        "in Python.",
    ),
    "cascade_c": (
        "cascade_c.py",
        ["--repeat", "2"],
        [],
        "A unicycle cascade's step in Python and as generated C; the figure-8 loop with it, in Python and in C.",
    ),
    "cli_startup": (
        "cli_startup.py",
        ["--commands"],
        ["--commands"],
        "The command line's start: `agvctl --help` against the bare interpreter, and each command's help.",
    ),
    "pose_tuning": (
        "pose_tuning.py",
        ["--trials", "6", "--scenarios", "8", "--validation-scenarios", "8"],
        [],
        "The search of the MPC's settings on the heavy-load envelope (`agvctl tune --pose`).",
    ),
}


def machine() -> str:
    """One line naming the machine: processor, cores, Python and the operating system."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, Python {platform.python_version()}, {platform.system()} {platform.release()}"
    )


def run_one(name: str, full: bool) -> str:
    """Run one benchmark and return its section of the page."""
    script, quick_args, full_args, what = BENCHMARKS[name]
    args = full_args if full else quick_args
    command = " ".join(["python", f"experiments/benchmarks/{script}", *args])
    started = datetime.datetime.now(datetime.UTC)
    load = " ".join(f"{x:.1f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "unknown"
    t0 = time.perf_counter()
    done = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "benchmarks" / script), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    wall_s = time.perf_counter() - t0
    output = done.stdout.rstrip() or "(no output)"
    if done.returncode != 0:
        output += f"\n\n(exit code {done.returncode})\n" + done.stderr.strip()[-2000:]
    return (
        f"## {name}\n\n{what}\n\n"
        f"- command: `{command}`\n"
        f"- date: {started:%Y-%m-%d %H:%M} UTC, {wall_s:.0f} s; load average at the start {load} (1, 5, 15 min)\n\n"
        f"```text\n{output}\n```\n"
    )


def existing_sections() -> dict[str, str]:
    """The sections of the results page as it is, by benchmark name (empty if there is no page yet)."""
    if not OUT.exists():
        return {}
    sections: dict[str, str] = {}
    for chunk in OUT.read_text(encoding="utf-8").split("\n## ")[1:]:
        name = chunk.split("\n", 1)[0].strip()
        if name in BENCHMARKS:
            sections[name] = "## " + chunk.rstrip("\n") + "\n"
    return sections


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--full", action="store_true", help="each script's own defaults instead of the quick settings")
    ap.add_argument("--only", default=None, help="comma-separated benchmark names (default: all)")
    args = ap.parse_args()
    names = args.only.split(",") if args.only else list(BENCHMARKS)
    unknown = sorted(set(names) - set(BENCHMARKS))
    if unknown:
        ap.error(f"--only: no benchmark named {', '.join(unknown)} (known: {', '.join(BENCHMARKS)})")
    kept = existing_sections() if args.only else {}  # --only replaces its sections and keeps the others
    for name in names:
        print(f"running {name} ...", file=sys.stderr, flush=True)
        kept[name] = run_one(name, args.full)
    sections = [kept[name] for name in BENCHMARKS if name in kept]
    mode = "each script's own settings" if args.full else "the quick settings of `regenerate.py` (fewer repeats)"
    if args.only:  # sections kept from earlier runs may have been run with the other settings
        mode = "the settings each section's command shows"
    header = (
        "# Benchmark results\n\n"
        "Written by `python docs/benchmarks/regenerate.py`; do not edit by hand. "
        f"Run with {mode}.\n\n"
        f"- machine: {machine()}\n\n"
        "The machine may be shared with other work: a load average above the number of cores means the benchmarks "
        "competed for them, and their timings are then slower than on a quiet machine, by up to several times.\n\n"
    )
    OUT.write_text(header + "\n".join(sections), encoding="utf-8")
    print(f"wrote {OUT}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
