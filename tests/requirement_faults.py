"""Pose controllers built to break a requirement: agvctl's MPC with one fault, named in an experiment as a user's
controller is (``pose = "requirement_faults.py:Late"``)."""

from __future__ import annotations

import numpy as np

from agvctl.controllers.base import PoseCommand
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController


class _Wrapped:
    def __init__(self, vehicle, settings) -> None:  # noqa: ANN001 - any vehicle, no settings
        self.inner = LtvMpcController(vehicle, MpcConfig())

    def reset(self, reference) -> None:  # noqa: ANN001
        self.inner.reset(reference)


class Late(_Wrapped):
    """Tracks the reference 3 s late: still at line speed when the clock is on the dock, at rest 3 s after the end."""

    def update(self, t_s: float, pose, wheel_speed_m_s) -> PoseCommand:  # noqa: ANN001
        return self.inner.update(max(0.0, t_s - 3.0), pose, wheel_speed_m_s)


class Offset(_Wrapped):
    """Believes itself 3 cm to the left of where it is: tracks 3 cm to the right of the path, pivots too."""

    def update(self, t_s: float, pose, wheel_speed_m_s) -> PoseCommand:  # noqa: ANN001
        theta = float(pose[2])
        shifted = np.array([pose[0] - 0.03 * np.sin(theta), pose[1] + 0.03 * np.cos(theta), theta])
        return self.inner.update(t_s, shifted, wheel_speed_m_s)


class Dither(_Wrapped):
    """Adds ±5 cm/s to both setpoints, alternating each sample: no wheel loop follows that within a sample."""

    def __init__(self, vehicle, settings) -> None:  # noqa: ANN001
        super().__init__(vehicle, settings)
        self.sign = 1.0

    def update(self, t_s: float, pose, wheel_speed_m_s) -> PoseCommand:  # noqa: ANN001
        cmd = self.inner.update(t_s, pose, wheel_speed_m_s)
        self.sign = -self.sign
        d = 0.05 * self.sign
        return PoseCommand(cmd.wheel_speed_left_m_s + d, cmd.wheel_speed_right_m_s + d)
