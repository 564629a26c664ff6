"""The limits a run is judged by: one table (name → metric → series → unit), an experiment's ``[limits]``, the
default limits of a healthy run, and their evaluation on a run (value, pass/fail, worst and first times).

Adding a limit is one entry in :data:`LIMITS`: the experiment loader validates ``[limits]`` against it, and
:func:`evaluate_limits` and the messages of ``run`` and ``check`` read it.

**The default gate** (:func:`default_limits`): whatever an experiment's ``[limits]`` leaves out is judged against
what every healthy run of a planned path keeps, derived from the vehicle and the run's start:

* it ends at the path's end (``final_position_error_m`` 1 cm: where a vehicle stops to load, a centimetre off is
  a miss, and a controller that docks keeps it) facing its final heading (``final_heading_error_deg`` 2°);
* it stays on the path (``cross_track_error_max_m``: 10 cm, or the start's own offset from the path plus 5 cm) and
  never faces against it (``path_heading_error_max_deg`` 90°);
* every controller step succeeds (``solver_failures`` 0);
* no wheel accelerates over a sample faster than the motors' torque at the current limit can drive it in any
  manoeuvre (``wheel_accel_m_s2``, :func:`~agvctl.feasibility.torque_accel_limit_m_s2`, eqs 47-49 and 58-59: 1.31
  m/s² for the IAU AGV, twice eq 5's a_lim, which assumes both wheels driving alike against friction). Only friction
  helping a wheel brake in a turn in place takes it further; tracking a planned path never needs that, while a wheel
  loop slammed from limit to limit does;
* each wheel follows its setpoint wherever its loop has authority (``wheel_speed_error_max_m_s``, the mean error over
  any second in which the loop is not clamped, :func:`~agvctl.evaluation.metrics.wheel_speed_error_m_s`): a loop
  that settles within a sample lags a setpoint ramping at that torque's acceleration by at most one sample's
  change, T_s times it (52 mm/s for the IAU AGV), while a loop that scales its speeds misses by a share of them.

An explicit key replaces the default of that key only. The acceleration is the mean over a sample
(:func:`~agvctl.evaluation.metrics.sample_wheel_accel_m_s2`), not the instant inside one: a wheel breaking away
from stiction jumps for a few milliseconds whatever the controller does.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.config import check_fields, convert_value, did_you_mean, document_fields, join_key
from agvctl.errors import ConfigError
from agvctl.evaluation.metrics import (
    NON_FINITE_COMMAND_STATUS,
    estimate_heading_error_rad,
    estimate_position_error_m,
    sample_wheel_accel_m_s2,
    wheel_speed_error_m_s,
)
from agvctl.feasibility import torque_accel_limit_m_s2
from agvctl.log import SimLog
from agvctl.params import VehicleParams

__all__ = [
    "LIMITS",
    "DefaultLimit",
    "Limit",
    "LimitResult",
    "LimitsSpec",
    "all_passed",
    "default_limits",
    "evaluate_limits",
    "format_limit_message",
]

Series = Callable[[SimLog, float], NDArray[np.float64]]


@document_fields
@dataclass(frozen=True)
class Limit:
    """One limit: an upper bound on a metric of :func:`~agvctl.evaluation.metrics.closed_loop_metrics`."""

    metric: str
    """The metric the bound applies to."""
    unit: str
    """The metric's unit as printed after the value (``" m"``, ``"°"``; empty for fractions and counts)."""
    series: Series
    """The per-sample signal behind the metric, from the log and T_s in s: its worst sample and the first one past
    the bound are reported. For ``events`` limits, the per-sample flags counted or averaged."""
    timing: Literal["peak", "rms", "final", "events"]
    """How the times are reported: ``peak`` (worst = the signal's peak), ``rms`` (no first exceedance: the bound
    is on a whole-run statistic), ``final`` (both at the end), ``events`` (both at the first flagged sample)."""
    values: Literal["positive", "fraction", "count"]
    """What the file may give: a number > 0, a fraction in [0, 1], or an integer >= 0."""


def _both(log: SimLog, name: str) -> NDArray[np.float64]:
    return np.maximum(log[name.format("left")], log[name.format("right")])


def _position_error(log: SimLog, ts: float) -> NDArray[np.float64]:
    return np.asarray(log["position_error_m"])


