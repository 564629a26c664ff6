"""A pose controller written as a user of agvctl writes one: pure pursuit of a point ahead on the reference.

The law: with the reference's pose, speed v_d and yaw rate ω_d at the current sample, and the pose error in the
vehicle's frame (e_x ahead, e_y to the left, e_θ), the vehicle chases the point ``lookahead_m`` ahead of the
reference point along the reference's heading (behind it when the reference reverses):

    q = (e_x + L cos e_θ, e_y + L sin e_θ)         the point, in the vehicle's frame
    κ = 2 q_y / |q|²                               the arc through it (pure pursuit)
    v = v_d cos e_θ + k e_x                        the speed, closing the gap along the path
    ω = ω_d + v_d κ + k e_θ (1 − s)                the reference's turn, the arc, and the heading in a spin

where s = min(|v_d| / 0.05 m/s, 1) fades the heading term out once the reference moves (pure pursuit steers the
heading then). On the reference (e = 0) q = (L, 0), κ = 0 and the command is the reference's own. The wheel
speeds are those of (v, ω) on the vehicle's wheel separation, scaled together into its top speed.

It uses only what a controller may see (the reference, the pose estimate) and the public API: ``PoseCommand``,
the ``Reference`` and the vehicle's parameters. Name it in an experiment as
``pose = "pure_pursuit.py:PurePursuit"`` (relative to the experiment file) or, with this folder on ``PYTHONPATH``,
``pose = "pure_pursuit:PurePursuit"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from agvctl.controllers.base import PoseCommand


@dataclass(frozen=True)
class PurePursuitSettings:
    """The gains, as an experiment's ``[controller]`` keys."""

    lookahead_m: float = 0.25
    """L: how far ahead of the reference point the vehicle aims, m."""
    gain_1_s: float = 2.0
    """k: how fast the gap along the path and, in a spin, the heading error close, 1/s."""

    def __post_init__(self) -> None:
        if not self.lookahead_m > 0 or not self.gain_1_s > 0:
            raise ValueError(f"lookahead_m and gain_1_s must be > 0 (got {self.lookahead_m}, {self.gain_1_s})")


class PurePursuit:
    """Pure pursuit of a point ahead on the reference, with the reference's feed-forward."""

    Settings = PurePursuitSettings

    def __init__(self, vehicle, settings: PurePursuitSettings | None) -> None:  # noqa: ANN001 - any vehicle
        self.settings = settings or PurePursuitSettings()
        self.half_separation_m = 0.5 * vehicle.wheels.separation_m
        self.sample_period_s = vehicle.control.sample_period_s
        self.max_wheel_speed_m_s = vehicle.derived.max_speed_m_s
        self.grid = np.zeros((0, 5))

    def reset(self, reference) -> None:  # noqa: ANN001
        """Sample the reference once on the control grid: x, y, θ, v, ω per sample."""
        n = int(math.ceil(reference.duration_s / self.sample_period_s)) + 1
        r = reference.sample(np.arange(n) * self.sample_period_s)
        self.grid = np.column_stack([r.x_m, r.y_m, r.theta_rad, r.speed_m_s, r.yaw_rate_rad_s])

    def update(self, t_s: float, pose, wheel_speed_m_s) -> PoseCommand:  # noqa: ANN001
        """The wheel-speed setpoints for the sample starting at ``t_s``."""
        k = min(round(t_s / self.sample_period_s), len(self.grid) - 1)
        x_d, y_d, theta_d, v_d, w_d = self.grid[k].tolist()
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        c, s = math.cos(theta), math.sin(theta)
        e_x = c * (x_d - x) + s * (y_d - y)
        e_y = -s * (x_d - x) + c * (y_d - y)
        e_theta = (theta_d - theta + math.pi) % (2.0 * math.pi) - math.pi
        lookahead = math.copysign(self.settings.lookahead_m, v_d) if v_d != 0.0 else self.settings.lookahead_m
        q_x, q_y = e_x + lookahead * math.cos(e_theta), e_y + lookahead * math.sin(e_theta)
        curvature = 2.0 * q_y / (q_x * q_x + q_y * q_y)
        gain = self.settings.gain_1_s
        moving = min(abs(v_d) / 0.05, 1.0)
        v = v_d * math.cos(e_theta) + gain * e_x
        w = w_d + v_d * curvature + gain * e_theta * (1.0 - moving)
        left, right = v - w * self.half_separation_m, v + w * self.half_separation_m
        peak = max(abs(left), abs(right))
        if peak > self.max_wheel_speed_m_s:
            left, right = left * self.max_wheel_speed_m_s / peak, right * self.max_wheel_speed_m_s / peak
        return PoseCommand(left, right)
