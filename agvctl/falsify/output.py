"""What a search reports: the JSON report, the readable summary and the figure (smallest margin against runs, the
random baseline beside it, the parameters that drive the margin)."""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from agvctl.falsify.result import FalsifyResult, SearchRun

__all__ = ["report_dict", "search_figure", "summary_text"]

SHOWN_IMPORTANCES = 8
"""The parameters shown in the summary and the figure, largest share first."""


def _number(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _run_dict(run: SearchRun) -> dict[str, Any]:
    return {
        "run": run.run,
        "scenario": run.scenario.name,
        "min_normalised_margin": _number(run.margin),
        "binding": run.binding,
        "error": run.error,
        "params": run.params,
    }


def report_dict(result: FalsifyResult) -> dict[str, Any]:
    """The search as JSON data: the setup, the worst run with its margins per limit and requirement, every run's
    margin, the importances, the baseline.

    Parameters
    ----------
    result : FalsifyResult
        From :func:`~agvctl.falsify.search.falsify`.

    Returns
    -------
    dict
        JSON-ready (non-finite numbers as None).
    """
    worst = result.worst
    baseline = [_number(m) for m in result.baseline_margins]
    return {
        "fuzz": result.spec.name,
        "source": result.spec.source,
        "controller": result.controller,
        "seed": result.seed,
        "batch": result.batch,
        "sampler": result.sampler,
        "runs": len(result.runs),
        "resumed": result.resumed,
        "falsified": result.falsified,
        "falsifying_runs": [r.run for r in result.falsifying],
        "first_falsifying_run": result.falsifying[0].run if result.falsified else None,
        "min_normalised_margin": None if worst is None else _number(worst.margin),
        "worst": None
        if worst is None
        else {
            **_run_dict(worst),
            "verdicts": [
                {k: (_number(v) if isinstance(v, float) else v) for k, v in d.items()} for d in worst.verdicts
            ],
        },
        "importances": result.importances,
        "margins": [_number(r.margin) for r in result.runs],
        "baseline_margins": baseline,
        "baseline_min_normalised_margin": min((m for m in baseline if m is not None), default=None),
        "wall_time_s": result.wall_time_s,
        "run_time_s": result.run_time_s,
    }


def summary_text(result: FalsifyResult) -> str:
    """The readable summary: the runs, the worst margin and where, the parameters that drive it.

    Parameters
    ----------
    result : FalsifyResult
        From :func:`~agvctl.falsify.search.falsify`.

    Returns
    -------
    str
        A few lines.
    """
    worst = result.worst
    head = (
        f"falsify {result.spec.name}: {len(result.runs)} runs of {result.controller} "
        f"(seed {result.seed}, {result.sampler}, batches of {result.batch}"
        + (f", {result.resumed} resumed" if result.resumed else "")
        + f") in {result.wall_time_s:.1f} s"
    )
    lines = [head]
    if worst is None:
        return head + "\nno run"
    verdict = "FALSIFIED" if result.falsified else "not falsified"
    if worst.error is not None:
        lines.append(f"{verdict}: run {worst.run} ({worst.scenario.name}) crashed: {worst.error}")
    else:
        lines.append(
            f"{verdict}: smallest margin {worst.margin:+.3f} of its bound ({worst.binding}) "
            f"at run {worst.run} ({worst.scenario.name})"
        )
        for v in worst.verdicts:
            if v["name"] == worst.binding:
                lines.append(f"    {v['message']}")
    if result.falsified:
        lines.append(f"first falsifying run: {result.falsifying[0].run}")
    if result.baseline_margins:
        lines.append(
            f"random baseline: smallest margin {min(result.baseline_margins):+.3f} over "
            f"{len(result.baseline_margins)} random scenarios, {sum(m < 0 for m in result.baseline_margins)} below 0"
        )
    if result.importances:
        shown = list(result.importances.items())[:SHOWN_IMPORTANCES]
        lines.append("drivers of the smallest margins (PED-ANOVA): " + ", ".join(f"{k} {v:.2f}" for k, v in shown))
    return "\n".join(lines)


def search_figure(result: FalsifyResult) -> bytes:
    """The figure of a search as PNG bytes: each run's margin and the smallest so far against runs (the random
    baseline's smallest so far beside it), and the importances.

    Parameters
    ----------
    result : FalsifyResult
        From :func:`~agvctl.falsify.search.falsify`.

    Returns
    -------
    bytes
        The PNG.
    """
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    ax, bars = fig.subplots(1, 2, width_ratios=[3, 2])
    runs = np.arange(1, len(result.runs) + 1)
    margins = np.array([-math.inf if math.isnan(r.margin) else r.margin for r in result.runs], dtype=float)
    shown = np.where(np.isfinite(margins), margins, np.nan)
    ax.plot(runs, shown, ".", color="0.6", label="each run")
    if runs.size:
        ax.step(runs, np.minimum.accumulate(margins), where="post", color="C0", label=f"search ({result.sampler})")
    if result.baseline_margins:
        base = np.array(result.baseline_margins, dtype=float)
        ax.step(
            np.arange(1, base.size + 1),
            np.minimum.accumulate(base),
            where="post",
            color="C1",
            ls="--",
            label="random scenarios",
        )
    ax.axhline(0.0, color="C3", lw=1.0)
    ax.set_xlabel("runs")
    ax.set_ylabel("smallest normalised margin")
    ax.set_title(f"{result.spec.name}: {result.controller}")
    ax.legend(loc="upper right")
    items = list(result.importances.items())[:SHOWN_IMPORTANCES][::-1]
    if items:
        bars.barh([k for k, _ in items], [v for _, v in items], color="C0")
        bars.set_xlabel("importance for the smallest margins (PED-ANOVA)")
    else:
        bars.text(0.5, 0.5, "too few runs for importances", ha="center", va="center", transform=bars.transAxes)
        bars.set_axis_off()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return buffer.getvalue()
