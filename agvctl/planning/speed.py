"""Speed along a path within the wheel limits: a velocity limit per section, forward/backward passes, Ruckig.

A path motion is cut into *sections* (a line or an arc, a smooth join, a stretch of a waypoint spline). On a
section with max ``|κ|`` = k₀, max ``|dκ/ds|`` = k₁ and max ``|d²κ/ds²|`` = k₂, with h = b/2 and the path speed ṡ ≥ 0,
the wheel speeds v = ṡ (d ∓ κ h) (eqs 39-43) and their derivatives are bounded by

    |v|  ≤ ṡ F,                       F  = 1 + k₀ h
    |v̇|  ≤ |s̈| F + ṡ² K₁,             K₁ = k₁ h         (the U² dκ/ds b/2 term)
    |v̈|  ≤ |s⃛| F + 3 ṡ |s̈| K₁ + ṡ³ K₂,  K₂ = k₂ h

so a profile of s with ``|ṡ|`` ≤ V, ``|s̈|`` ≤ A = (a − V² K₁)/F and ``|s⃛|`` ≤ (j − 3 V A K₁ − V³ K₂)/F keeps every wheel
within (v, a, j) at every instant. V is the section's velocity limit: v/F, the segment's speed cap, and, where
the curvature varies, the speed at which the curvature terms take :data:`CURVATURE_SHARE` of the wheel
acceleration and jerk. On a line or an arc (K₁ = K₂ = 0) these are the exact wheel limits divided by F.

The body's limits (:class:`~agvctl.planning.spec.BodyLimits`, where the path sets them) bound the same profile: the
path speed U = ṡ and its derivatives directly (|ṡ| ≤ U_max, |s̈| ≤ the linear acceleration, |s⃛| ≤ the linear jerk),
the yaw rate ω = ṡ κ (ṡ ≤ ω_max/k₀), the centripetal acceleration ṡ² κ (ṡ ≤ √(a_lat/k₀)) and the angular
acceleration ω̇ = s̈ κ + ṡ² dκ/ds (|s̈| ≤ (α_max − V² k₁)/k₀, with V such that V² k₁ takes at most
:data:`CURVATURE_SHARE` of α_max).

The sections join at speeds w_k with s̈ = 0 (so the wheel accelerations are continuous across a join, where
dκ/ds is continuous). The forward pass lowers each w_k+1 to what section k can reach from w_k, the backward
pass each w_k to what section k can brake from; then each section is one time-optimal jerk-limited Ruckig
profile from (0, w_k, 0) to (d_k, w_k+1, 0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from scipy.optimize import brentq

from agvctl.config import document_fields
from agvctl.errors import PlanningError
from agvctl.planning.profile import LIMIT_MARGIN, JerkProfile, _Solver, between
from agvctl.planning.spec import BodyLimits, WheelLimits

__all__ = ["CURVATURE_SHARE", "SectionLimits", "plan_speed", "section_limits"]

CURVATURE_SHARE = 0.85
"""Largest share of the wheel acceleration (and of the jerk) the change of curvature may take on a section;
the rest is left for changing speed along it. Through a smooth join the speed is held at about the
neighbours' speed, so most of the budget goes to the curvature (0.5 and 0.75 made the slalom 15 % and 3 %
slower)."""


@document_fields
@dataclass(frozen=True)
class SectionLimits:
    """Limits on the path coordinate s of one section."""

    length_m: float
    """The section's length, m."""
    speed_m_s: float
    """The largest ``|ṡ|``, m/s."""
    accel_m_s2: float
    """The largest ``|s̈|``, m/s²."""
    jerk_m_s3: float
    """The largest ``|s⃛|``, m/s³."""


def section_limits(
    length_m: float, bounds: Sequence[float], cap_m_s: float | None, limits: WheelLimits, half_b_m: float
) -> SectionLimits:
    """The limits of the path coordinate on a section, from its curvature bounds (see the module notes).

    Parameters
    ----------
    length_m : float
        The section's length, m.
    bounds : sequence of float
        Its curvature bounds (k₀, k₁, k₂): max ``|κ|`` (1/m), ``|dκ/ds|`` (1/m²), ``|d²κ/ds²|`` (1/m³).
    cap_m_s : float or None
        The segment's speed cap (None: none), m/s.
    limits : WheelLimits
        The wheel limits.
    half_b_m : float
        Half the wheel separation, b/2, m.

    Returns
    -------
    SectionLimits
        The limits that keep every wheel within ``limits`` at every instant.
    """
    k0, k1, k2 = bounds
    f, c1, c2 = 1.0 + k0 * half_b_m, k1 * half_b_m, k2 * half_b_m
    v_lim, a_lim, j_lim = limits.wheel_speed_m_s, limits.wheel_accel_m_s2, limits.wheel_jerk_m_s3
    v = v_lim / f
    if cap_m_s is not None:
        v = min(v, cap_m_s)
    if c1 > 0:
        v = min(v, math.sqrt(CURVATURE_SHARE * a_lim / c1))

    def accel(speed: float) -> float:
        return (a_lim - speed**2 * c1) / f

    def spare_jerk(speed: float) -> float:
        return j_lim - 3.0 * speed * accel(speed) * c1 - speed**3 * c2 - (1.0 - CURVATURE_SHARE) * j_lim

    if spare_jerk(v) < 0:
        v = float(brentq(spare_jerk, 0.0, v, xtol=1e-12 * max(v, 1e-12)))
    a = accel(v)
    j = (j_lim - 3.0 * v * a * c1 - v**3 * c2) / f
    return _within_body(SectionLimits(length_m, v, a, j), k0, k1, limits.planned_body)


