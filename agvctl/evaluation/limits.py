"""The limits a run is judged by: one table (the name of a metric of :data:`~agvctl.evaluation.metrics.METRICS`
→ the values a file may give), an experiment's ``[limits]``, the default limits of a healthy run, and their
evaluation on a run (value, pass/fail, worst and first times).

A limit bounds a metric, under the metric's name: the metric's per-sample signal gives the times reported, its
reduction (the worst sample, the final one, a share, a count, ...) the value, so the two cannot disagree. Adding a
limit is one entry in :data:`LIMITS` for a metric of :data:`~agvctl.evaluation.metrics.METRICS`: the experiment
loader validates ``[limits]`` against it, and :func:`evaluate_limits` and the messages of ``run`` and ``check`` read
it. :func:`judge_run` gives a run's metrics and verdicts together, as ``run``, ``check`` and ``fuzz`` report them.

**The default gate** (:func:`default_limits`): whatever an experiment's ``[limits]`` leaves out is judged against
what every healthy run of a planned path keeps, derived from the vehicle and the run's start:

* it ends at the path's end (``final_position_error_m`` 1 cm: where a vehicle stops to load, a centimetre off is
  a miss, and a controller that docks keeps it) facing its final heading (``final_heading_error_deg`` 2°);
* it stays on the path (``cross_track_error_max_m``: 10 cm, or the start's own offset from the path plus 5 cm) and
  never faces against it (``path_heading_error_max_deg`` 90°);
* every controller step succeeds (``solver_failures`` 0);
* no wheel accelerates over a sample faster than the motors' torque at the current limit can drive it in any
  manoeuvre (``peak_wheel_accel_m_s2``, :func:`~agvctl.feasibility.torque_accel_limit_m_s2`, eqs 47-49 and 58-59: 1.31
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
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from agvctl.config import check_fields, convert_value, did_you_mean, document_fields, join_key
from agvctl.errors import ConfigError
from agvctl.evaluation.metrics import METRICS, RunRecord, closed_loop_metrics
from agvctl.evaluation.signals import Metric
from agvctl.feasibility import torque_accel_limit_m_s2
from agvctl.log import SimLog
from agvctl.params import VehicleParams

__all__ = [
    "LIMITS",
    "DefaultLimit",
    "Limit",
    "LimitResult",
    "LimitsSpec",
    "RunVerdict",
    "all_passed",
    "default_limits",
    "evaluate_limits",
    "format_limit_message",
    "judge_run",
]


@document_fields
@dataclass(frozen=True)
class Limit:
    """One limit: an upper bound on a metric of :data:`~agvctl.evaluation.metrics.METRICS`, under its name."""

    metric: Metric
    """The metric the bound applies to: its signal's samples give the worst time and the first time past the
    bound, its reduction the value."""
    values: Literal["positive", "fraction", "count"]
    """What the file may give: a number > 0, a fraction in [0, 1], or an integer >= 0."""

    @property
    def unit(self) -> str:
        """The metric's unit as printed after a value (``" m"``, ``"°"``; empty for fractions and counts)."""
        return self.metric.unit


_LIMIT_VALUES: dict[str, Literal["positive", "fraction", "count"]] = {
    "peak_wheel_speed_m_s": "positive",
    "peak_wheel_accel_m_s2": "positive",
    "wheel_speed_error_max_m_s": "positive",
    "peak_motor_current_a": "positive",
    "current_limited_fraction": "fraction",
    "da_saturation_fraction": "fraction",
    "tracking_error_max_m": "positive",
    "tracking_error_rms_m": "positive",
    "heading_error_max_deg": "positive",
    "final_position_error_m": "positive",
    "final_heading_error_deg": "positive",
    "cross_track_error_max_m": "positive",
    "cross_track_error_rms_m": "positive",
    "drawn_cross_track_error_max_m": "positive",
    "along_track_lag_max_m": "positive",
    "path_heading_error_max_deg": "positive",
    "estimate_error_rms_m": "positive",
    "estimate_error_max_m": "positive",
    "heading_estimate_error_max_deg": "positive",
    "solve_time_p99_ms": "positive",
    "deadline_misses": "count",
    "solver_failures": "count",
    "non_finite_commands": "count",
}

LIMITS: dict[str, Limit] = {name: Limit(METRICS[name], values) for name, values in _LIMIT_VALUES.items()}
"""Every limit an experiment's ``[limits]`` table may set, by the name of the metric it bounds, in the order they
are reported."""

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
    """(worst, first past the bound) of a limit's signal, as its metric's reduction says
    (:meth:`~agvctl.evaluation.signals.Reduction.worst`, :meth:`~agvctl.evaluation.signals.Reduction.first_past`)."""
    metric = LIMITS[key].metric
    t, values = metric.series(log, sample_period_s)
    worst = metric.reduction.worst(values)
    first = metric.reduction.first_past(values, bound * (1 + 1e-12))
    return (None if worst is None else float(t[worst])), (None if first is None else float(t[first]))


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
        "peak_wheel_accel_m_s2": DefaultLimit(
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
    limits: LimitsSpec, log: SimLog, vehicle: VehicleParams, sample_period_s: float
) -> list[LimitResult]:
    """Check every limit of the default gate and every limit ``limits`` sets (which replaces the default of its key).

    Each limit's value, worst time and first time past its bound come from its metric's samples
    (:class:`~agvctl.evaluation.signals.Metric`), so a breach always has a first time.

    Parameters
    ----------
    limits : LimitsSpec
        The experiment's ``[limits]``.
    log : SimLog
        The run's log.
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
        value = LIMITS[key].metric.value(log, sample_period_s)
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


@document_fields
@dataclass(frozen=True)
class RunVerdict:
    """A closed-loop run judged: its metrics and its limits' verdicts."""

    metrics: dict[str, float]
    """Its :func:`~agvctl.evaluation.metrics.closed_loop_metrics`, each in the unit of its name."""
    limits: tuple[LimitResult, ...]
    """Each limit checked (:func:`evaluate_limits`), in the order of :data:`LIMITS`."""

    @property
    def passed(self) -> bool:
        """Whether every limit passes (:func:`all_passed`)."""
        return all_passed(list(self.limits))


def judge_run(result: RunRecord, limits: LimitsSpec, vehicle: VehicleParams) -> RunVerdict:
    """A closed-loop run's metrics and every limit's verdict: what ``run``, ``check`` and ``fuzz`` report.

    Parameters
    ----------
    result : ClosedLoopResult
        The run (:func:`~agvctl.scenario.experiment.run_experiment`).
    limits : LimitsSpec
        The experiment's ``[limits]``.
    vehicle : VehicleParams
        The controller's vehicle, from which the default gate is derived.

    Returns
    -------
    RunVerdict
        The metrics and the verdicts.
    """
    metrics = closed_loop_metrics(result)
    return RunVerdict(metrics, tuple(evaluate_limits(limits, result.log, vehicle, result.sample_period_s)))


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
