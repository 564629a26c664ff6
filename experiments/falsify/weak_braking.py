"""A pose controller with a planted weakness, for measuring ``agvctl falsify``: the MPC, told a pose shifted ahead
along its heading by a bias that grows steeply with how far off its start is, so it stops short of every stop.

The bias is ``BIAS_M · (h · d)^8`` with h the start heading error over the envelope's 5° and d the start offset over
its 5 cm (both in [0, 1]): nothing at a start on the path, 0.7 mm at h · d = 0.7, 12 mm at the envelope's corner.
With the default gate's 10 mm on the final position, it fails only near that corner (h · d above about 0.93: about
0.2 % of the envelope's uniform starts), and the margin shrinks gradually towards it.

Name it as ``"weak_braking.py:WeakBraking"`` from a file in this folder.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agvctl.controllers.mpc import LtvMpcController, MpcConfig
from agvctl.controllers.registry import POSE_CONTROLLERS, PoseControllerKind

BIAS_M = 0.012
"""The bias at the envelope's corner, m."""
HEADING_MAX_RAD = math.radians(5.0)
OFFSET_MAX_M = 0.05


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
            heading = abs((theta - float(r.theta_rad[0]) + math.pi) % (2.0 * math.pi) - math.pi) / HEADING_MAX_RAD
            offset = math.hypot(x - float(r.x_m[0]), y - float(r.y_m[0])) / OFFSET_MAX_M
            self.bias_m = BIAS_M * min(heading * offset, 1.0) ** 8
        b = self.bias_m
        shifted = np.array([x + b * math.cos(theta), y + b * math.sin(theta), theta, *pose[3:]])
        return self.inner.update(t_s, shifted, wheel_speed_m_s)


WeakBraking = PoseControllerKind(
    _WeakBraking, MpcConfig, "the MPC, stopping short at off-path starts", POSE_CONTROLLERS["mpc"].fit_wheel_loop
)