def _within_body(lim: SectionLimits, k0: float, k1: float, body: BodyLimits) -> SectionLimits:
    """``lim`` lowered to keep the body's motion within ``body`` on a section of max ``|κ|`` k0 and max
    ``|dκ/ds|`` k1 (see the module notes); unchanged where the path sets no body limit."""
    v, a, j = lim.speed_m_s, lim.accel_m_s2, lim.jerk_m_s3
    alpha = body.angular_accel_rad_s2
    caps = [
        body.linear_speed_m_s,
        None if body.angular_speed_rad_s is None or k0 <= 0 else body.angular_speed_rad_s / k0,
        None if body.lateral_accel_m_s2 is None or k0 <= 0 else math.sqrt(body.lateral_accel_m_s2 / k0),
        None if alpha is None or k1 <= 0 else math.sqrt(CURVATURE_SHARE * alpha / k1),
    ]
    v = min([v, *(c for c in caps if c is not None)])
    if body.linear_accel_m_s2 is not None:
        a = min(a, body.linear_accel_m_s2)
    if alpha is not None and k0 > 0:
        a = min(a, (alpha - v * v * k1) / k0)
    if body.linear_jerk_m_s3 is not None:
        j = min(j, body.linear_jerk_m_s3)
    return SectionLimits(lim.length_m, v, a, j)


def _distance_to_change(u: float, w: float, a: float, j: float) -> float:
    """Distance covered changing speed from u to w (either way), at zero acceleration at both ends, in the
    shortest time: the acceleration profile is symmetric, so the distance is (u + w)/2 times the time."""
    dv = abs(w - u)
    t = 2.0 * math.sqrt(dv / j) if dv <= a * a / j else dv / a + a / j
    return 0.5 * (u + w) * t


def _reach(u: float, d: float, a: float, j: float, v_max: float) -> float:
    """The highest speed ≤ v_max reachable from speed u (or brakeable to u) within distance d."""
    if v_max <= u or _distance_to_change(u, v_max, a, j) <= d:
        return v_max
    return float(brentq(lambda w: _distance_to_change(u, w, a, j) - d, u, v_max, xtol=1e-13))


def plan_speed(
    sections: Sequence[SectionLimits], *, solver: _Solver | None = None
) -> tuple[list[JerkProfile], list[float]]:
    """The speed along a chain of sections: one profile of s per section, at rest at both ends of the chain.

    Parameters
    ----------
    sections : sequence of SectionLimits
        The sections, in order.
    solver : _Solver or None
        A Ruckig instance to reuse (None: a new one).

    Returns
    -------
    profiles : list of JerkProfile
        One profile per section.
    junction_speeds_m_s : list of float
        The path speed at each junction, the chain's two ends (0) included, m/s.

    Raises
    ------
    PlanningError
        A profile cannot be planned, with the section's index in ``args[1]``.
    """
    solver = solver if solver is not None else _Solver()
    n = len(sections)
    keep = 1.0 - 4.0 * LIMIT_MARGIN
    w = [0.0] + [min(sections[k - 1].speed_m_s, sections[k].speed_m_s) * keep for k in range(1, n)] + [0.0]
    shrink = 1.0 - 1e-7  # leave the profiles a little room: reaching w_k+1 exactly at d_k is a rounding away
    for k in range(n):  # forward: what each section can reach
        s = sections[k]
        w[k + 1] = min(w[k + 1], _reach(w[k], s.length_m * shrink, s.accel_m_s2, s.jerk_m_s3, s.speed_m_s * keep))
    for k in range(n - 1, -1, -1):  # backward: what each section can brake from
        s = sections[k]
        w[k] = min(w[k], _reach(w[k + 1], s.length_m * shrink, s.accel_m_s2, s.jerk_m_s3, s.speed_m_s * keep))
    profiles = []
    for k, s in enumerate(sections):
        try:
            profiles.append(
                between(
                    s.length_m,
                    start_velocity=w[k],
                    end_velocity=w[k + 1],
                    max_velocity=s.speed_m_s,
                    max_acceleration=s.accel_m_s2,
                    max_jerk=s.jerk_m_s3,
                    solver=solver,
                )
            )
        except PlanningError as exc:
            raise PlanningError(str(exc), k) from None
    return profiles, w
