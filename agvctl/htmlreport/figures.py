"""The figure of a run on the page, drawn from its log and its limit verdicts where the run is
(:data:`~agvctl.checks.runner.RunRender`)."""

from __future__ import annotations

import math
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
    """The instant the page marks on a run's figure, and its label: where the limit that matters most was worst.

    That limit is the first violated one with a time, or else, when every limit passed, the one closest to its
    bound (the smallest finite margin over bound, of those with a positive bound and a time: for a limit, the
    largest value over bound).

    Parameters
    ----------
    limits : sequence of LimitResult
        The run's limit verdicts, in the order they were checked.

    Returns
    -------
    mark_time_s : float or None
        When that limit's signal was worst, s; None when there is no such limit.
    mark_label : str
        ``"<limit>: worst at t = 3.21 s"``, the mark's legend entry; empty when there is no mark.
    """
    timed = [r for r in limits if r.worst_time_s is not None]
    failed = [r for r in timed if not r.passed]
    if failed:
        mark = failed[0]
    else:

        def closeness(r: LimitResult) -> float:
            return 1.0 - r.value / r.bound if r.kind == "limit" else r.normalised_margin

        scored = [r for r in timed if r.bound > 0 and math.isfinite(closeness(r))]
        if not scored:
            return None, ""
        mark = min(scored, key=closeness)
    return mark.worst_time_s, f"{mark.limit}: worst at t = {mark.worst_time_s:.2f} s"


def run_panel(log: SimLog, vehicle: VehicleParams, title: str, limits: Sequence[LimitResult]) -> bytes:
    """The figure of a run on the page: its six panels, every limit's bound drawn and the worst point marked.

    :func:`~agvctl.plots.render_run_panel` with the bounds of ``limits`` and the instant of :func:`worst_mark`.

    Parameters
    ----------
    log : SimLog
        The run's log.
    vehicle : VehicleParams
        The controller's vehicle (the current limit and eq 5's a_lim drawn).
    title : str
        The figure's title (the experiment's or scenario's name).
    limits : sequence of LimitResult
        The run's limit verdicts: their bounds are drawn where their signals are.

    Returns
    -------
    bytes
        The PNG file's content.
    """
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
    experiment : Experiment
        The experiment as run.
    result : ClosedLoopResult
        Its closed-loop result.
    limits : sequence of LimitResult
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
