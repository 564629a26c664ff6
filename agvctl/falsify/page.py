"""The page of a search: the verdict, the smallest margin found per limit and requirement with the run that found
it, the search's figure, the worst (and first falsifying) scenario's parameters and files, and the command that
reproduces it. It is rendered through :mod:`agvctl.htmlreport` like the pages of ``check`` and ``fuzz``."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

from agvctl.errors import expect_instance
from agvctl.falsify.output import search_figure
from agvctl.falsify.result import FalsifyResult, SearchRun
from agvctl.fileio import write_text
from agvctl.htmlreport.render import data_uri, render_template

__all__ = ["falsify_html", "write_falsify_html"]

MEANINGS = {
    "PASS": "Not falsified: every run held every limit and requirement searched (exit 0).",
    "FAIL": "Falsified: a run broke a limit or requirement; its files are a regression experiment (exit 1).",
    "ERROR": "A run crashed: a finding too; its files are written (exit 3).",
}
"""What each verdict of the page means, with the command's exit code."""


def _margin_text(value: float | None) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:+.4g}"


def _param_text(value: object) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _smallest_margins(result: FalsifyResult) -> list[dict[str, Any]]:
    """Per limit and requirement, the run with its smallest normalised margin (the earliest of equals), smallest
    first."""
    best: dict[str, tuple[float, SearchRun, dict[str, Any]]] = {}
    for r in result.runs:
        for v in r.verdicts:
            value = v["normalised_margin"]
            if value is None or math.isnan(value):
                continue
            if v["name"] not in best or value < best[v["name"]][0]:
                best[v["name"]] = (float(value), r, v)
    rows = sorted(best.items(), key=lambda item: item[1][0])
    return [
        {
            "name": name,
            "kind": v["kind"],
            "margin": _margin_text(value),
            "falsified": value < 0.0,
            "run": r.run,
            "scenario": r.scenario.name,
            "message": v["message"],
        }
        for name, (value, r, v) in rows
    ]


def _scenario(result: FalsifyResult, run: SearchRun, folder: Path, heading: str, anchor: str) -> dict[str, Any]:
    names = list(result.files(run))
    experiment = next(n for n in names if not n.endswith(".path.toml"))
    return {
        "id": anchor,
        "heading": heading,
        "run": run.run,
        "scenario": run.scenario.name,
        "status": "ERROR" if run.error is not None else "FAIL" if run.falsified else "PASS",
        "margin": _margin_text(run.margin),
        "binding": run.binding,
        "error": run.error,
        "files": [(folder / n).as_posix() for n in names],
        "command": f"agvctl check {(folder / experiment).as_posix()}",
        "params": [(k, _param_text(v)) for k, v in run.params.items()],
    }


def falsify_html(result: FalsifyResult, *, out_dir: str | Path = ".", title: str = "") -> str:
    """The page of a search as HTML text: self-contained (its figure embedded), readable without JavaScript.

    Parameters
    ----------
    result : FalsifyResult
        From :func:`~agvctl.falsify.search.falsify`.
    out_dir : str or Path
        The search's output folder (``agvctl falsify --out``): the worst scenario's files are in its ``worst/``,
        the falsifying ones' in ``falsified/``, for the paths and the command that reproduces each.
    title : str
        The page's title (default: ``agvctl falsify <name>``).

    Returns
    -------
    str
        The HTML document.
    """
    expect_instance(result, FalsifyResult, "falsify_html", "result")
    expect_instance(out_dir, (str, os.PathLike), "falsify_html", "out_dir")
    expect_instance(title, str, "falsify_html", "title")
    out = Path(out_dir)
    crashed = [r for r in result.runs if r.error is not None]
    status = "ERROR" if crashed else "FAIL" if result.falsified else "PASS"
    scenarios = []
    if result.worst is not None:
        scenarios.append(_scenario(result, result.worst, out / "worst", "The worst scenario", "worst"))
    if result.falsified:
        first = result.falsifying[0]
        falsified = _scenario(result, first, out / "falsified", "The first falsifying scenario", "falsified")
        if scenarios and first is result.worst:  # one scenario, its files in both folders
            scenarios[0]["heading"] = "The worst scenario, the first falsifying"
            scenarios[0]["files"] += falsified["files"]
        else:
            scenarios.append(falsified)
    return render_template(
        "falsify.html.j2",
        title=title or f"agvctl falsify {result.spec.name}",
        status=status,
        verdict={"PASS": "not falsified", "FAIL": "FALSIFIED", "ERROR": "ERROR"}[status],
        meaning=MEANINGS[status],
        runs=len(result.runs),
        controller=result.controller,
        seed=result.seed,
        sampler=result.sampler,
        batch=result.batch,
        resumed=result.resumed,
        wall_time_s=result.wall_time_s,
        requirement=result.runs[0].requirement if result.runs else None,
        margins=_smallest_margins(result),
        crashes=[{"run": r.run, "scenario": r.scenario.name, "error": r.error} for r in crashed],
        plot=data_uri(search_figure(result)),
        scenarios=scenarios,
    )


def write_falsify_html(result: FalsifyResult, path: str | Path, *, out_dir: str | Path = ".", title: str = "") -> Path:
    """Write the page of :func:`falsify_html` to ``path``, atomically (a temporary file moved into place).

    Parameters
    ----------
    result : FalsifyResult
        The search's result.
    path : str or Path
        The HTML file to write.
    out_dir : str or Path
        The search's output folder, for the scenarios' paths and commands.
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
    expect_instance(path, (str, os.PathLike), "write_falsify_html", "path")
    write_text(path, falsify_html(result, out_dir=out_dir, title=title))
    return Path(path)
