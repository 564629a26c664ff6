"""Online velocity-command mode: stream target (U, ω) each control period, get wheel references in the limits.

Each :meth:`VelocityCommandPlanner.step` maps the target to wheel speeds (v_l = U − ω b/2, v_r = U + ω b/2;
eqs 39-43 inverted), scales both down together if either exceeds the wheel speed limit (the commanded
curvature is kept), and advances Ruckig's velocity-interface ``update`` loop by one period from the current
state (speed and acceleration of each wheel, the two wheels phase-synchronised where Ruckig can, time-
synchronised otherwise). The wheel accelerations and jerks never exceed their limits, and because every target
speed is within the speed limit, neither does the speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ruckig

from agvctl.config import document_fields
from agvctl.errors import PlanningError
from agvctl.params import VehicleParams
from agvctl.planning.limits import default_jerk_limit_m_s3
from agvctl.planning.profile import LIMIT_MARGIN
from agvctl.planning.spec import WheelLimits

__all__ = ["VelocityCommandPlanner", "WheelCommand"]


@document_fields
@dataclass(frozen=True)
class WheelCommand:
    """The wheel reference after one step of :class:`VelocityCommandPlanner`."""

    t_s: float
    """Its time, s."""
    speed_m_s: float
    """The vehicle's speed U, m/s."""
    yaw_rate_rad_s: float
    """Its yaw rate ω, rad/s."""
    wheel_speed_left_m_s: float
    """The left wheel's speed, m/s."""
    wheel_speed_right_m_s: float
    """The right wheel's speed, m/s."""
    wheel_accel_left_m_s2: float
    """The left wheel's acceleration, m/s²."""
    wheel_accel_right_m_s2: float
    """The right wheel's acceleration, m/s²."""
    wheel_jerk_left_m_s3: float
    """The left wheel's jerk, m/s³."""
    wheel_jerk_right_m_s3: float
    """The right wheel's jerk, m/s³."""
    saturated: bool
    """True if the target (U, ω) asked for a wheel speed above the limit and was scaled down."""