LIMITS: dict[str, Limit] = {
    "wheel_speed_m_s": Limit(
        "peak_wheel_speed_m_s",
        " m/s",
        lambda log, ts: np.maximum(np.abs(log["wheel_speed_left_m_s"]), np.abs(log["wheel_speed_right_m_s"])),
        "peak",
        "positive",
    ),
    "wheel_accel_m_s2": Limit("peak_wheel_accel_m_s2", " m/s²", sample_wheel_accel_m_s2, "peak", "positive"),
    "wheel_speed_error_max_m_s": Limit("wheel_speed_error_max_m_s", " m/s", wheel_speed_error_m_s, "peak", "positive"),
    "motor_current_a": Limit(
        "peak_motor_current_a", " A", lambda log, ts: _both(log, "current_peak_{}_a"), "peak", "positive"
    ),
    "current_limited_fraction": Limit(
        "current_limited_fraction",
        "",
        lambda log, ts: np.asarray((log["current_limited_left"] > 0) | (log["current_limited_right"] > 0)),
        "events",
        "fraction",
    ),
    "da_saturation_fraction": Limit(
        "da_saturation_fraction",
        "",
        lambda log, ts: np.asarray((log["da_clipped_left"] > 0) | (log["da_clipped_right"] > 0)),
        "events",
        "fraction",
    ),
    "tracking_error_max_m": Limit("tracking_error_max_m", " m", _position_error, "peak", "positive"),
    "tracking_error_rms_m": Limit("tracking_error_rms_m", " m", _position_error, "rms", "positive"),
    "heading_error_max_deg": Limit(
        "heading_error_max_deg", "°", lambda log, ts: np.degrees(np.abs(log["heading_error_rad"])), "peak", "positive"
    ),
    "final_position_error_m": Limit("final_position_error_m", " m", _position_error, "final", "positive"),
    "final_heading_error_deg": Limit(
        "final_heading_error_deg",
        "°",
        lambda log, ts: np.degrees(np.abs(log["heading_error_rad"])),
        "final",
        "positive",
    ),
    "cross_track_error_max_m": Limit(
        "cross_track_error_max_m", " m", lambda log, ts: np.asarray(log["cross_track_error_m"]), "peak", "positive"
    ),
    "cross_track_error_rms_m": Limit(
        "cross_track_error_rms_m", " m", lambda log, ts: np.asarray(log["cross_track_error_m"]), "rms", "positive"
    ),
    "along_track_lag_max_m": Limit(
        "along_track_lag_max_m", " m", lambda log, ts: np.abs(log["along_track_lag_m"]), "peak", "positive"
    ),
    "path_heading_error_max_deg": Limit(
        "path_heading_error_max_deg",
        "°",
        lambda log, ts: np.degrees(np.abs(log["path_heading_error_rad"])),
        "peak",
        "positive",
    ),
    "estimate_error_rms_m": Limit("estimate_error_rms_m", " m", estimate_position_error_m, "rms", "positive"),
    "estimate_error_max_m": Limit("estimate_error_max_m", " m", estimate_position_error_m, "peak", "positive"),
    "heading_estimate_error_max_deg": Limit(
        "heading_estimate_error_max_deg",
        "°",
        lambda log, ts: np.degrees(estimate_heading_error_rad(log, ts)),
        "peak",
        "positive",
    ),
    "solve_time_p99_ms": Limit(
        "solve_time_p99_ms", " ms", lambda log, ts: log["solve_time_s"] * 1e3, "peak", "positive"
    ),
    "deadline_misses": Limit(
        "deadline_misses", "", lambda log, ts: np.asarray(log["solve_time_s"] > ts), "events", "count"
    ),
    "solver_failures": Limit(
        "solver_failures", "", lambda log, ts: np.asarray(log["solver_status"] > 0), "events", "count"
    ),
    "non_finite_commands": Limit(
        "non_finite_commands",
        "",
        lambda log, ts: np.asarray(log["solver_status"] == NON_FINITE_COMMAND_STATUS),
        "events",
        "count",
    ),
}
"""Every limit an experiment's ``[limits]`` table may set, in the order they are reported."""

_VALUES: dict[str, tuple[type, dict[str, float]]] = {
    "positive": (float, {"gt": 0.0}),
    "fraction": (float, {"ge": 0.0, "le": 1.0}),
    "count": (int, {"ge": 0}),
}


