"""Figures of merit of a closed-loop run, computed from its log (the ``metrics`` of ``summary.json``)."""

from __future__ import annotations

import math
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.errors import ConfigError
from agvctl.evaluation.end_of_path import arrival_index, dock_offset_m, late_s, reference_end_index, rest_current_a
from agvctl.evaluation.payload import PAYLOAD_METRICS, wheel_held
from agvctl.evaluation.signals import Metric, Reduction, Signal
from agvctl.log import SimLog

__all__ = [
    "METRICS",
    "SIGNALS",
    "signal_values",
    "NON_FINITE_COMMAND_STATUS",
    "closed_loop_metrics",
    "sample_wheel_accel_m_s2",
    "estimate_heading_error_rad",
    "estimate_metrics",
    "estimate_position_error_m",
    "time_to_converge_s",
    "wheel_speed_error_m_s",
    "late_s",
    "dock_offset_m",
    "arrival_index",
    "reference_end_index",
    "rest_current_a",
    "RunRecord",
]


NON_FINITE_COMMAND_STATUS = 3
"""The log's ``solver_status`` at a sample whose pose-controller command was NaN or infinite (the wheel loops get
a stop, 0 m/s, instead): a controller failure, counted in ``solver_failures`` and in ``non_finite_commands``."""


class RunRecord(Protocol):
    """What the metrics read of a closed-loop run (:class:`agvctl.sim.loop.ClosedLoopResult` is one)."""

    @property
    def log(self) -> SimLog: ...

    @property
    def sample_period_s(self) -> float: ...

    @property
    def solver_failures(self) -> int: ...