class VelocityCommandPlanner:
    """Jerk-limited tracking of streamed (U, ω) targets, re-planned from the current state every period.

    Parameters
    ----------
    limits : WheelLimits
        The wheel limits the references keep to.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The period of :meth:`step`, s.

    Raises
    ------
    ValueError
        A separation or period that is not finite and > 0.

    Examples
    --------
    >>> cmd = VelocityCommandPlanner(WheelLimits(0.8, 0.657, 3.0), separation_m=0.54, sample_period_s=0.04)
    >>> ref = cmd.step(speed_m_s=0.5, yaw_rate_rad_s=0.0)  # the reference at t = 0.04 s
    >>> print(f"{ref.t_s:.2f} s: {ref.wheel_speed_left_m_s * 1e3:.1f} mm/s, {ref.wheel_accel_left_m_s2:.2f} m/s²")
    0.04 s: 2.4 mm/s, 0.12 m/s²
    """

    def __init__(self, limits: WheelLimits, *, separation_m: float, sample_period_s: float) -> None:
        if not (math.isfinite(separation_m) and separation_m > 0):
            raise ValueError(f"separation_m must be finite and > 0 (got {separation_m})")
        if not (math.isfinite(sample_period_s) and sample_period_s > 0):
            raise ValueError(f"sample_period_s must be finite and > 0 (got {sample_period_s})")
        self.limits = limits
        self.separation_m = float(separation_m)
        self.sample_period_s = float(sample_period_s)
        keep = 1.0 - LIMIT_MARGIN
        self._otg = ruckig.Ruckig(2, self.sample_period_s)
        self._inp = ruckig.InputParameter(2)
        self._out = ruckig.OutputParameter(2)
        self._inp.control_interface = ruckig.ControlInterface.Velocity
        self._inp.synchronization = ruckig.Synchronization.Phase
        self._inp.max_velocity = [limits.wheel_speed_m_s * keep] * 2
        self._inp.max_acceleration = [limits.wheel_accel_m_s2 * keep] * 2
        self._inp.max_jerk = [limits.wheel_jerk_m_s3 * keep] * 2
        self._inp.target_acceleration = [0.0, 0.0]
        self.reset()

    @classmethod
    def for_vehicle(cls, vehicle: VehicleParams, limits: WheelLimits | None = None) -> VelocityCommandPlanner:
        """A planner for ``vehicle``: its separation and sample period; limits default to the vehicle's
        (no-load top speed, a_lim of eq 5, :func:`~agvctl.planning.limits.default_jerk_limit_m_s3`)."""
        if limits is None:
            limits = WheelLimits(
                vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2, default_jerk_limit_m_s3(vehicle)
            )
        return cls(limits, separation_m=vehicle.wheels.separation_m, sample_period_s=vehicle.control.sample_period_s)

    def reset(
        self,
        *,
        wheel_speed_left_m_s: float = 0.0,
        wheel_speed_right_m_s: float = 0.0,
        wheel_accel_left_m_s2: float = 0.0,
        wheel_accel_right_m_s2: float = 0.0,
    ) -> None:
        """Restart at t = 0 from the given wheel state, which must be within the limits."""
        lim = self.limits
        for name, value, bound in (
            ("wheel_speed_left_m_s", wheel_speed_left_m_s, lim.wheel_speed_m_s),
            ("wheel_speed_right_m_s", wheel_speed_right_m_s, lim.wheel_speed_m_s),
            ("wheel_accel_left_m_s2", wheel_accel_left_m_s2, lim.wheel_accel_m_s2),
            ("wheel_accel_right_m_s2", wheel_accel_right_m_s2, lim.wheel_accel_m_s2),
        ):
            if not (math.isfinite(value) and abs(value) <= bound):
                raise ValueError(f"reset: |{name}| must be at most {bound:g} (got {value})")
        self._inp.current_position = [0.0, 0.0]
        self._inp.current_velocity = [wheel_speed_left_m_s, wheel_speed_right_m_s]
        self._inp.current_acceleration = [wheel_accel_left_m_s2, wheel_accel_right_m_s2]
        self._k = 0

    @property
    def t_s(self) -> float:
        """Time of the current state: k·T_s after the last :meth:`reset`."""
        return self._k * self.sample_period_s

    def target_wheel_speeds(self, speed_m_s: float, yaw_rate_rad_s: float) -> tuple[float, float, bool]:
        """``(v_l, v_r, saturated)`` for a target (U, ω), scaled together into the wheel speed limit."""
        if not (math.isfinite(speed_m_s) and math.isfinite(yaw_rate_rad_s)):
            raise ValueError(f"target must be finite (got U={speed_m_s}, ω={yaw_rate_rad_s})")
        half_b = 0.5 * self.separation_m
        v_l, v_r = speed_m_s - yaw_rate_rad_s * half_b, speed_m_s + yaw_rate_rad_s * half_b
        peak = max(abs(v_l), abs(v_r))
        limit = self.limits.wheel_speed_m_s * (1.0 - LIMIT_MARGIN)
        if peak > limit:
            scale = limit / peak
            return v_l * scale, v_r * scale, True
        return v_l, v_r, False

    def step(self, speed_m_s: float, yaw_rate_rad_s: float) -> WheelCommand:
        """Move the target to (U, ω), advance one sample period, and return the reference at the new time."""
        v_l, v_r, saturated = self.target_wheel_speeds(speed_m_s, yaw_rate_rad_s)
        self._inp.target_velocity = [v_l, v_r]
        result = self._otg.update(self._inp, self._out)
        if result not in (ruckig.Result.Working, ruckig.Result.Finished):
            raise PlanningError(f"Ruckig velocity update failed ({result})")
        out = self._out
        (vl, vr), (al, ar), (jl, jr) = out.new_velocity, out.new_acceleration, out.new_jerk
        out.pass_to_input(self._inp)
        self._k += 1
        b = self.separation_m
        return WheelCommand(
            t_s=self.t_s,
            speed_m_s=0.5 * (vr + vl),
            yaw_rate_rad_s=(vr - vl) / b,
            wheel_speed_left_m_s=vl,
            wheel_speed_right_m_s=vr,
            wheel_accel_left_m_s2=al,
            wheel_accel_right_m_s2=ar,
            wheel_jerk_left_m_s3=jl,
            wheel_jerk_right_m_s3=jr,
            saturated=saturated,
        )
