"""The page of a check: a summary table (failures first), then per experiment its limit table, its figure and its
resolved experiment file."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from agvctl.checks.report import CheckReport, ExperimentReport, LimitVerdict, RunOutcome
from agvctl.checks.runner import run_task
from agvctl.errors import expect_instance
from agvctl.fileio import write_text
from agvctl.htmlreport.figures import PANEL, check_run_figures
from agvctl.htmlreport.render import data_uri, limit_value, render_template, time_text
from agvctl.reports import resolved_experiment_toml
from agvctl.scenario.experiment import load_experiment

__all__ = ["check_html", "write_check_html"]

_ORDER = {"ERROR": 0, "FAIL": 1, "PASS": 2}


def _status(exp: ExperimentReport) -> str:
    return "ERROR" if not exp.completed else "PASS" if exp.passed else "FAIL"


def _shown_run(exp: ExperimentReport) -> RunOutcome | None:
    """The run whose figure the page shows: the nominal run, or of Monte Carlo samples the one that gave the
    verdict closest to (or furthest past) its bound, a violated one first; None when no run was completed."""
    completed = [o for o in exp.outcomes if o.error is None]
    if not completed:
        return None
    if not exp.monte_carlo or not exp.verdicts:
        return completed[0]
    scored = [v for v in exp.verdicts if v.bound > 0]
    if not scored:
        return completed[0]
    worst = max(scored, key=lambda v: (not v.passed, v.value / v.bound))
    return next((o for o in completed if o.task.sample == worst.sample), completed[0])


def _figure(outcome: RunOutcome) -> bytes | None:
    """The run's figure: drawn where it ran, or else by running it again here (None if that run fails)."""
    if PANEL in outcome.figures:
        return outcome.figures[PANEL]
    again = run_task(outcome.task, check_run_figures)
    return again.figures.get(PANEL)


def _with_unit(value: float, unit: str, *, signed: bool = False) -> str:
    """A value with its unit as the page shows it (``+∞``, ``−∞``; ``—`` for NaN)."""
    if math.isnan(value):
        return "—"
    if math.isinf(value):
        return "+∞" if value > 0 else "−∞"
    return f"{value:+.6g}{unit}" if signed else f"{value:.6g}{unit}"


def _limit_row(v: LimitVerdict) -> dict[str, Any]:
    sample = ""
    if not v.passed and v.sample is not None:
        params = ", ".join(f"{k} = {x:.6g}" for k, x in v.parameters.items())
        sample = f"sample {v.sample} of {v.runs} ({v.failed_runs} failed): {params}"
    unit = v.unit if v.kind == "requirement" else None
    window = (
        ""
        if v.window_s is None or not all(map(math.isfinite, v.window_s))
        else "[{:.2f}, {:.2f}] s".format(*v.window_s)
    )
    return {
        "passed": v.passed,
        "limit": v.limit,
        "kind": v.kind,
        "formula": " ".join(v.formula.split()) if v.kind == "requirement" else "",
        "note": v.note,
        "value": limit_value(v.limit, v.value) if unit is None else _with_unit(v.value, unit),
        "bound": limit_value(v.limit, v.bound) if unit is None else _with_unit(v.bound, unit),
        "margin": _with_unit(v.margin, v.unit, signed=True),
        "normalised_margin": "—" if math.isnan(v.normalised_margin) else f"{v.normalised_margin:+.3g}",
        "window": window,
        "default": v.default,
        "reason": v.reason,
        "worst": time_text(v.worst_time_s),
        "first": time_text(v.first_time_s),
        "sample": sample,
        "message": v.message,
    }


def _experiment(index: int, exp: ExperimentReport) -> dict[str, Any]:
    shown = _shown_run(exp)
    png = _figure(shown) if shown is not None else None
    experiment = exp.experiment if exp.experiment is not None else load_experiment(exp.path)
    caption = ""
    if shown is not None and shown.task.sample is not None:
        caption = f"Monte Carlo sample {shown.task.sample} of {len(exp.outcomes)}, the one nearest its bound"
    consistency = [
        {"name": name.split("_")[0].upper(), "interval": c["interval_95"], **c}
        for name, c in (exp.consistency() or {}).items()
    ]
    return {
        "anchor": f"experiment-{index}",
        "name": exp.name,
        "path": exp.path,
        "status": _status(exp),
        "runs": len(exp.outcomes),
        "monte_carlo": exp.monte_carlo,
        "wall_time_s": exp.wall_time_s,
        "errors": [
            f"{'the run' if o.task.sample is None else f'sample {o.task.sample}'} could not be completed: {o.error}"
            for o in exp.errors
        ],
        "limits": [_limit_row(v) for v in exp.verdicts],
        "failed": [_limit_row(v) for v in exp.verdicts if not v.passed],
        "consistency": consistency,
        "figure": data_uri(png) if png is not None else None,
        "caption": caption,
        "resolved_toml": resolved_experiment_toml(experiment),
    }


def check_html(report: CheckReport, *, title: str = "agvctl check") -> str:
    """The page of a check as HTML text: self-contained (figures embedded), readable without JavaScript.

    Parameters
    ----------
    report : CheckReport
        From :func:`~agvctl.checks.runner.check_experiments`; with ``render=check_run_figures`` its runs' figures
        were drawn where they ran. Otherwise (and for the Monte Carlo sample shown, which is never drawn where it
        ran) the run shown is run again here to draw it.
    title : str
        The page's title.

    Returns
    -------
    str
        The HTML document.
    """
    expect_instance(report, CheckReport, "check_html", "report")
    expect_instance(title, str, "check_html", "title")
    experiments = [_experiment(i, e) for i, e in enumerate(report.experiments)]
    experiments.sort(key=lambda e: _ORDER[e["status"]])  # failures first, else in the check's order
    n_passed = sum(e["status"] == "PASS" for e in experiments)
    status = "ERROR" if not report.completed else "PASS" if report.passed else "FAIL"
    return render_template(
        "check.html.j2",
        title=title,
        status=status,
        experiments=experiments,
        n_passed=n_passed,
        n_runs=sum(e["runs"] for e in experiments),
        wall_time_s=report.wall_time_s,
    )


def write_check_html(report: CheckReport, path: str | Path, *, title: str = "agvctl check") -> Path:
    """Write the page of :func:`check_html` to ``path``, atomically (a temporary file moved into place).

    Parameters
    ----------
    report : CheckReport
        The check's report.
    path : str or Path
        The HTML file to write.
    title : str
        The page's title.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OSError
        When ``path`` cannot be written (nothing is left half-written).
    """
    expect_instance(report, CheckReport, "write_check_html", "report")
    expect_instance(path, (str, os.PathLike), "write_check_html", "path")
    text = check_html(report, title=title)
    write_text(path, text)
    return Path(path)