@document_fields
@dataclass(frozen=True)
class LimitsSpec:
    """``[limits]``: upper bounds by name of :data:`LIMITS` (all optional).

    Raises
    ------
    ConfigError
        ``LimitsSpec: bounds.<key>: <problem>``: an unknown key, or a bound that is not a finite value of its kind
        (positive, a fraction, a count).
    """

    bounds: dict[str, float] = field(default_factory=dict)
    """The upper bounds by limit name, each in the unit of its name (``tracking_error_max_m``: m)."""

    def __post_init__(self) -> None:
        check_fields(self)
        object.__setattr__(self, "bounds", _bounds(self.bounds, source=type(self).__name__, prefix="bounds"))

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> LimitsSpec:
        return cls(_bounds(data, source=source, prefix=prefix))

    def to_file(self) -> dict[str, Any]:
        return dict(self.bounds)

    def items(self) -> list[tuple[str, float]]:
        """The limits that are set, as (key, bound), in the order of :data:`LIMITS`."""
        return [(key, float(self.bounds[key])) for key in LIMITS if key in self.bounds]


def _bounds(data: Mapping[str, Any], *, source: str, prefix: str) -> dict[str, float]:
    """Each bound of ``data`` a known limit's key with a value of its kind (positive, a fraction, a count)."""
    bounds: dict[str, float] = {}
    for key, value in data.items():
        if key not in LIMITS:
            hint = did_you_mean(key, LIMITS, prefix.split(".") if prefix else [])
            raise ConfigError(source, join_key(prefix, key), "unknown key" + hint)
        tp, meta = _VALUES[LIMITS[key].values]
        bounds[key] = convert_value(tp, value, source, join_key(prefix, key), meta)
    return bounds


def format_limit_message(
    limit: str, value: float, bound: float, passed: bool, worst_time_s: float | None, first_time_s: float | None
) -> str:
    """A limit's result as one readable line, as ``run`` and ``check`` print it.

    Parameters
    ----------
    limit : str
        The limit's name (a key of :data:`LIMITS`, whose unit is printed).
    value : float
        The run's value of its metric, in the limit's unit.
    bound : float
        The bound, in the same unit.
    passed : bool
        Whether the value is within the bound.
    worst_time_s : float or None
        When the signal was worst, s.
    first_time_s : float or None
        When it first went past the bound, s.

    Returns
    -------
    str
        ``"tracking_error_max_m: 0.0012 m against the limit 0.03 m — ok"``; a violated limit ends in
        ``— VIOLATED`` with the times.

    Examples
    --------
    >>> print(format_limit_message("tracking_error_max_m", 0.042, 0.03, False, 12.4, 11.9))
    tracking_error_max_m: 0.042 m against the limit 0.03 m — VIOLATED, worst at t = 12.40 s,
    first exceeded at t = 11.90 s
    """
    unit = LIMITS[limit].unit if limit in LIMITS else ""
    text = f"{limit}: {value:.6g}{unit} against the limit {bound:.6g}{unit}"
    if passed:
        return text + " — ok"
    text += " — VIOLATED"
    if worst_time_s is not None:
        text += f", worst at t = {worst_time_s:.2f} s"
    if first_time_s is not None:
        text += f", first exceeded at t = {first_time_s:.2f} s"
    return text


@document_fields
@dataclass(frozen=True)
class LimitResult:
    """One limit checked on one run."""

    limit: str
    """The limit's name, a key of :data:`LIMITS`."""
    bound: float
    """The bound, in the unit of the limit's name."""
    value: float
    """The run's value of the limit's metric, in the same unit."""
    passed: bool
    """Whether the value is within the bound."""
    worst_time_s: float | None
    """When the signal behind the limit was worst (None for counts that never happened), s."""
    first_time_s: float | None
    """When the signal first went past the bound (None if it never did), s."""
    default: bool = False
    """True when the bound is a default of :func:`default_limits`, not set in the file."""
    reason: str = ""
    """Why a default bound is what it is (one line; empty for a bound set in the file)."""

    @property
    def message(self) -> str:
        text = format_limit_message(
            self.limit, self.value, self.bound, self.passed, self.worst_time_s, self.first_time_s
        )
        return f"{text} (default: {self.reason})" if self.default else text

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["message"] = self.message
        return d


def _times(key: str, log: SimLog, bound: float, sample_period_s: float) -> tuple[float | None, float | None]:
    """(worst, first past the bound) of a limit's series, as its table entry's ``timing`` says."""
    t = log["t_s"]
    limit = LIMITS[key]
    series = limit.series(log, sample_period_s)
    if limit.timing == "final":
        return float(t[-1]), float(t[-1])
    if limit.timing == "events":
        idx = np.nonzero(series)[0]
        first = float(t[idx[0]]) if idx.size else None
        return first, first
    above = np.nonzero(series > bound)[0]
    first = float(t[above[0]]) if above.size else None
    return float(t[int(np.argmax(series))]), (None if limit.timing == "rms" else first)


