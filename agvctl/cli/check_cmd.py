"""``agvctl check``: run experiments and enforce their limits — a CI gate.

Every run is accounted for: a run that raises (the product's code or a user's controller) is that experiment's
error, and every other experiment is still run and reported; the JUnit XML, JSON and HTML page are always
written. Exit codes:

* 0 — every run completed and every limit held;
* 1 — a limit was violated (every run completed);
* 2 — bad input: a file, key or flag that cannot be used (one line on stderr; nothing is run, nothing written);
* 3 — a run could not be completed (it raised): an ``<error>`` in the JUnit XML, ``"completed": false`` in the
  JSON; this wins over 1;
* 130 — interrupted (Ctrl-C): one line on stderr; no output is left half-written.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path
from typing import Any

from agvctl.checks.junit import junit_xml
from agvctl.checks.report import CheckReport, closest_to_failing
from agvctl.checks.runner import check_experiments, load_check
from agvctl.cli.commands import command_summary
from agvctl.cli.outputs import Output, check_outputs, writing
from agvctl.cli.progress import Progress
from agvctl.cli.staging import check_replaceable, staged_outputs
from agvctl.errors import ConfigError
from agvctl.htmlreport import check_html, check_run_figures
from agvctl.plots import save_metric_histograms

EXIT_PASSED, EXIT_VIOLATED, EXIT_RUN_ERROR = 0, 1, 3
"""The exit codes of a check that ran (2, bad input, is the CLI's for every command)."""

EXIT_CODES = """exit codes:
  0  every run completed and every limit held
  1  a limit was violated
  2  bad input (one line on stderr naming the file or flag; nothing is run or written)
  3  a run could not be completed (it raised): reported as an <error> in the JUnit XML and
     "completed": false in the JSON, every other run still reported; wins over 1
  130  interrupted (Ctrl-C): one line on stderr, no partial output, the workers stopped"""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "check",
        help=command_summary("check"),
        description="Run each experiment (and its [robustness] Monte Carlo samples), check every limit, report. "
        "A run that raises is its experiment's error; every other run is still run and reported.",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("experiments", nargs="+", metavar="EXPERIMENT.toml")
    p.add_argument("--junit", metavar="FILE", help="write JUnit XML: one test case per experiment and limit")
    p.add_argument("--json", metavar="FILE", dest="json_out", help="write the same results as JSON")
    p.add_argument(
        "--html", metavar="FILE", help="write one self-contained HTML page: every verdict beside its run's plots"
    )
    p.add_argument(
        "--margins",
        type=int,
        nargs="?",
        const=10,
        default=None,
        metavar="N",
        help="after the report, list the N limits and requirements closest to failing, by margin over bound "
        "(default 10)",
    )
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="local worker processes (default: all cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="where the runs go (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument(
        "--report-dir",
        metavar="DIR",
        help="histogram PNGs of every metric of Monte Carlo runs, the folder replaced whole (default: out/check)",
    )
    p.set_defaults(func=run)


def format_report(report: CheckReport) -> str:
    lines = []
    for exp in report.experiments:
        runs = len(exp.outcomes)
        status = "ERROR" if not exp.completed else "PASS" if exp.passed else "FAIL"
        head = f"{status}  {exp.name}  ({exp.path}"
        head += f", {runs} Monte Carlo samples)" if exp.monte_carlo else ")"
        lines.append(head)
        for o in exp.errors:
            which = "the run" if o.task.sample is None else f"sample {o.task.sample}"
            lines.append(f"    ERROR  {which} could not be completed: {o.error}")
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
    n_error = sum(not e.completed for e in report.experiments)
    errors = f" ({n_error} with runs that could not be completed)" if n_error else ""
    lines.append(
        f"{len(report.experiments) - n_fail} of {len(report.experiments)} experiments passed{errors} "
        f"in {report.wall_time_s:.1f} s"
    )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise ConfigError("--scheduler", "", "only with --executor dask")
    if args.margins is not None and args.margins < 1:
        raise ConfigError("--margins", "", f"must be >= 1 (got {args.margins})")
    t0 = time.perf_counter()
    work = load_check(args.experiments)  # every file validated, every output checked: then the runs
    named = (("--junit", args.junit), ("--json", args.json_out), ("--html", args.html))
    outputs = [Output(flag, Path(name)) for flag, name in named if name]
    report_dir = Path(args.report_dir or "out/check")
    monte_carlo = any(len(tasks) > 1 or tasks[0].sample is not None for tasks in work.tasks)
    check_outputs(outputs, work.input_files, [("--report-dir", report_dir)] if monte_carlo else [])
    if monte_carlo:
        check_replaceable("--report-dir", report_dir, work.input_files)
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    with Progress("check") as progress:
        report = check_experiments(
            work,
            jobs=jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            progress=progress,
            render=check_run_figures if args.html else None,
            t0=t0,
        )
    # everything is computed before anything is written
    texts = {"--junit": junit_xml(report), "--json": json.dumps(report.as_dict(), indent=2) + "\n"}
    if args.html:
        texts["--html"] = check_html(report)
    written = [str(out.path) for out in outputs]
    with staged_outputs("check") as staging:  # every output moved into place once all are written
        if report.monte_carlo:
            staged = staging.directory("--report-dir", report_dir)
            with writing("--report-dir", report_dir):
                histograms = save_metric_histograms(report, staged)
            written.append(f"{report_dir}/ ({len(histograms)} histograms)")
        for out in outputs:
            staging.write_text(out.flag, out.path, texts[out.flag])
    print(format_report(report))
    if args.margins is not None:
        print(format_margins(report, args.margins))
    if written:
        print(f"wrote {', '.join(written)}")
    return exit_code(report)


def format_margins(report: CheckReport, count: int) -> str:
    """The ``--margins`` list: :func:`~agvctl.checks.report.closest_to_failing`, one line each."""
    rows = closest_to_failing(report, count)
    lines = [
        f"closest to failing ({len(rows)} of {sum(len(e.verdicts) for e in report.experiments)}, by margin over bound):"
    ]
    for name, v in rows:
        lines.append(f"  {v.normalised_margin:+8.3g}  {name}  {v.message}")
    return "\n".join(lines)


def exit_code(report: CheckReport) -> int:
    """3 when a run could not be completed, else 1 when a limit was violated, else 0."""
    if not report.completed:
        return EXIT_RUN_ERROR
    return EXIT_PASSED if report.passed else EXIT_VIOLATED
