"""The figure of a run on the page, drawn from its log and its limit verdicts where the run is
(:data:`~agvctl.checks.runner.RunRender`)."""

from __future__ import annotations

from collections.abc import Sequence

from agvctl.errors import expect_instance
from agvctl.evaluation.limits import LimitResult
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.plots import render_run_panel
from agvctl.scenario.experiment import Experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = ["PANEL", "check_run_figures", "run_panel", "worst_mark"]

PANEL = "panel.png"
"""The name of a run's figure among its figures."""


def worst_mark(limits: Sequence[LimitResult]) -> tuple[float | None, str]:
    """The instant the page marks on a run's plots and its label: where the first violated limit was worst, or
    else where the limit closest to its bound was (value over bound); ``(None, "")`` when no limit has a time."""
    timed = [r for r in limits if r.worst_time_s is not None]
    failed = [r for r in timed if not r.passed]
    if failed:
        mark = failed[0]
    else:
        scored = [r for r in timed if r.bound > 0]
        if not scored:
            return None, ""
        mark = max(scored, key=lambda r: r.value / r.bound)
    return mark.worst_time_s, f"{mark.limit}: worst at t = {mark.worst_time_s:.2f} s"


def run_panel(log: SimLog, vehicle: VehicleParams, title: str, limits: Sequence[LimitResult]) -> bytes:
    """The run's six-panel figure (PNG) with every limit's bound drawn and its worst point marked."""
    mark_time_s, mark_label = worst_mark(limits)
    return render_run_panel(
        log,
        vehicle,
        title=title,
        bounds={r.limit: r.bound for r in limits},
        mark_time_s=mark_time_s,
        mark_label=mark_label,
    )


def check_run_figures(
    experiment: Experiment, result: ClosedLoopResult, limits: Sequence[LimitResult]
) -> dict[str, bytes]:
    """A check run's figures for the page: :data:`PANEL`, the path against the reference with the worst point
    marked, the errors, wheel speeds, currents and wheel acceleration against their bounds.

    Parameters
    ----------
    experiment
        The experiment as run.
    result
        Its closed-loop result.
    limits
        Its limit verdicts.

    Returns
    -------
    dict of str to bytes
        ``{PANEL: PNG bytes}``.
    """
    expect_instance(experiment, Experiment, "check_run_figures", "experiment")
    expect_instance(result, ClosedLoopResult, "check_run_figures", "result")
    expect_instance(limits, (list, tuple), "check_run_figures", "limits")
    for i, r in enumerate(limits):
        expect_instance(r, LimitResult, "check_run_figures", f"limits[{i}]")
    return {PANEL: run_panel(result.log, experiment.controller_vehicle, experiment.spec.name, limits)}
