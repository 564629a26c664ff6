"""A pose controller with a planted weakness, for measuring ``agvctl falsify``: the MPC, told a pose shifted ahead
along its heading by a bias that grows in proportion to how far off its start is, so it stops short of its stops.

The bias is ``BIAS_M · h · d`` with h the start heading error over the envelope's 5° and d the start offset over
its 5 cm (both in [0, 1]): nothing at a start on the path, 3 mm at h · d = 0.5, 6 mm at the envelope's corner.
It degrades linearly: the final position error, and with it the margin of the default gate's 10 mm bound, worsens
steadily with h · d. The run's end turns the bias into 0.9 to 1.8 times as much final position error, depending
on the path, on top of the MPC's own 0.6-1.5 mm; so the bound breaks only near the corner (h · d above about
0.85) and on paths of the larger factor. For h and d uniform, as the fuzz file draws them,
P(h · d > t) = 1 − t + t · ln t: 1.2 % at t = 0.85, before the share of paths; decision record 0039 has the
measured failure rate. On a path that ends in a turn in place the MPC also turns to correct the shifted pose, so
near the corner the weakness can break the final heading as well.

Name it as ``"weak_braking.py:WeakBraking"`` from a file in this folder.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agvctl.controllers.mpc import LtvMpcController, MpcConfig
from agvctl.controllers.registry import POSE_CONTROLLERS, PoseControllerKind

BIAS_M = 0.006
"""The bias at the envelope's corner (h · d = 1), m."""
HEADING_MAX_RAD = math.radians(5.0)
OFFSET_MAX_M = 0.05


def start_severity(heading_error_rad: float, offset_m: float) -> float:
    """h · d: the start's heading error and offset, each over the envelope's largest, their product (0 to 1)."""
    return min(abs(heading_error_rad) / HEADING_MAX_RAD, 1.0) * min(offset_m / OFFSET_MAX_M, 1.0)


class _WeakBraking:
    def __init__(self, vehicle: Any, settings: MpcConfig | None) -> None:
        self.inner = LtvMpcController(vehicle, settings)
        self.reference: Any = None
        self.bias_m: float | None = None

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.inner, attribute)

    def reset(self, reference: Any) -> None:
        self.inner.reset(reference)
        self.reference, self.bias_m = reference, None

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> Any:
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        if self.bias_m is None:
            r = self.reference.sample(np.array([0.0]))
            heading = (theta - float(r.theta_rad[0]) + math.pi) % (2.0 * math.pi) - math.pi
            offset = math.hypot(x - float(r.x_m[0]), y - float(r.y_m[0]))
            self.bias_m = BIAS_M * start_severity(heading, offset)
        b = self.bias_m
        shifted = np.array([x + b * math.cos(theta), y + b * math.sin(theta), theta, *pose[3:]])
        return self.inner.update(t_s, shifted, wheel_speed_m_s)


WeakBraking = PoseControllerKind(
    _WeakBraking, MpcConfig, "the MPC, stopping short at off-path starts", POSE_CONTROLLERS["mpc"].fit_wheel_loop
)
