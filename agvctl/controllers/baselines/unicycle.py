"""What the unicycle tracking laws share (Ramsete and LTV-LQR, the siblings of this module).

Both compute a body speed v (m/s) and yaw rate ω (rad/s) from the reference's pose, speed and yaw rate at the
current sample and the pose error in the *robot* frame,

    e_x =  cos θ (x_d − x) + sin θ (y_d − y)      (ahead of the robot)
    e_y = −sin θ (x_d − x) + cos θ (y_d − y)      (to its left)
    e_θ = wrap(θ_d − θ)                           (in [−π, π))

and turn them into wheel rim-speed setpoints with the report's kinematics (eqs 39-43, b the wheel separation
of the controller's vehicle):

    v_l = v − ω b/2,  v_r = v + ω b/2.

If either setpoint exceeds the wheel-speed limit v_max, both are scaled by v_max / max(``|v_l|``, ``|v_r|``): the
curvature ω/v (the path the vehicle turns onto) is kept and only the speed along it is reduced. A law whose
output is not finite (a non-finite pose, say) is replaced by the reference's own wheel speeds for that sample
and reported as ``fallback_feedforward``, so a setpoint is always finite.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import PoseCommand, SolveStatus
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference

__all__ = ["UnicycleTracker", "desaturated_wheel_speeds", "robot_frame_error"]

FloatArray = NDArray[np.float64]


def robot_frame_error(
    pose: FloatArray, x_ref_m: float, y_ref_m: float, theta_ref_rad: float
) -> tuple[float, float, float]:
    """The reference pose seen from the robot: the pose error in the robot's frame.

    Parameters
    ----------
    pose : ndarray
        The robot's pose: x (m), y (m), heading (rad).
    x_ref_m : float
        The reference's x, m.
    y_ref_m : float
        The reference's y, m.
    theta_ref_rad : float
        The reference's heading, rad.

    Returns
    -------
    tuple of float
        (e_x in m ahead, e_y in m to the left, e_θ in rad wrapped to [−π, π)).

    Examples
    --------
    >>> robot_frame_error(np.array([0.0, 0.0, 0.0]), 1.0, 0.5, 0.0)  # 1 m ahead, 0.5 m to the left
    (1.0, 0.5, 0.0)
    """
    x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
    c, s = math.cos(theta), math.sin(theta)
    dx, dy = x_ref_m - x, y_ref_m - y
    e_theta = (theta_ref_rad - theta + math.pi) % (2.0 * math.pi) - math.pi
    return c * dx + s * dy, -s * dx + c * dy, e_theta


def desaturated_wheel_speeds(
    speed_m_s: float, yaw_rate_rad_s: float, separation_m: float, max_wheel_speed_m_s: float
) -> tuple[float, float]:
    """The wheel speeds of a body speed and yaw rate (eqs 39-43), scaled down together into the limit.

    Scaling both by the same factor keeps the curvature ω/v: the vehicle turns onto the same path, slower.

    Parameters
    ----------
    speed_m_s : float
        The body speed v, m/s.
    yaw_rate_rad_s : float
        The yaw rate ω, rad/s.
    separation_m : float
        The wheel separation b, m.
    max_wheel_speed_m_s : float
        The limit on either wheel's ``|speed|``, m/s.

    Returns
    -------
    tuple of float
        (v_l, v_r), m/s.

    Examples
    --------
    >>> desaturated_wheel_speeds(1.0, 1.0, 1.0, 0.75)  # 0.5 and 1.5 m/s asked, 0.75 m/s allowed
    (0.25, 0.75)
    """
    half = 0.5 * separation_m * yaw_rate_rad_s
    return _within(speed_m_s - half, speed_m_s + half, max_wheel_speed_m_s)


def _within(left_m_s: float, right_m_s: float, max_wheel_speed_m_s: float) -> tuple[float, float]:
    """Both wheel speeds scaled by the same factor so that neither exceeds ``max_wheel_speed_m_s``."""
    peak = max(abs(left_m_s), abs(right_m_s))
    if peak > max_wheel_speed_m_s:
        scale = max_wheel_speed_m_s / peak
        return left_m_s * scale, right_m_s * scale
    return left_m_s, right_m_s


class UnicycleTracker:
    """A :class:`~agvctl.controllers.base.PoseController` from a unicycle law ``_law(e, v_d, ω_d) -> (v, ω)``.

    Subclasses set ``max_wheel_speed_m_s`` and implement :meth:`_law`. The reference is sampled once at
    :meth:`reset` on the control grid t_k = k·T_s (any other time is sampled directly).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its wheel separation (m) and sample period (s).
    """

    max_wheel_speed_m_s: float

    def __init__(self, vehicle: VehicleParams) -> None:
        self.vehicle = vehicle
        self.separation_m = vehicle.wheels.separation_m
        self.sample_period_s = vehicle.control.sample_period_s
        self._reference: Reference | None = None
        self._grid: FloatArray = np.zeros((0, 7))
        self._failures = 0

    @property
    def failures(self) -> int:
        """How many updates since construction fell back to the reference's wheel speeds."""
        return self._failures

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` from its time 0."""
        self._reference = reference
        g = reference.sample(np.arange(len(reference.grid_times_s) + 1) * self.sample_period_s)
        self._grid = np.column_stack(
            [g.x_m, g.y_m, g.theta_rad, g.speed_m_s, g.yaw_rate_rad_s, g.wheel_speed_left_m_s, g.wheel_speed_right_m_s]
        )

    @property
    def reference_rows(self) -> FloatArray:
        """The reference on the control grid since the last :meth:`reset`: row k at t = k·T_s holds x (m), y (m),
        heading (rad), speed (m/s), yaw rate (rad/s) and the left and right wheel speeds (m/s); from the last row on
        the reference rests at its end."""
        return self._grid

    def _reference_at(self, t_s: float) -> FloatArray:
        """(x_m, y_m, theta_rad, speed_m_s, yaw_rate_rad_s, left_m_s, right_m_s) of the reference at ``t_s``."""
        if self._reference is None:
            raise RuntimeError(f"{type(self).__name__}.update called before reset(reference)")
        k = round(t_s / self.sample_period_s)
        row: FloatArray
        if 0 <= k < len(self._grid) and abs(t_s - k * self.sample_period_s) <= 1e-9:
            row = self._grid[k]
            return row
        if t_s >= self._reference.duration_s:  # at rest at the end
            row = self._grid[-1]
            return row
        g = self._reference.sample(np.array([t_s]))
        return np.array(
            [
                g.x_m[0],
                g.y_m[0],
                g.theta_rad[0],
                g.speed_m_s[0],
                g.yaw_rate_rad_s[0],
                g.wheel_speed_left_m_s[0],
                g.wheel_speed_right_m_s[0],
            ]
        )

    def _law(self, error: tuple[float, float, float], speed_m_s: float, yaw_rate_rad_s: float) -> tuple[float, float]:
        """(v in m/s, ω in rad/s) from the robot-frame error (e_x, e_y, e_θ) and the reference's v_d, ω_d."""
        raise NotImplementedError

    def update(self, t_s: float, pose: FloatArray, wheel_speed_m_s: FloatArray) -> PoseCommand:
        """Wheel rim-speed setpoints (left, right) in m/s for the sample starting at ``t_s``."""
        t0 = time.perf_counter()
        r = self._reference_at(t_s)
        error = robot_frame_error(pose, float(r[0]), float(r[1]), float(r[2]))
        speed, yaw_rate = self._law(error, float(r[3]), float(r[4]))
        status: SolveStatus = "solved"
        left, right = desaturated_wheel_speeds(speed, yaw_rate, self.separation_m, self.max_wheel_speed_m_s)
        if not (math.isfinite(left) and math.isfinite(right)):
            self._failures += 1
            status = "fallback_feedforward"
            left, right = _within(float(r[5]), float(r[6]), self.max_wheel_speed_m_s)
        return PoseCommand(left, right, time.perf_counter() - t0, status)
