"""The limits an experiment can set (``[limits]``): one table, name → metric → series → unit.

Adding a limit is one entry in :data:`LIMITS`: the experiment loader validates ``[limits]`` against it, and
:func:`agvctl.checks.limits.evaluate_limits` and the messages of ``run`` and ``check`` read it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.config import convert_value, did_you_mean, join_key
from agvctl.errors import ConfigError
from agvctl.sim.estimators import estimate_heading_error_rad, estimate_position_error_m
from agvctl.sim.log import SimLog

__all__ = ["LIMITS", "Limit", "LimitsSpec"]

Series = Callable[[SimLog, float], NDArray[np.float64]]


@dataclass(frozen=True)
class Limit:
    """One limit: an upper bound on a metric of :func:`~agvctl.sim.metrics.closed_loop_metrics`."""

    metric: str
    """The metric the bound applies to."""
    unit: str
    """As printed after the value (``" m"``, ``"°"``; empty for fractions and counts)."""
    series: Series
    """The per-sample signal behind the metric, from the log and T_s (s): its worst sample and the first one past
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
    "wheel_accel_m_s2": Limit(
        "peak_wheel_accel_m_s2", " m/s²", lambda log, ts: _both(log, "wheel_accel_peak_{}_m_s2"), "peak", "positive"
    ),
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
}
"""Every limit an experiment's ``[limits]`` table may set, in the order they are reported."""

_VALUES: dict[str, tuple[type, dict[str, float]]] = {
    "positive": (float, {"gt": 0.0}),
    "fraction": (float, {"ge": 0.0, "le": 1.0}),
    "count": (int, {"ge": 0}),
}


@dataclass(frozen=True)
class LimitsSpec:
    """``[limits]``: upper bounds by name of :data:`LIMITS` (all optional)."""

    bounds: dict[str, float] = field(default_factory=dict)

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> LimitsSpec:
        bounds: dict[str, float] = {}
        for key, value in data.items():
            if key not in LIMITS:
                hint = did_you_mean(key, LIMITS, prefix.split(".") if prefix else [])
                raise ConfigError(source, join_key(prefix, key), "unknown key" + hint)
            tp, meta = _VALUES[LIMITS[key].values]
            bounds[key] = convert_value(tp, value, source, join_key(prefix, key), meta)
        return cls(bounds)

    def to_file(self) -> dict[str, Any]:
        return dict(self.bounds)

    def items(self) -> list[tuple[str, float]]:
        """The limits that are set, as (key, bound), in the order of :data:`LIMITS`."""
        return [(key, float(self.bounds[key])) for key in LIMITS if key in self.bounds]
