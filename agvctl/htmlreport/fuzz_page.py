"""The page of a fuzz run: per controller the pass counts and the distributions, the comparison between the
controllers, and the worst scenarios with their figures and the command that reproduces each."""

from __future__ import annotations

import math
import os
import tempfile
import warnings
from pathlib import Path
from typing import Any

from agvctl.errors import ConfigError, expect_instance
from agvctl.fileio import write_text
from agvctl.fuzz.report import FUZZ_METRICS, PERCENTILES, FuzzOutcome, FuzzReport, FuzzTask
from agvctl.htmlreport.figures import run_panel
from agvctl.htmlreport.render import data_uri, limit_value, render_template
from agvctl.plots import fuzz_figure
from agvctl.plots.figures import png_bytes
from agvctl.plots.panel import PANEL_DPI
from agvctl.scenario.experiment import load_experiment, run_experiment

__all__ = ["WORST_SHOWN", "fuzz_html", "write_fuzz_html"]

WORST_SHOWN = 3
"""How many of each controller's worst scenarios the page shows with their figures (each is run again to draw)."""


def _figure(task: FuzzTask, outcome: FuzzOutcome) -> bytes | None:
    """The scenario's figure, from running its files again in this process (None for a run that crashed). The run
    again is silent: its warnings are those of the run itself, in the outcome already (and would name the files of
    a folder deleted before they are shown)."""
    if outcome.error is not None:
        return None
    with warnings.catch_warnings(), tempfile.TemporaryDirectory(prefix="agvctl-page-") as tmp:
        warnings.simplefilter("ignore")
        for name, text in task.files:
            Path(tmp, name).write_text(text, encoding="utf-8")
        experiment = load_experiment(Path(tmp, task.files[-1][0]))
        result = run_experiment(experiment)
    return run_panel(result.log, experiment.controller_vehicle, f"{task.name} ({task.controller})", outcome.limits)


def _worst(report: FuzzReport, controller: str, n: int, failures_dir: Path) -> list[dict[str, Any]]:
    tasks = {(t.scenario, t.controller): t for t in report.tasks}
    rows = []
    for o in report.worst(controller, n):
        task = tasks[(o.scenario, o.controller)]
        png = _figure(task, o)
        file_name = task.files[-1][0]
        rows.append(
            {
                "name": task.name,
                "status": "ERROR" if o.error is not None else "PASS" if o.passed else "FAIL",
                "reasons": o.reasons,
                "cross_track": limit_value("cross_track_error_max_m", o.value("cross_track_error_max_m")),
                "final": limit_value("final_position_error_m", o.value("final_position_error_m")),
                "command": None if o.passed else f"agvctl run {(failures_dir / file_name).as_posix()}",
                "figure": data_uri(png) if png is not None else None,
            }
        )
    return rows


def _comparison(cmp: dict[str, Any], seed: int) -> dict[str, Any]:
    frac, ratio = cmp["a_cross_track_max_le_b_fraction"], cmp["median_rms_ratio"]
    return {
        **cmp,
        "fraction": "—" if frac is None else f"{100 * frac:.1f} %",
        "ratio": "—" if ratio is None or not math.isfinite(ratio) else f"{ratio:.3g}",
        "tolerance_mm": f"{cmp['tolerance_m'] * 1e3:g}",
        "rms_a": limit_value("cross_track_error_rms_m", cmp["median_rms_a_m"]),
        "rms_b": limit_value("cross_track_error_rms_m", cmp["median_rms_b_m"]),
        "above": [f"s{seed}_{i:05d}" for i in cmp["a_cross_track_max_above_b"]],
    }


MAX_WORST_SHOWN = 100
"""The most worst scenarios a page shows per controller (each is run again to draw it)."""


def _check_page_arguments(source: str, report: object, failures_dir: object, worst: object, title: object) -> None:
    expect_instance(report, FuzzReport, source, "report")
    expect_instance(failures_dir, (str, os.PathLike), source, "failures_dir")
    expect_instance(title, str, source, "title")
    if isinstance(worst, bool) or not isinstance(worst, int) or not 0 <= worst <= MAX_WORST_SHOWN:
        raise ConfigError(source, "worst", f"must be an integer from 0 to {MAX_WORST_SHOWN} (got {worst!r})")


def fuzz_html(
    report: FuzzReport, *, failures_dir: str | Path = "failures", worst: int = WORST_SHOWN, title: str = ""
) -> str:
    """The page of a fuzz run as HTML text: self-contained (figures embedded), readable without JavaScript.

    Parameters
    ----------
    report : FuzzReport
        From :func:`~agvctl.fuzz.run.fuzz`.
    failures_dir : str or Path
        Where the failing scenarios' files are (``agvctl fuzz``: ``<out>/failures``), for the command that
        reproduces each.
    worst : int
        How many of each controller's worst scenarios to show; each is run again here to draw its figure.
    title : str
        The page's title (default: ``agvctl fuzz <name>``).

    Returns
    -------
    str
        The HTML document.
    """
    _check_page_arguments("fuzz_html", report, failures_dir, worst, title)
    spec = report.spec
    stats = report.statistics()
    controllers = []
    for c in spec.controllers:
        s = stats[c]
        metrics = [
            {"name": m, "cells": [limit_value(m, s[m][f"p{p}"]) for p in PERCENTILES] + [limit_value(m, s[m]["max"])]}
            for m in FUZZ_METRICS
        ]
        status = "ERROR" if s["crashed"] else "FAIL" if s["failed"] else "PASS"
        worst_rows = _worst(report, c, worst, Path(failures_dir))
        controllers.append({"name": c, "status": status, "stats": s, "metrics": metrics, "worst": worst_rows})
    crashed = any(o.error is not None for o in report.outcomes)
    return render_template(
        "fuzz.html.j2",
        title=title or f"agvctl fuzz {spec.name}",
        status="ERROR" if crashed else "PASS" if report.passed else "FAIL",
        spec=spec,
        scenarios=len({t.scenario for t in report.tasks}),
        runs=len(report.outcomes),
        wall_time_s=report.wall_time_s,
        limits=spec.limits.to_file(),
        percentiles=[f"p{p}" for p in PERCENTILES] + ["max"],
        controllers=controllers,
        comparisons=[_comparison(cmp, spec.seed) for cmp in report.comparisons()],
        cdf=data_uri(png_bytes(fuzz_figure(report), PANEL_DPI)),
    )


def write_fuzz_html(
    report: FuzzReport,
    path: str | Path,
    *,
    failures_dir: str | Path = "failures",
    worst: int = WORST_SHOWN,
    title: str = "",
) -> Path:
    """Write the page of :func:`fuzz_html` to ``path``, atomically (a temporary file moved into place).

    Parameters
    ----------
    report : FuzzReport
        The fuzz run's report.
    path : str or Path
        The HTML file to write.
    failures_dir : str or Path
        Where the failing scenarios' files are, for the reproducing commands.
    worst : int
        How many of each controller's worst scenarios to show.
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
    expect_instance(path, (str, os.PathLike), "write_fuzz_html", "path")
    _check_page_arguments("write_fuzz_html", report, failures_dir, worst, title)
    text = fuzz_html(report, failures_dir=failures_dir, worst=worst, title=title)
    write_text(path, text)
    return Path(path)
