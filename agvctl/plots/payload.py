"""What the payload feels, drawn: the accelerometer's readings against the load's bounds, the held wheels shaded."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from agvctl.evaluation.payload import wheel_held
from agvctl.log import SimLog

__all__ = ["BODY_ACCEL_LIMITS", "draw_body_accel"]


BODY_ACCEL_LIMITS = {
    "peak_body_linear_accel_m_s2": ("body_linear_accel_m_s2", "C2"),
    "peak_body_lateral_accel_m_s2": ("body_lateral_accel_m_s2", "C4"),
}
"""The limits on the payload's accelerations drawn on the acceleration panel, by the column each bounds and its
colour (:mod:`agvctl.evaluation.payload`)."""


def draw_body_accel(ax: Any, log: SimLog, bounds: Mapping[str, float]) -> Any:
    """Draw on an axes what the payload's accelerometer reads, for each of :data:`BODY_ACCEL_LIMITS` that
    ``bounds`` sets, with that bound (both signs); and, where ``peak_body_angular_accel_rad_s2`` is set, the angular
    reading against its bound on a second y axis at the right (rad/s²). Acceleration in m/s², time in s. Where a
    bound is drawn, the samples with a wheel held or recovering (:func:`~agvctl.evaluation.payload.wheel_held`) are
    shaded: an excess there is a break-away or a catch-up, not a command.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on (the wheel acceleration's, which shares the unit).
    log : SimLog
        The run's log (the columns of :data:`~agvctl.evaluation.payload.PAYLOAD_LOG_COLUMNS`).
    bounds : mapping of str to float
        The gate's bounds by limit name; only the payload's are drawn.

    Returns
    -------
    matplotlib.axes.Axes or None
        The angular reading's axes, sharing ``ax``'s time axis (None: none drawn).
    """
    if any(key in bounds for key in (*BODY_ACCEL_LIMITS, "peak_body_angular_accel_rad_s2")):
        _shade_held_wheels(ax, log)
        ax.legend(loc="best", fontsize=8)
    for key, (column, colour) in BODY_ACCEL_LIMITS.items():
        if key in bounds and column in log:
            ax.plot(log["t_s"], log[column], color=colour, lw=1.2, label=f"payload: {column}")
            ax.axhline(bounds[key], color=colour, ls="--", lw=1, label=f"{key} {bounds[key]:.3g}")
            ax.axhline(-bounds[key], color=colour, ls="--", lw=1)
            ax.legend(loc="best", fontsize=8)
    key, column = "peak_body_angular_accel_rad_s2", "body_angular_accel_rad_s2"
    if key not in bounds or column not in log:
        return None
    angular = ax.twinx()  # its tick labels inside the axes: the panel's layout leaves no room at the right
    angular.plot(log["t_s"], log[column], color="C9", lw=1.2, label=f"payload: {column} (right axis)")
    angular.axhline(bounds[key], color="C9", ls="--", lw=1, label=f"{key} {bounds[key]:.3g}")
    angular.axhline(-bounds[key], color="C9", ls="--", lw=1)
    angular.tick_params(axis="y", direction="in", pad=-24, labelsize=7, labelcolor="C9")
    angular.legend(loc="lower right", fontsize=8)
    return angular


def _shade_held_wheels(ax: Any, log: SimLog) -> None:
    """Shade the samples where a wheel is held or recovering, across the axes' height."""
    t = np.asarray(log["t_s"])
    if len(t) < 2:
        return
    held = wheel_held(log, float(t[1] - t[0])) > 0
    if held.any():
        ax.fill_between(
            t,
            0.0,
            1.0,
            where=held,
            step="post",
            color="0.88",
            lw=0,
            transform=ax.get_xaxis_transform(),
            label="a wheel held or recovering (wheel_held)",
        )