@document_fields
@dataclass(frozen=True)
class DefaultLimit:
    """A bound of the default gate and why it is what it is."""

    bound: float
    """The bound, in the unit of the limit's name."""
    reason: str
    """Why, in one line (``"ends within 1 cm of the path's end"``)."""


CORRIDOR_M = 0.10
"""The default corridor about the path: a healthy run stays within 10 cm of it."""
CORRIDOR_BEYOND_START_M = 0.05
"""A run that starts further off than the corridor may stray this much beyond its start's own offset."""


def default_limits(vehicle: VehicleParams, log: SimLog) -> dict[str, DefaultLimit]:
    """The default gate of a run (see the module notes).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its motors' torque sets the acceleration bound.
    log : SimLog
        The run's log: its start's offset from the path sets the corridor.

    Returns
    -------
    dict of str to DefaultLimit
        The bound and reason of each default limit, in the order of :data:`LIMITS`.
    """
    start_offset_m = abs(float(log["cross_track_error_m"][0])) if len(log) else 0.0
    if start_offset_m + CORRIDOR_BEYOND_START_M > CORRIDOR_M:
        corridor = DefaultLimit(
            start_offset_m + CORRIDOR_BEYOND_START_M, f"the start's offset {start_offset_m:.3g} m from the path + 5 cm"
        )
    else:
        corridor = DefaultLimit(CORRIDOR_M, "stays within 10 cm of the path")
    torque = torque_accel_limit_m_s2(vehicle)
    defaults = {
        "wheel_accel_m_s2": DefaultLimit(
            torque, "what the motors' torque at the current limit gives a wheel, eqs 58-59"
        ),
        "wheel_speed_error_max_m_s": DefaultLimit(
            torque * vehicle.control.sample_period_s,
            "where its loop is not clamped, a wheel reaches its setpoint within a sample",
        ),
        "final_position_error_m": DefaultLimit(0.01, "ends within 1 cm of the path's end"),
        "final_heading_error_deg": DefaultLimit(2.0, "ends facing the path's final heading"),
        "cross_track_error_max_m": corridor,
        "path_heading_error_max_deg": DefaultLimit(90.0, "never faces against the path"),
        "solver_failures": DefaultLimit(0, "every controller step succeeds"),
        "non_finite_commands": DefaultLimit(0, "every pose command is a finite number"),
    }
    return {key: defaults[key] for key in LIMITS if key in defaults}


def evaluate_limits(
    limits: LimitsSpec, log: SimLog, metrics: dict[str, float], vehicle: VehicleParams, sample_period_s: float
) -> list[LimitResult]:
    """Check every limit of the default gate and every limit ``limits`` sets (which replaces the default of its key).

    Parameters
    ----------
    limits : LimitsSpec
        The experiment's ``[limits]``.
    log : SimLog
        The run's log.
    metrics : dict of str to float
        Its :func:`~agvctl.evaluation.metrics.closed_loop_metrics`.
    vehicle : VehicleParams
        The controller's vehicle, from which the defaults are derived (:func:`default_limits`).
    sample_period_s : float
        T_s, for the per-sample signals, s.

    Returns
    -------
    list of LimitResult
        In the order of :data:`LIMITS`; ``default`` marks a bound of the default gate.
    """
    defaults = default_limits(vehicle, log)
    bounds: dict[str, tuple[float, DefaultLimit | None]] = {k: (d.bound, d) for k, d in defaults.items()}
    bounds.update({key: (bound, None) for key, bound in limits.items()})
    results = []
    for key in LIMITS:
        if key not in bounds:
            continue
        bound, default = bounds[key]
        value = float(metrics[LIMITS[key].metric])
        passed = value <= bound * (1 + 1e-12)
        worst, first = _times(key, log, bound, sample_period_s)
        results.append(
            LimitResult(
                key,
                bound,
                value,
                bool(passed),
                worst,
                None if passed else first,
                default is not None,
                default.reason if default is not None else "",
            )
        )
    return results


def all_passed(results: list[LimitResult]) -> bool:
    """Whether a run passes its limits: every one within its bound, and none of a metric that is NaN.

    Parameters
    ----------
    results : list of LimitResult
        The run's checked limits.

    Returns
    -------
    bool
        True if it passes (also with no limit at all).
    """
    return all(r.passed for r in results) and not any(math.isnan(r.value) for r in results)
