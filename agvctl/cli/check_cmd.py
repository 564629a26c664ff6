"""``agvctl check``: run experiments and enforce their limits — a CI gate (exit 0 pass, 1 violated, 2 bad input)."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

from agvctl.checks.junit import junit_xml
from agvctl.checks.report import CheckReport
from agvctl.checks.runner import check_experiments
from agvctl.cli.progress import ProgressBar
from agvctl.errors import ConfigError
from agvctl.fileio import write_text
from agvctl.plots import save_metric_histograms


def register(sub: Any) -> None:
    p = sub.add_parser(
        "check",
        help="run experiments and enforce their [limits] (CI gate: exit 1 on a violation)",
        description="Run each experiment (and its [robustness] Monte Carlo samples), check every limit, report. "
        "Exit 0 when every limit holds, 1 when any is violated, 2 on bad input (nothing is run then).",
    )
    p.add_argument("experiments", nargs="+", metavar="EXPERIMENT.toml")
    p.add_argument("--junit", metavar="FILE", help="write JUnit XML: one test case per experiment and limit")
    p.add_argument("--json", metavar="FILE", dest="json_out", help="write the same results as JSON")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="local worker processes (default: all cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="where the runs go (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument(
        "--report-dir", metavar="DIR", help="histogram PNGs of every metric of Monte Carlo runs (default: out/check)"
    )
    p.set_defaults(func=run)


def format_report(report: CheckReport) -> str:
    lines = []
    for exp in report.experiments:
        runs = len(exp.outcomes)
        head = f"{'PASS' if exp.passed else 'FAIL'}  {exp.name}  ({exp.path}"
        head += f", {runs} Monte Carlo samples)" if exp.monte_carlo else ")"
        lines.append(head)
        for v in exp.verdicts:
            lines.append(f"    {'ok  ' if v.passed else 'FAIL'}  {v.message}")
        for name, c in (exp.consistency() or {}).items():
            lo, hi = c["interval_95"]
            verdict = "consistent" if c["inside"] else "INCONSISTENT"
            lines.append(
                f"    {name.split('_')[0].upper():4}  mean {c['value']:.3g} over {c['runs']} runs (3 dof; the 95 % "
                f"chi-square interval of an average over {c['runs']} runs: [{lo:.3g}, {hi:.3g}]) — {verdict}"
            )
    n_fail = sum(not e.passed for e in report.experiments)
    lines.append(
        f"{len(report.experiments) - n_fail} of {len(report.experiments)} experiments passed "
        f"in {report.wall_time_s:.1f} s"
    )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise ConfigError("--scheduler", "", "only with --executor dask")
    for name in (args.junit, args.json_out):
        if name and Path(name).is_dir():
            raise ConfigError(name, "", "is a directory; expected a file name")
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    bar = ProgressBar("check:")
    try:
        report = check_experiments(
            args.experiments,
            jobs=jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            progress=lambda done, total: bar(done / total),
        )
    finally:
        bar.close()
    # everything is computed before anything is written
    outputs: dict[str, str] = {}
    if args.junit:
        outputs[args.junit] = junit_xml(report)
    if args.json_out:
        outputs[args.json_out] = json.dumps(report.as_dict(), indent=2) + "\n"
    for path, text in outputs.items():
        write_text(path, text)
    if any(e.monte_carlo for e in report.experiments):
        save_metric_histograms(report, Path(args.report_dir or "out/check"))
    print(format_report(report))
    return 0 if report.passed else 1
