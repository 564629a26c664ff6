"""What a closed-loop run does at the end of its path, from its log: when the reference comes to rest, when the
vehicle arrives (and how late), how far it stands beside the path's final line once there, and the current it holds
at rest (signals of :data:`~agvctl.evaluation.metrics.SIGNALS`)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvctl.log import SimLog

__all__ = ["arrival_index", "dock_offset_m", "late_s", "reference_end_index", "rest_current_a"]


def reference_end_index(log: SimLog) -> int:
    """The first sample at which the reference has come to rest at its end: from it on, the log's reference pose
    and wheel speeds (``ref_*``) no longer change (the last sample if they change to the end).

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the reference's columns.

    Returns
    -------
    int
        The sample's index (0 for an empty log or a reference at rest throughout).
    """
    return _settled_index(log, REFERENCE_COLUMNS)


def _settled_index(log: SimLog, columns: tuple[str, ...]) -> int:
    """The first sample from which none of ``columns`` changes (0 for an empty log or columns constant throughout)."""
    if len(log) == 0:
        return 0
    moving = np.zeros(len(log), dtype=bool)
    for column in columns:
        values = np.asarray(log[column])
        moving |= values != values[-1]
    changed = np.nonzero(moving)[0]
    return int(changed[-1]) + 1 if changed.size else 0


REFERENCE_COLUMNS = ("ref_x_m", "ref_y_m", "ref_theta_rad", "ref_wheel_speed_left_m_s", "ref_wheel_speed_right_m_s")
"""The log's columns of the reference (its pose and wheel speeds at each sample)."""

ARRIVED_M = 0.02
"""How near the path's end (m) a vehicle counts as arrived (:func:`late_s`, ``completion_time_s``)."""


def _to_end_m(log: SimLog, x: str, y: str) -> NDArray[np.float64]:
    """The distance of the point ``(x, y)`` (two columns of the log) from the path's end, per sample."""
    return np.asarray(np.hypot(log[x] - log["ref_x_m"][-1], log[y] - log["ref_y_m"][-1]), dtype=np.float64)


def arrival_index(log: SimLog) -> int:
    """The sample at which the vehicle arrives at the path's end: the first, from the one at which the reference
    comes within :data:`ARRIVED_M` of its end for good, at which the vehicle is within :data:`ARRIVED_M` of it too.

    Counting from the reference's own final approach, a path that passes its end earlier (a figure eight, a
    shuttle) gives no early arrival; counting the first time there, not the time from which the vehicle stays
    there, a vehicle that reaches the end with its reference and runs past it (a fast path with no headroom to
    brake) and a dock that backs away from the end and comes in again arrive when they first get there: how far
    they stray is for the final position and the dock's limits to judge.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the reference's and the vehicle's columns.

    Returns
    -------
    int
        The sample's index (the log's length if the vehicle never arrives).
    """
    if len(log) == 0:
        return 0
    away = np.nonzero(_to_end_m(log, "ref_x_m", "ref_y_m") > ARRIVED_M)[0]
    approach = int(away[-1]) + 1 if away.size else 0  # the reference within ARRIVED_M of its end for good
    arrived = np.nonzero(_to_end_m(log, "x_m", "y_m")[approach:] <= ARRIVED_M)[0]
    return approach + int(arrived[0]) if arrived.size else len(log)


def late_s(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """From the reference's end (:func:`reference_end_index`) to the vehicle's arrival (:func:`arrival_index`,
    its sample included), the time since the reference's end; 0 elsewhere. Its largest value, the lateness, is
    ``max(0, arrival − end of the reference)`` (the rest of the run if the vehicle never arrives): how late the
    vehicle is against the time its path promises.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the reference's and the vehicle's columns.
    ts : float
        The sample period, s (unused: the signature of a signal).

    Returns
    -------
    ndarray
        The time past the reference's end before arriving, per sample, s.
    """
    out = np.zeros(len(log))
    if len(log) == 0:
        return out
    end = reference_end_index(log)
    until = min(arrival_index(log) + 1, len(log))
    t = np.asarray(log["t_s"], dtype=np.float64)
    out[end:until] = t[end:until] - t[end]
    return out


def dock_offset_m(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """Once the reference is at rest and the vehicle has arrived (from :func:`reference_end_index` and
    :func:`arrival_index` on, whichever is later), the vehicle's distance from the path's final line; 0 before, and
    throughout on a path that never drives (only turns in place).

    The final line runs through the path's end along its last drive: the reference's heading at the sample from
    which its position no longer changes (turns in place after it do not move it). It is the line a dock backs up
    along and comes in on (:mod:`agvctl.controllers.mpc.docking`), so the distance across it is how far the vehicle
    stands or strays beside where it should stop. A vehicle that runs past the end along that line (a fast path with
    no headroom to brake) and comes back is not off it, and one still on its way (late, on a path ending in a curve
    that bends away from that line) is not there yet: running past is for the final position to judge, arriving
    late for the lateness.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the reference's and the vehicle's columns.
    ts : float
        The sample period, s (unused: the signature of a signal).

    Returns
    -------
    ndarray
        The distance across the final line per sample, m.
    """
    out = np.zeros(len(log))
    stops = _settled_index(log, ("ref_x_m", "ref_y_m"))
    if stops == 0:
        return out
    heading = float(log["ref_theta_rad"][min(stops, len(log) - 1)])
    dx, dy = log["x_m"] - log["ref_x_m"][-1], log["y_m"] - log["ref_y_m"][-1]
    across = np.abs(np.asarray(dy * math.cos(heading) - dx * math.sin(heading)))
    start = max(reference_end_index(log), arrival_index(log))
    out[start:] = across[start:]
    return out


REST_SPEED_M_S = 1e-3
"""A wheel slower than this (m/s) with a zero setpoint is at rest (:func:`rest_current_a`)."""

REST_WINDOW_S = 1.0
"""How long both wheels must have rested for the current to count (:func:`rest_current_a`)."""


def rest_current_a(log: SimLog, sample_period_s: float) -> NDArray[np.float64]:
    """At each sample that ends a :data:`REST_WINDOW_S` throughout which both wheels rested (setpoints exactly 0,
    rim speeds under :data:`REST_SPEED_M_S`), the median over that window of the two motors' mean ``|current|``; 0
    elsewhere. Stiction holds a wheel at rest for free (record 0023): a current held there buys nothing, heats the
    motors and drains the battery. The median counts what is held for most of the window: the current that brakes
    a wheel to a stop, or that the loops still give while their speed estimate settles in the first samples of a
    rest, is not held.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the wheels' setpoints, rim speeds and currents.
    sample_period_s : float
        T_s, s.

    Returns
    -------
    ndarray
        The median motor current over each second at rest, per sample, A.
    """
    n = max(1, int(round(REST_WINDOW_S / sample_period_s)))
    out = np.zeros(len(log))
    if len(log) < n:
        return out
    rest = np.ones(len(log), dtype=bool)
    for side in ("left", "right"):
        rest &= np.asarray(log[f"setpoint_wheel_speed_{side}_m_s"]) == 0.0
        rest &= np.abs(np.asarray(log[f"wheel_speed_{side}_m_s"])) < REST_SPEED_M_S
    current = 0.5 * (np.abs(np.asarray(log["current_left_a"])) + np.abs(np.asarray(log["current_right_a"])))
    count = np.concatenate(([0], np.cumsum(rest)))
    whole = np.flatnonzero((count[n:] - count[:-n]) == n)  # the windows at rest, by their first sample
    if whole.size:
        out[n - 1 + whole] = np.median(np.lib.stride_tricks.sliding_window_view(current, n)[whole], axis=1)
    return out
