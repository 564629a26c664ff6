"""The reference's own wheel speeds as the pose command (``pose = "none"``): no feedback, for contrast."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import PoseCommand
from agvctl.planning.reference import Reference

__all__ = ["FeedForwardPoseController"]


class FeedForwardPoseController:
    """No feedback: the reference's own wheel speeds (``pose = "none"``), for contrast with the MPC.

    The reference is sampled once, vectorised, on its control grid (:attr:`Reference.grid`, cached by the
    reference); an update at a grid time reads the grid, one at or after the reference's end its final rest, and
    any other time samples the reference. Each gives the values :meth:`Reference.sample` gives at that time.
    """

    def __init__(self) -> None:
        self._reference: Reference | None = None
        self._grid_times_s: list[float] = []
        self._grid_left_m_s: list[float] = []
        self._grid_right_m_s: list[float] = []

    def reset(self, reference: Reference) -> None:
        self._reference = reference
        grid = reference.grid
        self._grid_times_s = grid.t_s.tolist()
        self._grid_left_m_s = grid.wheel_speed_left_m_s.tolist()
        self._grid_right_m_s = grid.wheel_speed_right_m_s.tolist()

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        reference = self._reference
        if reference is None:
            raise RuntimeError("FeedForwardPoseController.update called before reset(reference)")
        if t_s >= reference.duration_s:  # at rest at the end: the grid's last time is the first at or after it
            return PoseCommand(self._grid_left_m_s[-1], self._grid_right_m_s[-1])
        k = round(t_s / reference.sample_period_s)
        if 0 <= k < len(self._grid_times_s) and self._grid_times_s[k] == t_s:
            return PoseCommand(self._grid_left_m_s[k], self._grid_right_m_s[k])
        s = reference.sample(np.array([t_s]))
        return PoseCommand(float(s.wheel_speed_left_m_s[0]), float(s.wheel_speed_right_m_s[0]))
