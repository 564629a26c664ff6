"""What shapes an MPC command between the solver and the wheel loops: the setpoints each wheel can follow, the rules
of motion near the path's start and its turning points, and the hard speed and rate limits.

**Reachable setpoints (anti-windup across the cascade).** Each wheel's setpoint stays within a bounded lead of its
*measured* speed: s − v ∈ [−D↓, D↑], D = reach_lead·a_reach·T_s/(1 − e^(−T_s/τ)) for the wheel-loop lag τ
(reach_lead·a_reach·T_s for the kinematic model), a_reach from :class:`~agvctl.feasibility.WheelReach` (current
limit, back-EMF and friction of the controller's model). The previous command s_{−1} is brought into the same
window before the solve, so the setpoints never run away from wheels that are current- or voltage-limited
(:class:`ReachWindow`, :class:`CommandShaper`).

**Rules of motion** (:class:`CommandRule`), applied in order to the solver's (or the fallback's) setpoints:

* :class:`NoBackingAtStart` — at the start of a forward path the vehicle never backs up to a start point it is
  already past.
* :class:`TowardTurningPoint` — where the reference turns in place, a mean speed that would carry the vehicle away
  from the turning point is dropped (the turn kept).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.controllers.mpc.body_bounds import BodyBounds
from agvctl.controllers.mpc.fallback import clamp, limit_command
from agvctl.controllers.mpc.horizon import HorizonReference, turning_in_place
from agvctl.feasibility import WheelReach

__all__ = [
    "CommandRule",
    "CommandShaper",
    "HorizonStep",
    "NoBackingAtStart",
    "ReachWindow",
    "SetpointWindow",
    "TowardTurningPoint",
]

FloatArray = NDArray[np.float64]


class SetpointWindow(NamedTuple):
    """The setpoints each wheel can follow from its measured speed, and the leads that make it.

    Each field holds a (left, right) pair of plain floats (per-sample arithmetic; numpy's scalars cost more).

    Parameters
    ----------
    lower_m_s : tuple of float
        The lowest setpoint of each wheel, v − D↓ (at most v_max), m/s.
    upper_m_s : tuple of float
        The highest setpoint of each wheel, v + D↑ (at least −v_max), m/s.
    lead_down_m_s : tuple of float
        D↓: how far a setpoint may lie below its wheel's speed, m/s.
    lead_up_m_s : tuple of float
        D↑: how far a setpoint may lie above its wheel's speed, m/s.
    """

    lower_m_s: tuple[float, float]
    upper_m_s: tuple[float, float]
    lead_down_m_s: tuple[float, float]
    lead_up_m_s: tuple[float, float]


@document_fields
@dataclass(slots=True)
class HorizonStep:
    """What a solver and the rules see of one MPC step."""

    grid: HorizonReference
    """The reference on the control grid."""
    k: int
    """The window's first grid point (the governed clock, rounded down)."""
    fraction: float
    """The governed clock's position between grid points k and k + 1, in [0, 1)."""
    pose: FloatArray
    """The pose the controller sees (x in m, y in m, θ in rad)."""
    wheel_speed_m_s: FloatArray
    """The measured wheel rim speeds (left, right), m/s."""
    window: SetpointWindow | None
    """The reachable setpoints; None when a wheel speed is not finite (a broken measurement)."""
    previous_m_s: FloatArray
    """The previous command (left, right), brought into the window, m/s."""
    on_main_path: bool
    """Whether the step tracks the path itself (not a docking manoeuvre)."""


class ReachWindow:
    """The reachable-setpoint window of a vehicle (see the module notes).

    Parameters
    ----------
    reach : WheelReach
        The rim accelerations each wheel can reach at its speed (the controller's model of the vehicle).
    lead_factor_s : float
        D/a_reach, the lead per m/s² of reachable acceleration
        (the prediction model's ``lead_factor_s``, :class:`~agvctl.controllers.mpc.prediction.PredictionModel`), s.
    max_wheel_speed_m_s : float
        v_max, m/s: the window always meets the speed box ±v_max.
    """

    def __init__(self, reach: WheelReach, lead_factor_s: float, max_wheel_speed_m_s: float) -> None:
        self.reach = reach
        self.lead_factor_s = lead_factor_s
        self.max_wheel_speed_m_s = max_wheel_speed_m_s

    def __call__(self, wheel_speed_m_s: FloatArray) -> SetpointWindow | None:
        """The window from the measured wheel speeds (left, right), or None if either is not finite. The window
        always meets the speed box, even from a measured speed beyond it."""
        v_l, v_r = float(wheel_speed_m_s[0]), float(wheel_speed_m_s[1])
        if not (math.isfinite(v_l) and math.isfinite(v_r)):
            return None
        up_l, up_r, down_l, down_r = self.reach.accel_pair_m_s2(v_l, v_r)
        f, v_max = self.lead_factor_s, self.max_wheel_speed_m_s
        lead_down_l, lead_down_r, lead_up_l, lead_up_r = down_l * f, down_r * f, up_l * f, up_r * f
        lower_l, lower_r, upper_l, upper_r = v_l - lead_down_l, v_r - lead_down_r, v_l + lead_up_l, v_r + lead_up_r
        # min(·, v_max) and max(·, −v_max) as the comparisons the builtins make (clamp): the same, cheaper
        return SetpointWindow(
            (v_max if v_max < lower_l else lower_l, v_max if v_max < lower_r else lower_r),
            (-v_max if -v_max > upper_l else upper_l, -v_max if -v_max > upper_r else upper_r),
            (lead_down_l, lead_down_r),
            (lead_up_l, lead_up_r),
        )


class CommandRule(Protocol):
    """A rule of motion: the setpoints (left, right; m/s) of one step, reshaped."""

    def reset(self, grid: HorizonReference) -> None:
        """Start on the path sampled by ``grid``."""

    def __call__(self, step: HorizonStep, left: float, right: float) -> tuple[float, float]: ...


class NoBackingAtStart:
    """At the start of a forward path, never back up to a start point the vehicle is already past.

    The start of a forward path: the reference has moved less than 5 cm, and it has no backward but some forward
    speed over the horizon. There the reference comes to the vehicle (the turn is kept, the backward mean speed
    dropped). It handles starts ahead of the path's first point, where a time-indexed tracker would otherwise reverse
    a few centimetres before driving off: a jolt and a change of direction no user asks for, whatever its
    (sub-millimetre) effect on the cross-track error.

    Parameters
    ----------
    horizon : int
        N, the samples ahead whose reference speeds tell a forward start.
    """

    def __init__(self, horizon: int) -> None:
        self.horizon = horizon

    def reset(self, grid: HorizonReference) -> None:
        """Nothing to precompute."""

    def _starting_forward(self, step: HorizonStep) -> bool:
        g, k = step.grid, step.k
        if not step.on_main_path or g.points[k].travel_m >= 0.05:
            return False
        ahead = g.speed_m_s[k : k + self.horizon + 1]
        return bool(np.min(ahead) >= -1e-9 and np.max(ahead) > 1e-6)

    def __call__(self, step: HorizonStep, left: float, right: float) -> tuple[float, float]:
        if not self._starting_forward(step):
            return left, right
        mean = 0.5 * (left + right)
        if mean < 0.0:
            return left - mean, right - mean
        return left, right


class TowardTurningPoint:
    """Where the reference turns in place, the setpoints without their mean speed if it would carry the vehicle away
    from the turning point (the turn kept).

    The path there is the point, so moving away from it moves off the path. Driving along the heading with speed U
    changes the squared distance to the point at −2U·(distance ahead along the heading), so only a mean speed
    towards the point is kept. It handles starts beside a turn in place and turns reached with a lateral error,
    where a wheel breaking away from stiction before the other would otherwise carry the vehicle 1-6 mm further off.

    Parameters
    ----------
    separation_m : float
        The wheel separation b, m, which tells a turn in place
        (:func:`~agvctl.controllers.mpc.horizon.turning_in_place`).
    """

    def __init__(self, separation_m: float) -> None:
        self.separation_m = separation_m

    def reset(self, grid: HorizonReference) -> None:
        """Nothing to precompute."""

    def __call__(self, step: HorizonStep, left: float, right: float) -> tuple[float, float]:
        ref, pose = step.grid.points[step.k], step.pose
        if not turning_in_place(ref.yaw_rate_rad_s, ref.speed_m_s, self.separation_m):
            return left, right
        th = float(pose[2])
        ahead = math.cos(th) * (ref.x_m - float(pose[0])) + math.sin(th) * (ref.y_m - float(pose[1]))
        mean = 0.5 * (left + right)
        if mean * ahead < 0.0:
            return left - mean, right - mean
        return left, right


class CommandShaper:
    """The previous command and everything a command passes after the solver: the rules, the reachable window, the
    bounds on the body's motion (:class:`~agvctl.controllers.mpc.body_bounds.BodyBounds`) and the hard limits
    ``|s|`` ≤ v_max, ``|s − s_prev|`` ≤ a_lim·T_s (:func:`~agvctl.controllers.mpc.fallback.limit_command`).

    Parameters
    ----------
    rules : tuple of CommandRule
        The rules of motion, applied in order.
    max_wheel_speed_m_s : float
        v_max, the largest setpoint either way, m/s.
    max_step_m_s : float
        a_lim·T_s, the largest change of a setpoint from the previous command, m/s.
    body : BodyBounds or None
        The bounds on the body's motion (None: none).
    """

    def __init__(
        self,
        rules: tuple[CommandRule, ...],
        max_wheel_speed_m_s: float,
        max_step_m_s: float,
        body: BodyBounds | None = None,
    ) -> None:
        self.rules = rules
        self.max_wheel_speed_m_s = max_wheel_speed_m_s
        self.max_step_m_s = max_step_m_s
        self.body = body
        self._previous: FloatArray | None = None

    def reset(self, grid: HorizonReference) -> None:
        """Start on a new path: the next command starts from the measured wheel speeds."""
        self._previous = None
        for rule in self.rules:
            rule.reset(grid)

    def previous(self, wheel_speed_m_s: FloatArray, window: SetpointWindow | None) -> FloatArray:
        """The previous command, kept reachable from the wheels (anti-windup); the measured speeds at the first
        step."""
        if self._previous is None:
            self._previous = np.array(wheel_speed_m_s, dtype=np.float64)
        elif window is not None:
            u, a_step = self._previous, self.max_step_m_s
            (lo_l, lo_r), (hi_l, hi_r) = window.lower_m_s, window.upper_m_s
            u_l, u_r = u.tolist()
            u[0] = clamp(u_l, lo_l - a_step, hi_l + a_step)
            u[1] = clamp(u_r, lo_r - a_step, hi_r + a_step)
        return self._previous

    def __call__(self, step: HorizonStep, left: float, right: float) -> tuple[float, float]:
        """The command for ``step`` from the setpoints (left, right) the solver or a fallback gave; remembered as
        the next step's previous command."""
        for rule in self.rules:
            left, right = rule(step, left, right)
        window = step.window
        if window is not None:
            (lo_l, lo_r), (hi_l, hi_r) = window.lower_m_s, window.upper_m_s
            left = clamp(left, lo_l, hi_l)
            right = clamp(right, lo_r, hi_r)
        u = step.previous_m_s
        u_l, u_r = u.tolist()
        body = self.body
        if body is not None and body.active:
            v_l, v_r = step.wheel_speed_m_s.tolist()
            left, right = body.command(left, right, (u_l, u_r), (v_l, v_r))
        left = limit_command(left, u_l, self.max_wheel_speed_m_s, self.max_step_m_s)
        right = limit_command(right, u_r, self.max_wheel_speed_m_s, self.max_step_m_s)
        u[0], u[1] = left, right
        return left, right
