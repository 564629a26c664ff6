"""Time-optimal, jerk-limited rest-to-rest profiles of one coordinate, computed by Ruckig.

A :class:`JerkProfile` is the coordinate q(t) from q = 0 at rest to q = distance at rest, as seven phases of
constant jerk (some of zero duration). Ruckig's intermediate waypoints are never used (in the free edition
they are computed by a network service): each profile is one local ``calculate`` call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ruckig

from agvctl.errors import PlanningError

__all__ = ["JerkProfile", "rest_to_rest"]

LIMIT_MARGIN = 1e-9
"""Relative margin kept below each limit, so rounding never lifts a wheel above its limit."""


@dataclass(frozen=True, eq=False)
class JerkProfile:
    """q(t) on [0, duration_s] as phases of constant jerk; each array holds one entry per phase.

    ``phase_durations_s`` and ``jerk`` describe the phases; ``q0``, ``v0``, ``a0`` the state at each phase's
    start (v = q̇, a = q̈). Within a phase of length τ starting in state (q0, v0, a0) with jerk j:
    q = q0 + v0 τ + a0 τ²/2 + j τ³/6.
    """

    distance: float
    duration_s: float
    phase_durations_s: np.ndarray
    jerk: np.ndarray
    q0: np.ndarray
    v0: np.ndarray
    a0: np.ndarray
    max_velocity: float
    max_acceleration: float
    max_jerk: float

    def peaks(self) -> tuple[float, float, float]:
        """Exact peaks of |q̇|, |q̈| and |q⃛| over the profile."""
        tau, j, v0, a0 = self.phase_durations_s, self.jerk, self.v0, self.a0
        v_end = v0 + a0 * tau + 0.5 * j * tau**2
        a_end = a0 + j * tau
        candidates = [np.abs(v0), np.abs(v_end)]
        with np.errstate(divide="ignore", invalid="ignore"):
            t_star = np.where(j != 0, -a0 / np.where(j != 0, j, 1.0), -1.0)  # where q̈ = 0 inside a phase
        inside = (t_star > 0) & (t_star < tau)
        candidates.append(np.where(inside, np.abs(v0 + a0 * t_star + 0.5 * j * t_star**2), 0.0))
        v_peak = float(np.max(candidates))
        a_peak = float(max(np.max(np.abs(a0)), np.max(np.abs(a_end))))
        j_peak = float(np.max(np.where(tau > 0, np.abs(j), 0.0)))
        return v_peak, a_peak, j_peak


class _Solver:
    """One reusable 1-DOF Ruckig instance (construction costs more than a calculation)."""

    def __init__(self) -> None:
        self.otg = ruckig.Ruckig(1)
        self.inp = ruckig.InputParameter(1)
        self.traj = ruckig.Trajectory(1)
        self.inp.current_position = [0.0]
        self.inp.current_velocity = [0.0]
        self.inp.current_acceleration = [0.0]
        self.inp.target_velocity = [0.0]
        self.inp.target_acceleration = [0.0]


def rest_to_rest(
    distance: float,
    *,
    max_velocity: float,
    max_acceleration: float,
    max_jerk: float,
    solver: _Solver | None = None,
) -> JerkProfile:
    """The time-optimal profile from 0 to ``distance`` > 0, at rest at both ends, within the given limits.

    ``solver`` lets a caller planning many profiles reuse one Ruckig instance. Raises :class:`PlanningError`
    if Ruckig cannot find a profile (non-finite or non-positive input).
    """
    for name, value in (("distance", distance), ("max_velocity", max_velocity),
                        ("max_acceleration", max_acceleration), ("max_jerk", max_jerk)):
        if not (np.isfinite(value) and value > 0):
            raise PlanningError(f"rest_to_rest: {name} must be finite and > 0 (got {value})")
    s = solver if solver is not None else _Solver()
    keep = 1.0 - LIMIT_MARGIN
    s.inp.target_position = [distance]
    s.inp.max_velocity = [max_velocity * keep]
    s.inp.max_acceleration = [max_acceleration * keep]
    s.inp.max_jerk = [max_jerk * keep]
    try:
        result = s.otg.calculate(s.inp, s.traj)
    except ruckig.RuckigError:  # raised (with a multi-line dump) for inputs it cannot handle numerically
        raise PlanningError(f"Ruckig could not plan {distance:g} within the limits (numerical failure)") from None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PlanningError(f"Ruckig could not plan {distance:g} within the limits ({result})")
    prof = s.traj.profiles[0][0]
    if prof.brake.duration > 0:  # impossible from rest within the limits; guard against a silent change
        raise PlanningError("Ruckig returned a braking pre-trajectory for a rest-to-rest motion")
    n = len(prof.t)
    return JerkProfile(
        distance=distance,
        duration_s=float(s.traj.duration),
        phase_durations_s=np.array(prof.t, dtype=float),
        jerk=np.array(prof.j, dtype=float),
        q0=np.array(prof.p[:n], dtype=float),
        v0=np.array(prof.v[:n], dtype=float),
        a0=np.array(prof.a[:n], dtype=float),
        max_velocity=max_velocity,
        max_acceleration=max_acceleration,
        max_jerk=max_jerk,
    )