def estimate_position_error_m(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """The pose estimate's position error per sample: ``|estimated − true position|``.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the estimate's and the truth's columns.
    ts : float
        The sample period, s (unused: the signature of a limit's series).

    Returns
    -------
    ndarray
        The error per sample, m.
    """
    return np.asarray(np.hypot(log["est_x_m"] - log["x_m"], log["est_y_m"] - log["y_m"]))


def estimate_heading_error_rad(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """The pose estimate's heading error per sample: ``|estimated − true heading|``, wrapped.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the estimate's and the truth's columns.
    ts : float
        The sample period, s (unused: the signature of a limit's series).

    Returns
    -------
    ndarray
        The error per sample, rad.
    """
    return np.asarray(np.abs(wrap_angle(log["est_theta_rad"] - log["theta_rad"])))


def time_to_converge_s(t_s: np.ndarray, error_m: np.ndarray, threshold_m: float) -> float:
    """The first time after which an error stays at or below a threshold.

    Parameters
    ----------
    t_s : ndarray
        The sample times, s.
    error_m : ndarray
        The error at each, m.
    threshold_m : float
        The threshold, m.

    Returns
    -------
    float
        The time, s: 0 if the error never exceeds the threshold, inf if it never settles.

    Examples
    --------
    >>> time_to_converge_s(np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.5, 0.2, 0.01, 0.0]), 0.02)
    2.0
    """
    above = np.nonzero(error_m > threshold_m)[0]
    if above.size == 0:
        return 0.0
    last = int(above[-1])
    return float(t_s[last + 1]) if last + 1 < len(t_s) else math.inf


def sample_wheel_accel_m_s2(log: SimLog, sample_period_s: float) -> NDArray[np.float64]:
    """Each sample's larger mean rim acceleration ``|v(t_k) − v(t_k−1)|``/T_s of the two wheels: what encoders see and
    a payload feels over a sample, without the stiction break-away's instants inside it.

    Parameters
    ----------
    log : SimLog
        A closed-loop or open-loop log with the wheels' rim speeds.
    sample_period_s : float
        T_s, s.

    Returns
    -------
    ndarray
        The acceleration per sample (0 at k = 0), m/s².
    """
    speeds = np.column_stack([log["wheel_speed_left_m_s"], log["wheel_speed_right_m_s"]])
    accel = np.max(np.abs(np.diff(speeds, axis=0)), axis=1) / sample_period_s if len(speeds) > 1 else np.zeros(0)
    return np.concatenate(([0.0], accel))


SPEED_ERROR_WINDOW_S = 1.0
"""How long a wheel-speed error is averaged over (:func:`wheel_speed_error_m_s`): far longer than the wheel loop
settles after a setpoint's step (a few of its 31 ms time constants), so that what remains is an error it keeps."""


def wheel_speed_error_m_s(log: SimLog, sample_period_s: float) -> NDArray[np.float64]:
    """Each sample's larger ``|mean(v(t_j+1) − v_sp(t_j))|`` of the two wheels over the :data:`SPEED_ERROR_WINDOW_S`
    before it: how far a wheel stays from its setpoint, one sample after it is set, in the windows in which its loop
    had authority (``wheel_loop_limited_*`` 0 at every sample). A window in which the loop was clamped to the current
    limit or the DA range, or whose wheel controller does not say (NaN), counts 0.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the wheels' setpoints, rim speeds and ``wheel_loop_limited_*``.
    sample_period_s : float
        T_s, s.

    Returns
    -------
    ndarray
        The error per sample (0 before a whole window has passed), m/s.
    """
    n = max(1, int(round(SPEED_ERROR_WINDOW_S / sample_period_s)))
    worst = np.zeros(len(log))
    for side in ("left", "right"):
        error = log[f"wheel_speed_{side}_m_s"][1:] - log[f"setpoint_wheel_speed_{side}_m_s"][:-1]
        free = log[f"wheel_loop_limited_{side}"][:-1] == 0.0
        if len(error) < n:
            continue
        total = np.concatenate(([0.0], np.cumsum(np.where(free, error, 0.0))))
        count = np.concatenate(([0], np.cumsum(free)))
        judged = (count[n:] - count[:-n]) == n
        mean = np.where(judged, np.abs(total[n:] - total[:-n]) / n, 0.0)
        worst[n:] = np.maximum(worst[n:], mean)
    return worst


JOINED_M = 0.02
"""How near the path (m) a vehicle that started off it counts as having joined it."""


def _either(log: SimLog, column: str) -> NDArray[np.float64]:
    """The larger ``|value|`` of the left and right wheels' ``column`` (``{}`` for the side) at each sample."""
    return np.asarray(np.maximum(np.abs(log[column.format("left")]), np.abs(log[column.format("right")])))


def _joined_cross_track_m(log: SimLog, ts: float) -> NDArray[np.float64]:
    """``|cross-track error|`` from the first sample within :data:`JOINED_M` of the path on (0 before it; every
    sample if none is)."""
    cross = np.abs(np.asarray(log["cross_track_error_m"]))
    on = np.nonzero(cross <= JOINED_M)[0]
    if on.size:
        cross[: int(on[0])] = 0.0
    return cross


def _flags(mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """1.0 where ``mask`` holds, else 0.0."""
    return mask.astype(np.float64)


def _clipped(log: SimLog, ts: float) -> NDArray[np.float64]:
    """1 where the DA converter clipped either wheel's command, else 0."""
    return _flags((log["da_clipped_left"] > 0) | (log["da_clipped_right"] > 0))


def _current_limited(log: SimLog, ts: float) -> NDArray[np.float64]:
    """The larger share of either wheel's hold interval spent at the current limit."""
    return _either(log, "current_limited_fraction_{}")


def _solve_time_ms(log: SimLog, ts: float) -> NDArray[np.float64]:
    """The pose controller's computation time at each step, ms."""
    return np.asarray(log["solve_time_s"]) * 1e3


_DEG = math.degrees(1.0)


def _wheel_speed_error(side: str) -> Signal:
    """``v(t_k) − v_sp(t_k−1)`` of one wheel: its rim speed one sample after its setpoint was set (0 at k = 0)."""

    def signal(log: SimLog, ts: float) -> NDArray[np.float64]:
        error = log[f"wheel_speed_{side}_m_s"][1:] - log[f"setpoint_wheel_speed_{side}_m_s"][:-1]
        return np.concatenate(([0.0], error))

    return signal


SIGNALS: dict[str, Signal] = {
    "heading_error_deg": lambda log, ts: np.asarray(log["heading_error_rad"]) * _DEG,
    "path_heading_error_deg": lambda log, ts: np.asarray(log["path_heading_error_rad"]) * _DEG,
    "cross_track_error_joined_m": _joined_cross_track_m,
    "dock_offset_m": dock_offset_m,
    "late_s": late_s,
    "rest_current_a": rest_current_a,
    "wheel_speed_m_s": lambda log, ts: _either(log, "wheel_speed_{}_m_s"),
    "wheel_accel_m_s2": sample_wheel_accel_m_s2,
    "wheel_accel_instant_m_s2": lambda log, ts: _either(log, "wheel_accel_peak_{}_m_s2"),
    "wheel_speed_error_m_s": wheel_speed_error_m_s,
    "wheel_speed_error_left_m_s": _wheel_speed_error("left"),
    "wheel_speed_error_right_m_s": _wheel_speed_error("right"),
    "wheel_held": wheel_held,
    "motor_current_peak_a": lambda log, ts: _either(log, "current_peak_{}_a"),
    "da_clipped": _clipped,
    "current_limited_share": _current_limited,
    "solve_time_ms": _solve_time_ms,
    "deadline_missed": lambda log, ts: _flags(log["solve_time_s"] > ts),
    "solver_failed": lambda log, ts: _flags(log["solver_status"] > 0),
    "non_finite_command": lambda log, ts: _flags(log["solver_status"] == NON_FINITE_COMMAND_STATUS),
    "estimate_error_m": estimate_position_error_m,
    "heading_estimate_error_deg": lambda log, ts: estimate_heading_error_rad(log) * _DEG,
}
"""The signals derived from a run's log, by name (its unit in it), one value per row: with the log's own columns
(:data:`~agvctl.log.PLANT_LOG_COLUMNS` and the closed loop's), what a metric reduces and a requirement's formula
compares. ``heading_error_deg`` and ``path_heading_error_deg`` are signed (the log's radians in degrees);
``wheel_speed_m_s``, ``wheel_accel_m_s2`` (:func:`sample_wheel_accel_m_s2`), ``wheel_accel_instant_m_s2``
and ``motor_current_peak_a`` the larger magnitude of the two wheels'; ``wheel_speed_error_m_s`` the windowed error
where the loop has authority (:func:`wheel_speed_error_m_s`), ``wheel_speed_error_left_m_s`` and
``wheel_speed_error_right_m_s`` each wheel's signed ``v(t_k) − v_sp(t_k−1)``; ``da_clipped``, ``deadline_missed``,
``solver_failed``, ``non_finite_command`` and ``wheel_held`` (a wheel held or recovering,
:func:`~agvctl.evaluation.payload.wheel_held`) are flags (1 or 0); ``current_limited_share`` is the larger share of
either wheel's hold interval at the current limit."""


def signal_values(log: SimLog, name: str, sample_period_s: float) -> NDArray[np.float64]:
    """A named signal's samples: a signal of :data:`SIGNALS` or a column of the log.

    Parameters
    ----------
    log : SimLog
        The run's log.
    name : str
        A key of :data:`SIGNALS` or a column of ``log``.
    sample_period_s : float
        T_s, s.

    Returns
    -------
    ndarray
        One value per row of the log, in the unit of its name.

    Raises
    ------
    KeyError
        A name that is neither.
    """
    if name in SIGNALS:
        return np.asarray(SIGNALS[name](log, sample_period_s), dtype=np.float64)
    return np.asarray(log[name], dtype=np.float64)


def _metric(
    name: str,
    unit: str,
    signal: str,
    reduction: Reduction,
    *,
    absolute: bool = False,
    over: Literal["samples", "intervals"] = "samples",
) -> Metric:
    """The metric ``name``: the reduction of the named signal (of its magnitude with ``absolute``)."""

    def series(log: SimLog, ts: float) -> NDArray[np.float64]:
        values = signal_values(log, signal, ts)
        return np.abs(values) if absolute else values

    return Metric(name, unit, series, reduction, over, signal_name=signal, absolute=absolute)


METRICS: dict[str, Metric] = {
    m.name: m
    for m in (
        _metric("tracking_error_rms_m", " m", "position_error_m", Reduction.RMS, absolute=True),
        _metric("tracking_error_max_m", " m", "position_error_m", Reduction.MAX, absolute=True),
        _metric("heading_error_max_deg", "°", "heading_error_deg", Reduction.MAX, absolute=True),
        _metric("final_position_error_m", " m", "position_error_m", Reduction.FINAL, absolute=True),
        _metric("final_heading_error_deg", "°", "heading_error_deg", Reduction.FINAL, absolute=True),
        _metric("cross_track_error_max_m", " m", "cross_track_error_m", Reduction.MAX, absolute=True),
        _metric("cross_track_error_rms_m", " m", "cross_track_error_m", Reduction.RMS, absolute=True),
        _metric("cross_track_error_max_joined_m", " m", "cross_track_error_joined_m", Reduction.MAX),
        _metric("drawn_cross_track_error_max_m", " m", "drawn_cross_track_error_m", Reduction.MAX, absolute=True),
        _metric("along_track_lag_max_m", " m", "along_track_lag_m", Reduction.MAX, absolute=True),
        _metric("dock_cross_track_error_max_m", " m", "dock_offset_m", Reduction.MAX),
        _metric("lateness_s", " s", "late_s", Reduction.MAX),
        _metric("rest_current_max_a", " A", "rest_current_a", Reduction.MAX),
        _metric("path_heading_error_max_deg", "°", "path_heading_error_deg", Reduction.MAX, absolute=True),
        _metric("peak_wheel_speed_m_s", " m/s", "wheel_speed_m_s", Reduction.MAX),
        _metric("peak_wheel_accel_m_s2", " m/s²", "wheel_accel_m_s2", Reduction.MAX),
        _metric("wheel_speed_error_max_m_s", " m/s", "wheel_speed_error_m_s", Reduction.MAX),
        _metric("peak_wheel_accel_instant_m_s2", " m/s²", "wheel_accel_instant_m_s2", Reduction.MAX),
        _metric("peak_motor_current_a", " A", "motor_current_peak_a", Reduction.MAX),
        *(_metric(name, unit, col, Reduction.MAX, absolute=True) for name, (col, unit) in PAYLOAD_METRICS.items()),
        _metric("da_saturation_fraction", "", "da_clipped", Reduction.MEAN, over="intervals"),
        _metric("current_limited_fraction", "", "current_limited_share", Reduction.MEAN, over="intervals"),
        _metric("solve_time_p50_ms", " ms", "solve_time_ms", Reduction.P50),
        _metric("solve_time_p99_ms", " ms", "solve_time_ms", Reduction.P99),
        _metric("deadline_misses", "", "deadline_missed", Reduction.COUNT),
        _metric("solver_failures", "", "solver_failed", Reduction.COUNT),
        _metric("non_finite_commands", "", "non_finite_command", Reduction.COUNT),
        _metric("estimate_error_rms_m", " m", "estimate_error_m", Reduction.RMS),
        _metric("estimate_error_max_m", " m", "estimate_error_m", Reduction.MAX),
        _metric("heading_estimate_error_max_deg", "°", "heading_estimate_error_deg", Reduction.MAX),
    )
}
"""Every metric defined by a per-sample signal and a reduction, by name. Each limit of
:data:`~agvctl.evaluation.limits.LIMITS` is one of them, under the same name."""

_ESTIMATE_METRICS = ("estimate_error_rms_m", "estimate_error_max_m", "heading_estimate_error_max_deg")


def _scalar(metric: Metric, log: SimLog, sample_period_s: float) -> float:
    """The metric's value; a count as an integer (unless NaN)."""
    value = metric.value(log, sample_period_s)
    return int(value) if metric.reduction is Reduction.COUNT and math.isfinite(value) else value


def closed_loop_metrics(result: RunRecord) -> dict[str, float]:
    """Tracking, actuator and computation figures of a run (SI units, names carry them).

    Each metric of :data:`METRICS` is its signal's reduction. ``peak_wheel_accel_m_s2`` is the largest mean rim
    acceleration over a sample (:func:`sample_wheel_accel_m_s2`), ``peak_wheel_accel_instant_m_s2`` the largest
    within one. Besides the time-indexed tracking error ``|p(t) − p_d(t)|``, the errors against the reference's path
    separate being off the path from being behind the clock (:mod:`agvctl.evaluation.path_metrics`):
    ``cross_track_error_*_m`` (distance to the path; ``drawn_cross_track_error_max_m`` to the path its file draws,
    before the planner smooths its joins), ``along_track_lag_max_m`` (the largest ``|lag|`` along the path, behind
    or ahead) and ``path_heading_error_max_deg`` (heading against the path's at the nearest point).
    ``wheel_speed_error_max_m_s`` is how far a wheel stays from its setpoint where its loop has authority
    (:func:`wheel_speed_error_m_s`). ``da_saturation_fraction`` and ``current_limited_fraction`` are shares of the
    run's hold intervals; the solve times, ``deadline_misses``, ``solver_failures`` and ``non_finite_commands``
    (the samples whose pose-controller command was NaN or infinite, also counted in ``solver_failures``) are over
    every controller step. ``cross_track_error_max_joined_m`` is the largest cross-track error once the vehicle is
    on the path: after it first comes within :data:`JOINED_M` of it (over the whole run if it never does), so that
    an off-path start does not hide what follows. ``time_to_2cm_s`` is the first time after which the vehicle stays
    within 2 cm of the reference; ``completion_time_s`` the first time after which it stays within 2 cm of the
    reference's final position (inf if it never does), against the reference's ``reference_duration_s`` (for a
    run with a reference), and the planned path's largest distance from the drawn one,
    ``reference_drawn_path_deviation_m`` (what a vehicle exactly on the reference scores as
    ``drawn_cross_track_error_max_m``).

    Parameters
    ----------
    result : ClosedLoopResult
        A closed-loop run: a :class:`~agvctl.sim.loop.ClosedLoopResult` from
        :func:`~agvctl.scenario.experiment.run_experiment` or :func:`~agvctl.sim.loop.run_closed_loop` (any record
        with its ``log``, ``solver_failures`` and ``wall_time_s``).

    Returns
    -------
    dict of str to float
        Each metric by name, its unit in the name (``tracking_error_rms_m``, ``heading_error_max_deg``, ...).
    """
    if not isinstance(getattr(result, "log", None), SimLog) or not hasattr(result, "sample_period_s"):
        raise ConfigError(
            "closed_loop_metrics", "result", f"expected a closed-loop run with a log (got {result!r:.60})"
        )
    log, ts = result.log, result.sample_period_s
    out: dict[str, float] = {
        name: _scalar(metric, log, ts) for name, metric in METRICS.items() if name not in _ESTIMATE_METRICS
    }
    out["time_to_2cm_s"] = time_to_converge_s(log["t_s"], log["position_error_m"], 0.02)
    return {**out, **_completion(log, getattr(result, "reference", None)), **estimate_metrics(log)}


def _completion(log: SimLog, reference: Any) -> dict[str, float]:
    """``completion_time_s``, ``reference_duration_s`` and ``reference_drawn_path_deviation_m`` of a run on
    ``reference`` (none without one)."""
    if reference is None:
        return {}
    end = reference.final_pose
    to_end = np.hypot(log["x_m"] - end.x_m, log["y_m"] - end.y_m)
    return {
        "completion_time_s": time_to_converge_s(log["t_s"], to_end, 0.02),
        "reference_duration_s": float(reference.duration_s),
        "reference_drawn_path_deviation_m": float(reference.drawn_path_deviation_m),
    }


def estimate_metrics(log: SimLog) -> dict[str, float]:
    """The pose estimate against the truth over a run.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the estimate's and the truth's columns.

    Returns
    -------
    dict of str to float
        ``estimate_error_rms_m``, ``estimate_error_max_m`` and ``heading_estimate_error_max_deg`` (zero with
        ``localization = "truth"``); with an estimator that has a covariance also its mean NEES (3 degrees of
        freedom) and mean NIS over the fixes; with one that gates its fixes the fixes rejected, dropped (older
        than it keeps) and applied out of order over the run.
    """
    out = {name: METRICS[name].value(log, 0.0) for name in _ESTIMATE_METRICS}
    if np.any(np.isfinite(log["nees"])):
        out["nees_mean"] = float(np.nanmean(log["nees"]))
        nis = log["nis"][np.isfinite(log["nis"])]
        out["nis_mean"] = float(np.mean(nis)) if nis.size else math.nan
    for what in ("rejected", "dropped", "reordered"):
        column = f"fixes_{what}"
        if column in log and math.isfinite(float(log[column][-1])):
            out[column] = int(log[column][-1])
    return out
