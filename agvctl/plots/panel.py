"""One run on one figure, for a report a person reads: the path with its worst point, the errors, the wheel
speeds, the currents and the wheel acceleration, each against the gate's bounds (the panels of
:mod:`agvctl.plots.closed_loop`). The five time panels span the run's whole time, so the time axis is labelled
once, under each column's bottom panel."""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.plots.closed_loop import (
    MM_PER_M,
    draw_both_sides,
    draw_errors,
    draw_path,
    draw_wheel_accel,
    draw_wheel_speed,
)
from agvctl.plots.figures import png_bytes, subplots
from agvctl.plots.payload import draw_body_accel

__all__ = ["PANEL_DPI", "render_run_panel"]

PANEL_DPI = 64
"""Dots per inch of the panel: the figure is 704 × 576 pixels, legible on a screen and some 100 kB as PNG."""

_KEPT = threading.local()
"""Each thread's panel figure between two runs, cleared of the last run's artists, with the matplotlib style
(``rcParams``) it was made in (``_KEPT.panel``), for the life of the thread: a worker draws one run after another,
and making the figure, its axes and their ticks again would cost a third of each panel. A figure made in another
style than the current one is made again."""


def render_run_panel(
    log: SimLog,
    vehicle: VehicleParams,
    *,
    title: str,
    bounds: Mapping[str, float],
    mark_time_s: float | None = None,
    mark_label: str = "",
    dpi: int = PANEL_DPI,
) -> bytes:
    """The run's figure as PNG bytes: six panels, each limit of ``bounds`` drawn where its signal is.

    Parameters
    ----------
    log : SimLog
        The run's log.
    vehicle : VehicleParams
        The controller's vehicle (the current limit and eq 5's a_lim drawn).
    title : str
        The figure's title.
    bounds : mapping of str to float
        The gate's bounds by limit name (:data:`~agvctl.evaluation.limits.LIMITS`): ``tracking_error_max_m`` and
        ``cross_track_error_max_m`` are drawn on the errors, ``peak_wheel_speed_m_s`` on the wheel
        speeds, ``peak_motor_current_a`` on the currents, ``peak_wheel_accel_m_s2`` on the acceleration, with the
        payload's readings where ``peak_body_linear_accel_m_s2`` or ``peak_body_lateral_accel_m_s2`` is set, and its
        angular reading on a second y axis where ``peak_body_angular_accel_rad_s2`` is.
    mark_time_s : float or None
        The instant to mark (s): the vehicle's position then on the path, a vertical line on the other panels.
    mark_label : str
        The mark's legend entry (the limit it belongs to).
    dpi : int
        Dots per inch of the PNG.

    Returns
    -------
    bytes
        The PNG.
    """
    import matplotlib

    # a figure takes its style when made: kept only while the style holds (the hinting is the PNG's own)
    style = {k: v for k, v in matplotlib.rcParams.items() if k != "text.hinting"}
    kept = getattr(_KEPT, "panel", None)
    fig, axes = kept[:2] if kept is not None and kept[2] == style else subplots(3, 2, figsize=(11, 9))
    _KEPT.panel = None  # taken: a failed drawing leaves no half-drawn figure behind
    _draw(fig, axes, log, vehicle, title, bounds, mark_time_s, mark_label)
    png = png_bytes(fig, dpi)
    _clear(axes)
    _KEPT.panel = fig, axes, style
    return png


