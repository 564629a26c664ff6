"""Time-optimal, jerk-limited rest-to-rest profiles of one coordinate, computed by Ruckig.

A :class:`JerkProfile` is the coordinate q(t) from q = 0 to q = distance, at zero acceleration and given
speeds at both ends (at rest for :func:`rest_to_rest`), as seven phases of constant jerk (some of zero
duration). Ruckig's intermediate waypoints are never used (in the free edition
they are computed by a network service): each profile is one local ``calculate`` call.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ruckig

from agvctl.config import document_fields
from agvctl.errors import PlanningError

__all__ = ["JerkProfile", "between", "rest_to_rest"]

LIMIT_MARGIN = 1e-9
"""Relative margin kept below each limit, so rounding never lifts a wheel above its limit."""


@document_fields
@dataclass(frozen=True, eq=False)
class JerkProfile:
    """q(t) on [0, duration_s] as phases of constant jerk; each array holds one entry per phase.

    The coordinate q is a distance along the path (m) or a heading change (rad), and the values below are in its
    unit. Within a phase of length τ starting in state (q0, v0, a0) with jerk j:
    q = q0 + v0 τ + a0 τ²/2 + j τ³/6.
    """

    distance: float
    """The coordinate's total change, > 0."""
    duration_s: float
    """The profile's duration, s."""
    phase_durations_s: np.ndarray
    """Each phase's duration (some zero), s."""
    jerk: np.ndarray
    """Each phase's jerk q⃛, per s³."""
    q0: np.ndarray
    """The coordinate at each phase's start."""
    v0: np.ndarray
    """Its rate q̇ at each phase's start, per s."""
    a0: np.ndarray
    """Its acceleration q̈ at each phase's start, per s²."""
    max_velocity: float
    """The limit on ``|q̇|`` the profile was planned for, per s."""
    max_acceleration: float
    """The limit on ``|q̈|``, per s²."""
    max_jerk: float
    """The limit on ``|q⃛|``, per s³."""

    def peaks(self) -> tuple[float, float, float]:
        """Exact peaks of ``|q̇|``, ``|q̈|`` and ``|q⃛|`` over the profile."""
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

    def min_velocity(self) -> float:
        """The lowest q̇ over the profile (at a phase end, or where q̈ = 0 inside a phase)."""
        lowest = math.inf
        for tau, j, v0, a0 in zip(
            self.phase_durations_s.tolist(), self.jerk.tolist(), self.v0.tolist(), self.a0.tolist(), strict=True
        ):  # seven phases: plain floats are faster
            lowest = min(lowest, v0, v0 + a0 * tau + 0.5 * j * tau * tau)
            t_star = -a0 / j if j != 0 else -1.0
            if 0 < t_star < tau:
                lowest = min(lowest, v0 + a0 * t_star + 0.5 * j * t_star * t_star)
        return lowest


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
    """The time-optimal profile from 0 to ``distance``, at rest at both ends, within the given limits.

    Parameters
    ----------
    distance : float
        The coordinate's total change, > 0 (m along a path, rad for a spin).
    max_velocity : float
        The limit on ``|q̇|``, per s in the coordinate's unit.
    max_acceleration : float
        The limit on ``|q̈|``, per s².
    max_jerk : float
        The limit on ``|q⃛|``, per s³.
    solver : _Solver or None
        A Ruckig instance to reuse when planning many profiles (None: a new one).

    Returns
    -------
    JerkProfile
        The profile.

    Raises
    ------
    PlanningError
        Ruckig cannot find a profile (a non-finite or non-positive input).

    Examples
    --------
    >>> profile = rest_to_rest(2.0, max_velocity=0.5, max_acceleration=0.6, max_jerk=3.0)
    >>> print(f"{profile.duration_s:.3f} s")
    5.033 s
    """
    return between(
        distance,
        start_velocity=0.0,
        end_velocity=0.0,
        max_velocity=max_velocity,
        max_acceleration=max_acceleration,
        max_jerk=max_jerk,
        solver=solver,
    )


def _check_inputs(
    distance: float,
    start_velocity: float,
    end_velocity: float,
    max_velocity: float,
    max_acceleration: float,
    max_jerk: float,
) -> None:
    """Refuse a profile's input that is not finite and > 0, or an end speed outside [0, max_velocity)."""
    for name, value in (
        ("distance", distance),
        ("max_velocity", max_velocity),
        ("max_acceleration", max_acceleration),
        ("max_jerk", max_jerk),
    ):
        if not (np.isfinite(value) and value > 0):
            raise PlanningError(f"{name} must be finite and > 0 (got {value:g})")
    for name, value in (("start_velocity", start_velocity), ("end_velocity", end_velocity)):
        if not (np.isfinite(value) and 0.0 <= value <= max_velocity * (1.0 - LIMIT_MARGIN)):
            raise PlanningError(f"{name} must be in [0, {max_velocity:g}] (got {value:g})")


def between(
    distance: float,
    *,
    start_velocity: float,
    end_velocity: float,
    max_velocity: float,
    max_acceleration: float,
    max_jerk: float,
    solver: _Solver | None = None,
) -> JerkProfile:
    """The time-optimal profile from (0, ``start_velocity``, 0) to (``distance``, ``end_velocity``, 0).

    The profile never moves backwards.

    Parameters
    ----------
    distance : float
        The coordinate's total change, > 0 (m along a path, rad for a spin).
    start_velocity : float
        q̇ at the start, in [0, max_velocity), per s.
    end_velocity : float
        q̇ at the end, in [0, max_velocity), per s.
    max_velocity : float
        The limit on ``|q̇|``, per s.
    max_acceleration : float
        The limit on ``|q̈|``, per s².
    max_jerk : float
        The limit on ``|q⃛|``, per s³.
    solver : _Solver or None
        A Ruckig instance to reuse when planning many profiles (None: a new one).

    Returns
    -------
    JerkProfile
        The profile.

    Raises
    ------
    PlanningError
        An input out of range, or Ruckig cannot find a profile within the limits.
    """
    _check_inputs(distance, start_velocity, end_velocity, max_velocity, max_acceleration, max_jerk)
    keep = 1.0 - LIMIT_MARGIN
    s = solver if solver is not None else _Solver()
    s.inp.target_position = [distance]
    s.inp.current_velocity = [start_velocity]
    s.inp.target_velocity = [end_velocity]
    s.inp.max_velocity = [max_velocity * keep]
    s.inp.max_acceleration = [max_acceleration * keep]
    s.inp.max_jerk = [max_jerk * keep]
    try:
        result = s.otg.calculate(s.inp, s.traj)
    except (ruckig.RuckigError, RuntimeError) as exc:  # its input check: a multi-line message, keep one line
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise PlanningError(f"Ruckig refused the profile over {distance:g} ({first})") from None
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise PlanningError(f"Ruckig could not plan {distance:g} within the limits ({result})")
    prof = s.traj.profiles[0][0]
    if prof.brake.duration > 0:  # impossible from within the limits; guard against a silent change
        raise PlanningError("Ruckig returned a braking pre-trajectory")
    n = len(prof.t)
    out = JerkProfile(
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
    if out.min_velocity() < -1e-9 * max_velocity:
        raise PlanningError(f"Ruckig's profile over {distance:g} would move backwards")
    return out
