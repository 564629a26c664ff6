"""The limits a run is judged by: one table (a metric's name → the values a file may give), an experiment's
``[limits]``, the default gate of a healthy run, and their evaluation (value, pass/fail, worst and first times).

A limit bounds a metric of :data:`~agvctl.evaluation.metrics.METRICS` under its name: the metric's signal gives the
times reported, its reduction (the worst sample, the final one, a share, a count, ...) the value, so the two cannot
disagree. A new limit is one entry in :data:`LIMITS`: the loader validates ``[limits]`` against it, and
:func:`evaluate_limits` and the messages read it. :func:`judge_run` gives a run's metrics and verdicts together.

**The default gate** (:func:`default_limits`): whatever an experiment's ``[limits]`` leaves out is judged against
what every healthy run of a planned path keeps, derived from the vehicle and the run's start:

* it ends at the path's end (``final_position_error_m`` 1 cm: where a vehicle stops to load, a centimetre off is
  a miss, and a controller that docks keeps it) facing its final heading (``final_heading_error_deg`` 0.5°);
* it arrives on time (``lateness_s`` 0.5 s, :func:`~agvctl.evaluation.metrics.late_s`): the reference governor
  holds its clock while the vehicle lags and catches up after, so a healthy run is there when its path ends;
* it stays on the path (``cross_track_error_max_m``: 10 cm, or the start's own offset from the path plus 5 cm),
  once there within 3 cm of the path's final line, docking included (``dock_cross_track_error_max_m``,
  :func:`~agvctl.evaluation.metrics.dock_offset_m`), and never faces against it (``path_heading_error_max_deg`` 90°);
* a wheel at rest holds no current (``rest_current_max_a`` 0.1 A, :func:`~agvctl.evaluation.metrics.rest_current_a`);
* every controller step succeeds (``solver_failures`` 0);
* where the path limits the body's motion (:class:`~agvctl.planning.BodyLimits`), the payload feels no more than
  each limit (``peak_body_<key>``, read as :mod:`~agvctl.evaluation.payload`'s accelerometer reads it);
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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from agvctl.config import check_fields, convert_value, did_you_mean, document_fields, join_key
from agvctl.errors import ConfigError
from agvctl.evaluation.default_bounds import (
    DefaultLimit,
    default_bounds,
)
from agvctl.evaluation.formula import Comparison, Formula, Temporal, parse_formula
from agvctl.evaluation.metrics import METRICS, RunRecord, closed_loop_metrics
from agvctl.evaluation.payload import PAYLOAD_LOG_COLUMNS, PAYLOAD_METRICS
from agvctl.evaluation.requirements import PathParts, RequirementSpec, evaluate_requirement
from agvctl.evaluation.signals import Metric, Reduction
from agvctl.evaluation.verdicts import (
    COUNT_MARGIN_STEP,
    LimitResult,
    all_passed,
    format_limit_message,
    format_margin,
    format_requirement_message,
    margin_scale,
    smallest_normalised_margin,
)
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.planning.spec import BodyLimits

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
    "evaluate_requirements",
    "format_limit_message",
    "format_margin",
    "format_requirement_message",
    "judge_run",
    "limit_formula",
    "margin_scale",
    "smallest_normalised_margin",
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
    **dict.fromkeys(PAYLOAD_METRICS, "positive"),
    "current_limited_fraction": "fraction",
    "da_saturation_fraction": "fraction",
    "tracking_error_max_m": "positive",
    "tracking_error_rms_m": "positive",
    "heading_error_max_deg": "positive",
    "final_position_error_m": "positive",
    "final_heading_error_deg": "positive",
    "cross_track_error_max_m": "positive",
    "cross_track_error_rms_m": "positive",
    "dock_cross_track_error_max_m": "positive",
    "lateness_s": "positive",
    "rest_current_max_a": "positive",
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


def _times(key: str, log: SimLog, bound: float, sample_period_s: float) -> tuple[float | None, float | None]:
    """(worst, first past the bound) of a limit's signal, as its metric's reduction says
    (:meth:`~agvctl.evaluation.signals.Reduction.worst`, :meth:`~agvctl.evaluation.signals.Reduction.first_past`)."""
    metric = LIMITS[key].metric
    t, values = metric.series(log, sample_period_s)
    worst = metric.reduction.worst(values)
    first = metric.reduction.first_past(values, bound * (1 + 1e-12))
    return (None if worst is None else float(t[worst])), (None if first is None else float(t[first]))


def default_limits(vehicle: VehicleParams, log: SimLog, body: BodyLimits | None = None) -> dict[str, DefaultLimit]:
    """The default gate of a run (see the module notes).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its motors' torque sets the acceleration bound.
    log : SimLog
        The run's log: its start's offset from the path sets the corridor.
    body : BodyLimits or None
        The path's limits on the body's motion: each one set is judged on what the payload feels
        (``peak_body_<key>``, :mod:`~agvctl.evaluation.payload`).

    Returns
    -------
    dict of str to DefaultLimit
        The bound and reason of each default limit, in the order of :data:`LIMITS`.
    """
    defaults = default_bounds(vehicle, log, body)
    return {key: defaults[key] for key in LIMITS if key in defaults}


def limit_formula(key: str, bound: float) -> tuple[Formula, str, str] | None:
    """A limit as a requirement of signal temporal logic, where it is one: (formula, its text, its anchor).

    A bound on the worst sample is ``always signal <= bound`` over the run, one on the final sample ``signal <=
    bound`` at the run's end. A bound on a whole-run number (an RMS, a share, a count, a percentile) is not a
    property of samples in time: None.

    Parameters
    ----------
    key : str
        The limit's name, a key of :data:`LIMITS`.
    bound : float
        Its bound, in the unit of its name.

    Returns
    -------
    tuple or None
        The parsed formula, its text and its anchor (``"start"`` or ``"run_end"``); None for a whole-run number.

    Examples
    --------
    >>> limit_formula("tracking_error_max_m", 0.03)[1:]
    ('always abs(position_error_m) <= 0.03', 'start')
    """
    metric = LIMITS[key].metric
    if metric.reduction not in (Reduction.MAX, Reduction.FINAL) or not metric.signal_name:
        return None
    comparison = Comparison(metric.signal_name, "<=", float(bound), metric.absolute)
    if metric.reduction is Reduction.MAX:
        return Temporal("always", (0.0, math.inf), comparison), f"always {comparison}", "start"
    return comparison, str(comparison), "run_end"


def _limit_result(
    key: str, bound: float, default: DefaultLimit | None, log: SimLog, sample_period_s: float
) -> LimitResult:
    """One limit judged on a run: through its formula where it has one (:func:`limit_formula`), else as its
    whole-run number against the bound."""
    metric = LIMITS[key].metric
    value = metric.value(log, sample_period_s)
    t = np.asarray(log["t_s"], dtype=np.float64)
    run_window = (float(t[0]), float(t[-1])) if len(t) else (0.0, 0.0)
    as_formula = limit_formula(key, bound)
    worst, first = _times(key, log, bound, sample_period_s)
    if as_formula is not None:
        formula, text, anchor = as_formula
        verdict = evaluate_requirement(formula, log, sample_period_s, None, anchor=anchor)
        margin, worst, window = verdict.margin, verdict.worst_time_s, verdict.window_s
    elif LIMITS[key].values == "count":
        text, margin, window = "", bound + COUNT_MARGIN_STEP - value, run_window
    else:
        text, margin, window = "", bound - value, run_window
    passed = bool(margin >= -abs(bound) * 1e-12) and not math.isnan(value)
    note = "" if passed else _held_wheel_note(key, bound, log, sample_period_s)
    return LimitResult(
        key,
        bound,
        value,
        passed,
        worst,
        None if passed else first,
        default is not None,
        default.reason if default is not None else "",
        margin=float(margin) if not math.isnan(value) else math.nan,
        window_s=window,
        formula=text,
        unit=LIMITS[key].unit,
        note=note,
    )


def _held_wheel_note(key: str, bound: float, log: SimLog, sample_period_s: float) -> str:
    """For a broken limit on what the payload's accelerometer reads, how the run fares where the wheels move freely
    (``wheel_held``, :func:`~agvctl.evaluation.payload.wheel_held`): a break-away's jolt or a held wheel's catch-up
    told apart from what the controller commands. Empty for any other limit."""
    signal = LIMITS[key].metric.signal_name
    if signal not in PAYLOAD_LOG_COLUMNS:
        return ""
    formula = parse_formula(f"always (not wheel_held -> abs({signal}) <= {float(bound)!r})")
    free = evaluate_requirement(formula, log, sample_period_s, None).margin
    if math.isnan(free):  # a run that diverged: the limit's own line says so
        return ""
    if math.isinf(free):
        return "a wheel was held or recovering at every sample (wheel_held)"
    kept = "kept" if free >= 0.0 else "broken"
    return f"where the wheels move freely (not wheel_held) {kept}, margin {free:+.3g}{LIMITS[key].unit}"


def evaluate_limits(
    limits: LimitsSpec, log: SimLog, vehicle: VehicleParams, sample_period_s: float, body: BodyLimits | None = None
) -> list[LimitResult]:
    """Check every limit of the default gate and every limit ``limits`` sets (which replaces the default of its key).

    A limit on the worst or the final sample is judged as a requirement (:func:`limit_formula`,
    :func:`~agvctl.evaluation.requirements.evaluate_requirement`): its margin, the time of its worst sample and its
    window come from the formula's robustness; a limit on a whole-run number has the margin ``bound − value``.
    The first time past the bound comes from its metric's samples (:class:`~agvctl.evaluation.signals.Metric`), so
    a breach always has a first time.

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
    body : BodyLimits or None
        The path's limits on the body's motion, judged by default (:func:`default_limits`).

    Returns
    -------
    list of LimitResult
        In the order of :data:`LIMITS`; ``default`` marks a bound of the default gate.
    """
    defaults = default_limits(vehicle, log, body)
    bounds: dict[str, tuple[float, DefaultLimit | None]] = {k: (d.bound, d) for k, d in defaults.items()}
    bounds.update({key: (bound, None) for key, bound in limits.items()})
    return [_limit_result(key, *bounds[key], log, sample_period_s) for key in LIMITS if key in bounds]


def evaluate_requirements(
    requirements: Sequence[RequirementSpec], log: SimLog, sample_period_s: float, reference: PathParts | None
) -> list[LimitResult]:
    """Judge each of a file's ``[[requirements]]`` on a run.

    Parameters
    ----------
    requirements : sequence of RequirementSpec
        The requirements.
    log : SimLog
        The run's log.
    sample_period_s : float
        T_s, s.
    reference : Reference or None
        The run's reference, which marks the parts of its path.

    Returns
    -------
    list of LimitResult
        One per requirement (``kind = "requirement"``), in their order: kept when the margin is ≥ 0 (a margin
        that could not be judged, NaN, breaks it and its note says why).
    """
    out = []
    for req in requirements:
        v = evaluate_requirement(req, log, sample_period_s, reference)
        out.append(
            LimitResult(
                req.name,
                v.bound,
                v.value,
                bool(v.margin >= 0),
                v.worst_time_s,
                None,
                margin=v.margin,
                window_s=v.window_s,
                kind="requirement",
                formula=req.formula,
                unit=v.unit,
                note=v.note,
            )
        )
    return out


@document_fields
@dataclass(frozen=True)
class RunVerdict:
    """A closed-loop run judged: its metrics, its limits' and its requirements' verdicts."""

    metrics: dict[str, float]
    """Its :func:`~agvctl.evaluation.metrics.closed_loop_metrics`, each in the unit of its name."""
    limits: tuple[LimitResult, ...]
    """Each limit checked (:func:`evaluate_limits`), in the order of :data:`LIMITS`, then each requirement
    (:func:`evaluate_requirements`) in the file's order."""

    @property
    def passed(self) -> bool:
        """Whether every limit and requirement passes (:func:`all_passed`)."""
        return all_passed(list(self.limits))

    @property
    def min_normalised_margin(self) -> float:
        """The smallest margin over its bound of every verdict (:func:`smallest_normalised_margin`)."""
        return smallest_normalised_margin(self.limits)


def judge_run(
    result: RunRecord, limits: LimitsSpec, vehicle: VehicleParams, requirements: Sequence[RequirementSpec] = ()
) -> RunVerdict:
    """A closed-loop run's metrics and every limit's and requirement's verdict: what ``run``, ``check`` and
    ``fuzz`` report.

    Parameters
    ----------
    result : ClosedLoopResult
        The run (:func:`~agvctl.scenario.experiment.run_experiment`).
    limits : LimitsSpec
        The experiment's ``[limits]``.
    vehicle : VehicleParams
        The controller's vehicle, from which the default gate is derived.
    requirements : sequence of RequirementSpec
        The experiment's ``[[requirements]]``, judged on the run's reference's parts.

    Returns
    -------
    RunVerdict
        The metrics and the verdicts.
    """
    metrics = closed_loop_metrics(result)
    reference = getattr(result, "reference", None)
    body = None if reference is None else reference.limits.body
    verdicts = evaluate_limits(limits, result.log, vehicle, result.sample_period_s, body)
    if requirements:
        verdicts += evaluate_requirements(requirements, result.log, result.sample_period_s, reference)
    return RunVerdict(metrics, tuple(verdicts))
