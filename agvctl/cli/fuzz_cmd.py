"""``agvctl fuzz``: random scenarios through the closed loop with one or more pose controllers, against limits.

Exit 0 when every run of every controller passes, 1 when any fails (its files are written out, ready for
``agvctl run``), 2 on bad input (one line naming the file and key; nothing is run), 3 when any run could not be
completed — it raised, or its log or metrics hold a non-finite value — reported as an ``<error>`` in the JUnit XML
and an ``error`` in the JSON, every other run still reported (as ``agvctl check``'s 3; it wins over 1).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

from agvctl.checks.runner import resolved_jobs
from agvctl.cli.commands import command_summary
from agvctl.cli.outputs import Output, check_outputs, files_in, vehicle_input, writing
from agvctl.cli.progress import Progress
from agvctl.cli.staging import check_replaceable, staged_outputs
from agvctl.errors import ConfigError
from agvctl.evaluation.limits import LIMITS
from agvctl.fuzz.report import FUZZ_METRICS, FuzzOutcome, FuzzReport
from agvctl.fuzz.run import FuzzRun, fuzz_tasks, run_fuzz
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config
from agvctl.htmlreport import fuzz_html
from agvctl.plots import save_fuzz_plot

__all__ = ["format_fuzz_report", "register", "run"]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "fuzz",
        help=command_summary("fuzz"),
        description="Draw random scenarios from a fuzz configuration's seed (paths of lines, arcs and turns; default "
        "or explicit limits; a plant within an envelope; an off-path start), run each with every pose controller "
        "listed, report per controller and write every failing scenario as a ready-to-run experiment file. "
        "Exit 0 when all pass, 1 when any fails, 2 on bad input, 3 when any run could not be completed "
        "(it raised or broke down numerically: a JUnit <error>; wins over 1).",
    )
    p.add_argument("config", metavar="FUZZ.toml")
    p.add_argument("--out", metavar="DIR", help="output directory, replaced whole (default: out/fuzz/<name>)")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="local worker processes (default: all cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="where the runs go (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument("--junit", metavar="FILE", help="write JUnit XML: one test case per scenario and controller")
    p.add_argument(
        "--html", metavar="FILE", help="write one self-contained HTML page: counts, distributions, the worst runs"
    )
    p.add_argument("--seed", type=int, default=None, help="instead of the file's seed")
    p.add_argument("--scenarios", type=int, default=None, metavar="N", help="instead of the file's number")
    p.add_argument("--controllers", metavar="A,B", help="instead of the file's pose controllers (comma-separated)")
    p.add_argument(
        "--only", metavar="I,J", help="run only these scenario indices (comma-separated), each as in the full run"
    )
    p.add_argument("--no-plot", action="store_true", help="skip fuzz.png")
    p.set_defaults(func=run)


def _value(metric: str, value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return "—"
    unit = LIMITS[metric].unit if metric in LIMITS else ""
    return f"{value:.4g}{unit}"


def _worst_line(outcome: FuzzOutcome) -> str:
    """``cross-track 0.43 m  final 0.2 m  heading 178°  (violated: a, b)``, or the crash."""
    if outcome.error is not None:
        return f"crashed: {outcome.error}"
    shown = {"cross-track": "cross_track_error_max_m", "final": "final_position_error_m"}
    text = "  ".join(f"{label} {_value(m, outcome.value(m))}" for label, m in shown.items())
    text += f"  heading {_value('path_heading_error_max_deg', outcome.value('path_heading_error_max_deg'))}"
    violated = [r.limit for r in outcome.limits if not r.passed or math.isnan(r.value)]
    return text + f"  (violated: {', '.join(violated)})"


def format_fuzz_report(report: FuzzReport, worst: int = 5) -> str:
    """The readable report: per controller the pass count, percentiles, the worst scenarios; comparisons."""
    spec = report.spec
    lines = [
        f"fuzz {spec.name}: {len({t.scenario for t in report.tasks})} scenarios (seed {spec.seed}) × "
        f"{', '.join(spec.controllers)}: {len(report.outcomes)} runs in {report.wall_time_s:.1f} s"
    ]
    stats = report.statistics()
    for c in spec.controllers:
        s = stats[c]
        lines.append(
            f"{'PASS' if s['failed'] == 0 else 'FAIL'}  {c}: {s['passed']} of {s['runs']} passed, "
            f"{s['failed']} failed ({s['crashed']} crashed)"
        )
        lines.append(f"    {'metric':<28}" + "".join(f"{h:>12}" for h in ("p50", "p90", "p99", "max")))
        for m in FUZZ_METRICS:
            lines.append(f"    {m:<28}" + "".join(f"{_value(m, s[m][h]):>12}" for h in ("p50", "p90", "p99", "max")))
        bad = [o for o in report.worst(c, worst) if not o.passed]
        if bad:
            lines.append("    worst:")
        names = {(t.scenario, t.controller): t for t in report.tasks}
        for o in bad:
            lines.append(f"      {names[(o.scenario, o.controller)].files[-1][0]}  {_worst_line(o)}")
    for cmp in report.comparisons():
        frac, ratio = cmp["a_cross_track_max_le_b_fraction"], cmp["median_rms_ratio"]
        frac_text = "—" if frac is None else f"{100 * frac:.1f} %"
        ratio_text = "—" if ratio is None or not math.isfinite(ratio) else f"{ratio:.3g}"
        rms_a, rms_b = (_value("cross_track_error_rms_m", cmp[k]) for k in ("median_rms_a_m", "median_rms_b_m"))
        tol_mm = cmp["tolerance_m"] * 1e3
        lines.append(
            f"{cmp['a']} vs {cmp['b']}: {cmp['a']}'s max cross-track error within {tol_mm:g} mm of {cmp['b']}'s or "
            f"below in {frac_text} of {cmp['scenarios']} scenarios; median cross-track RMS {rms_a} vs {rms_b} "
            f"(ratio {ratio_text})"
        )
        above = cmp["a_cross_track_max_above_b"]
        if above:
            shown = ", ".join(f"s{spec.seed}_{i:05d}" for i in above[:8]) + (", …" if len(above) > 8 else "")
            lines.append(
                f"    {cmp['a']}'s max cross-track error above {cmp['b']}'s by more than {tol_mm:g} mm in: {shown}"
            )
    return "\n".join(lines)


def _indices(text: str) -> list[int]:
    """``"3,17"`` → ``[3, 17]``; anything else is a one-line error naming ``--only``."""
    try:
        indices = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise ConfigError("--only", "", f"expected scenario indices like 3,17 (got {text!r})") from None
    if not indices or min(indices) < 0:
        raise ConfigError("--only", "", f"expected scenario indices >= 0 (got {text!r})")
    return sorted(set(indices))


def _check_outputs(args: argparse.Namespace, work: FuzzRun, out_dir: Path) -> None:
    """Every file the run may write — the summary, the plot, each scenario's files should it fail, the JUnit XML —
    checked against the configuration and its vehicle before anything runs."""
    names = ["summary.json", *([] if args.no_plot else ["fuzz.png"])]
    outputs = files_in("--out", out_dir, names)
    failures = {name for task in work.tasks for name, _text in task.files}
    outputs += files_in("--out", out_dir / "failures", sorted(failures))
    outputs += [Output(flag, Path(name)) for flag, name in (("--junit", args.junit), ("--html", args.html)) if name]
    inputs = [Path(args.config), vehicle_input(work.spec.vehicle)]
    check_outputs(outputs, inputs, [("--out", out_dir)])
    check_replaceable("--out", out_dir, inputs)


def run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise ConfigError("--scheduler", "", "only with --executor dask")
    spec = load_fuzz_config(args.config)
    controllers = None if args.controllers is None else [c.strip() for c in args.controllers.split(",") if c.strip()]
    spec = override_fuzz_config(spec, seed=args.seed, scenarios=args.scenarios, controllers=controllers)
    only = _indices(args.only) if args.only is not None else None
    out_dir = Path(args.out) if args.out else Path("out") / "fuzz" / spec.name
    resolved_jobs(args.jobs, args.executor)
    t0 = time.perf_counter()  # the report's time counts the drawing of the scenarios, as fuzz() does
    work = fuzz_tasks(spec, only)
    _check_outputs(args, work, out_dir)
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    where = f"a Dask cluster ({args.scheduler or 'local'})" if args.executor == "dask" else f"{jobs} local jobs"
    print(f"fuzz {spec.name}: {len(work.tasks)} runs on {where}", file=sys.stderr, flush=True)
    with Progress("fuzz", unit="runs") as progress:
        report = run_fuzz(work, jobs=jobs, executor=args.executor, scheduler=args.scheduler, progress=progress, t0=t0)
    # everything is computed before anything is written
    texts = {out_dir / "summary.json": json.dumps(report.as_dict(), indent=2) + "\n"}
    failures = report.failure_files()
    texts.update({out_dir / "failures" / name: text for name, text in failures.items()})
    flags = {}
    if args.junit:
        texts[Path(args.junit)] = report.junit()
        flags[Path(args.junit)] = "--junit"
    if args.html:
        texts[Path(args.html)] = fuzz_html(report, failures_dir=out_dir / "failures")
        flags[Path(args.html)] = "--html"
    with staged_outputs("fuzz") as staging:  # the folder replaced whole, once every file is written
        staged = staging.directory("--out", out_dir)
        for path, text in texts.items():
            staging.write_text(flags.get(path, "--out"), path, text)
        written = [str(out_dir / "summary.json")]
        if not args.no_plot:
            with writing("--out", out_dir / "fuzz.png"):
                save_fuzz_plot(report, staged / "fuzz.png")
            written.append(str(out_dir / "fuzz.png"))
    print(format_fuzz_report(report))
    written += [name for name in (args.junit, args.html) if name]
    print(f"wrote {', '.join(written)}")
    if failures:
        first = next(t.files[-1][0] for t, o in zip(report.tasks, report.outcomes, strict=True) if not o.passed)
        n_fail = sum(not o.passed for o in report.outcomes)
        print(
            f"wrote {n_fail} failing runs as experiment files in {out_dir / 'failures'}; "
            f"reproduce one with: agvctl run {out_dir / 'failures' / first}"
        )
    if any(o.error is not None for o in report.outcomes):
        return 3
    return 0 if report.passed else 1
