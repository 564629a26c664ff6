"""Evaluate an experiment's ``[limits]`` on a closed-loop run: value, pass/fail, worst and first times."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.params import VehicleParams
from agvctl.sim.experiment import LimitsSpec
from agvctl.sim.log import SimLog

__all__ = ["LimitResult", "all_passed", "evaluate_limits", "format_limit_message", "limit_series"]


def format_limit_message(
    limit: str, value: float, bound: float, passed: bool, worst_time_s: float | None, first_time_s: float | None
) -> str:
    """``"tracking_error_max_m: 0.0012 m against the limit 0.03 m — ok"`` (with the times when violated)."""
    units = {"_m": " m", "_m_s": " m/s", "_m_s2": " m/s²", "_a": " A", "_deg": "°", "_ms": " ms"}
    suffix = next((u for k, u in sorted(units.items(), key=lambda kv: -len(kv[0])) if limit.endswith(k)), "")
    text = f"{limit}: {value:.6g}{suffix} against the limit {bound:.6g}{suffix}"
    if passed:
        return text + " — ok"
    text += " — VIOLATED"
    if worst_time_s is not None:
        text += f", worst at t = {worst_time_s:.2f} s"
    if first_time_s is not None:
        text += f", first exceeded at t = {first_time_s:.2f} s"
    return text


@dataclass(frozen=True)
class LimitResult:
    """One limit checked on one run."""

    limit: str
    bound: float
    value: float
    passed: bool
    worst_time_s: float | None
    """When the signal behind the limit was worst (None for counts that never happened)."""
    first_time_s: float | None
    """When the signal first went past the bound (None if it never did)."""
    default: bool = False
    """True when the bound is a default (wheel_accel_m_s2 = the vehicle's a_lim), not set in the file."""

    @property
    def message(self) -> str:
        return format_limit_message(
            self.limit, self.value, self.bound, self.passed, self.worst_time_s, self.first_time_s
        )

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        d["message"] = self.message
        return d


def limit_series(log: SimLog, key: str) -> NDArray[np.float64] | None:
    """The per-sample signal whose peak a limit bounds (None for limits on a whole-run statistic)."""
    if key == "wheel_speed_m_s":
        return np.maximum(np.abs(log["wheel_speed_left_m_s"]), np.abs(log["wheel_speed_right_m_s"]))
    if key == "wheel_accel_m_s2":
        return np.maximum(log["wheel_accel_peak_left_m_s2"], log["wheel_accel_peak_right_m_s2"])
    if key == "motor_current_a":
        return np.maximum(log["current_peak_left_a"], log["current_peak_right_a"])
    if key in ("tracking_error_max_m", "tracking_error_rms_m", "final_position_error_m"):
        return np.asarray(log["position_error_m"])
    if key == "heading_error_max_deg":
        return np.degrees(np.abs(log["heading_error_rad"]))
    if key in ("solve_time_p99_ms",):
        return log["solve_time_s"] * 1e3
    return None


def _first_above(t: NDArray[np.float64], series: NDArray[np.float64], bound: float) -> float | None:
    idx = np.nonzero(series > bound)[0]
    return float(t[idx[0]]) if idx.size else None


def evaluate_limits(
    limits: LimitsSpec, log: SimLog, metrics: dict[str, float], vehicle: VehicleParams, sample_period_s: float
) -> list[LimitResult]:
    """Check every limit that is set, plus the wheel acceleration against a_lim (eq 5) when none is set."""
    t = log["t_s"]
    items = list(limits.items())
    defaults = set()
    if limits.wheel_accel_m_s2 is None:
        items.append(("wheel_accel_m_s2", vehicle.derived.accel_limit_m_s2))
        defaults.add("wheel_accel_m_s2")
    results = []
    for key, bound in items:
        series = limit_series(log, key)
        if key == "wheel_speed_m_s":
            value = metrics["peak_wheel_speed_m_s"]
        elif key == "wheel_accel_m_s2":
            value = metrics["peak_wheel_accel_m_s2"]
        elif key == "motor_current_a":
            value = metrics["peak_motor_current_a"]
        else:
            value = float(metrics[key])
        passed = value <= bound * (1 + 1e-12)
        worst: float | None
        first: float | None
        if series is not None:
            worst = float(t[int(np.argmax(series))])
            first = _first_above(t, series, bound)
            if key == "final_position_error_m":
                worst = first = float(t[-1])
            elif key == "tracking_error_rms_m":
                first = None
        else:
            flags = _event_flags(log, key, sample_period_s)
            idx = np.nonzero(flags)[0]
            first = float(t[idx[0]]) if idx.size else None
            worst = first
        results.append(LimitResult(key, bound, value, bool(passed), worst, None if passed else first, key in defaults))
    return results


def _event_flags(log: SimLog, key: str, sample_period_s: float) -> NDArray[np.bool_]:
    if key == "current_limited_fraction":
        return np.asarray((log["current_limited_left"] > 0) | (log["current_limited_right"] > 0))
    if key == "da_saturation_fraction":
        return np.asarray((log["da_clipped_left"] > 0) | (log["da_clipped_right"] > 0))
    if key == "deadline_misses":
        return np.asarray(log["solve_time_s"] > sample_period_s)
    if key == "solver_failures":
        return np.asarray(log["solver_status"] > 0)
    raise KeyError(key)


def all_passed(results: list[LimitResult]) -> bool:
    return all(r.passed for r in results) and not any(math.isnan(r.value) for r in results)
