"""Evaluate an experiment's ``[limits]`` on a closed-loop run: value, pass/fail, worst and first times.

What each limit bounds (its metric, its per-sample series, its unit) is the table
:data:`agvctl.sim.limits.LIMITS`; this module only applies it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from agvctl.params import VehicleParams
from agvctl.sim.limits import LIMITS, LimitsSpec
from agvctl.sim.log import SimLog

__all__ = ["LimitResult", "all_passed", "evaluate_limits", "format_limit_message"]


def format_limit_message(
    limit: str, value: float, bound: float, passed: bool, worst_time_s: float | None, first_time_s: float | None
) -> str:
    """``"tracking_error_max_m: 0.0012 m against the limit 0.03 m — ok"`` (with the times when violated)."""
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


def evaluate_limits(
    limits: LimitsSpec, log: SimLog, metrics: dict[str, float], vehicle: VehicleParams, sample_period_s: float
) -> list[LimitResult]:
    """Check every limit that is set, plus the wheel acceleration against a_lim (eq 5) when none is set."""
    items = limits.items()
    defaults = set()
    if "wheel_accel_m_s2" not in limits.bounds:
        items.append(("wheel_accel_m_s2", vehicle.derived.accel_limit_m_s2))
        defaults.add("wheel_accel_m_s2")
    results = []
    for key, bound in items:
        value = float(metrics[LIMITS[key].metric])
        passed = value <= bound * (1 + 1e-12)
        worst, first = _times(key, log, bound, sample_period_s)
        results.append(LimitResult(key, bound, value, bool(passed), worst, None if passed else first, key in defaults))
    return results


def all_passed(results: list[LimitResult]) -> bool:
    return all(r.passed for r in results) and not any(math.isnan(r.value) for r in results)