def _draw(
    fig: Any,
    axes: Any,
    log: SimLog,
    vehicle: VehicleParams,
    title: str,
    bounds: Mapping[str, float],
    mark_time_s: float | None,
    mark_label: str,
) -> None:
    """The six panels of :func:`render_run_panel` on ``fig``'s 3 × 2 ``axes``."""
    (a_path, a_err), (a_left, a_right), (a_cur, a_acc) = axes
    draw_path(a_path, log, mark_time_s=mark_time_s, mark_label=mark_label)
    a_path.set_aspect("equal", adjustable="datalim")  # the panel's full size, the scale kept
    draw_errors(a_err, log, bounds)
    a_err.set_yscale("log")  # a millimetre and a bound of ten centimetres both readable
    error_bounds_mm = [bounds[k] * MM_PER_M for k in ("cross_track_error_max_m", "tracking_error_max_m") if k in bounds]
    a_err.set_ylim(bottom=min([1e-2, *(b / 2 for b in error_bounds_mm)]))
    speed_bound = bounds.get("peak_wheel_speed_m_s")
    for ax, side in ((a_left, "left"), (a_right, "right")):
        draw_wheel_speed(ax, log, side)
        if speed_bound is not None:
            ax.axhline(speed_bound, color="r", ls="--", lw=1, label=f"peak_wheel_speed_m_s {speed_bound:.3g}")
            ax.axhline(-speed_bound, color="r", ls="--", lw=1)
    a_left.legend(fontsize=8)  # the same lines on the right: one legend for both
    i_max = vehicle.amplifier.current_limit_a
    draw_both_sides(a_cur, log, "current_{side}_a", i_max, "amplifier limit", "armature current [A]")
    current_bound = bounds.get("peak_motor_current_a")
    if current_bound is not None and current_bound != i_max:
        a_cur.axhline(current_bound, color="r", ls="--", lw=1, label=f"peak_motor_current_a {current_bound:.3g}")
        a_cur.axhline(-current_bound, color="r", ls="--", lw=1)
        a_cur.legend(loc="best", fontsize=8)
    draw_wheel_accel(a_acc, log, vehicle, bounds.get("peak_wheel_accel_m_s2"))
    draw_body_accel(a_acc, log, bounds)  # a load's bounds, where the experiment sets them
    for ax in (a_err, a_left, a_right):  # the same time range as the bottom row's: read there
        ax.tick_params(labelbottom=False)
        ax.set(xlabel="")
    for ax in (a_cur, a_acc):
        ax.set(xlabel="t [s]")
    for ax in (a_err, a_left, a_right, a_cur, a_acc):
        if mark_time_s is not None:
            ax.axvline(mark_time_s, color="r", lw=0.8, alpha=0.6)
    _tidy((a_path, a_err, a_left, a_right, a_cur, a_acc), log_axis=a_err)
    fig.suptitle(title)
    # a fixed layout: the tight layout's measuring pass costs as much as drawing the figure again
    fig.subplots_adjust(left=0.07, right=0.98, top=0.93, bottom=0.06, hspace=0.2, wspace=0.22)


def _clear(axes: Any) -> None:
    """Each of ``axes`` as :func:`_draw` found it, but for the ticks it made (kept for the next run) and what it sets
    again (labels, aspect, locators): no artist of the run, a linear scale, limits from the data."""
    own = set(axes.flat)
    figure = axes.flat[0].figure
    for extra in [ax for ax in figure.axes if ax not in own]:  # a second y axis a run drew (the payload's angular)
        extra.remove()
    for ax in axes.flat:
        for artist in (*ax.lines, *ax.collections, *ax.patches, *ax.texts):
            artist.remove()
        legend = ax.get_legend()
        if legend is not None:
            legend.remove()
        ax.set_yscale("linear")  # as new: where a bound line falls outside the limits depends on the scale
        ax.relim()
        ax.set_autoscale_on(True)


def _tidy(axes: tuple[Any, ...], log_axis: Any) -> None:
    """A few ticks on each axis (each a label to lay out and draw, a tick mark and a grid line), plain numbers on the
    log axis (no mathtext to lay out), and each legend in a fixed place in small type (the search for the best place
    costs more than the rest of the figure)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter, NullLocator

    log_axis.yaxis.set_major_locator(LogLocator(numticks=6))
    log_axis.yaxis.set_minor_locator(NullLocator())
    log_axis.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    log_axis.yaxis.set_minor_formatter(NullFormatter())
    for ax in axes:
        ax.xaxis.set_major_locator(MaxNLocator(5))
        if ax is not log_axis:
            ax.yaxis.set_major_locator(MaxNLocator(4))
        legend = ax.get_legend()
        if legend is not None:
            legend.set_loc("upper right")
            legend.get_frame().set_alpha(0.7)
            for text in legend.get_texts():
                text.set_fontsize(8)
