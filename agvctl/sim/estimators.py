"""Pose estimators: what the controllers believe the pose is (``[controller] localization``).

An estimator sees, every sample, what the vehicle could measure: the true pose (a perfect pose sensor, for the
``truth`` estimator and for any future sensor model) and the measured wheel rim speeds. A new estimator is a class
satisfying :class:`PoseEstimator`, constructed from the controller's vehicle, and one line in :data:`ESTIMATORS`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.params import VehicleParams

__all__ = ["ESTIMATORS", "OdometryEstimator", "PoseEstimator", "TruthEstimator"]

FloatArray = NDArray[np.float64]


class PoseEstimator(Protocol):
    """Estimates the pose (x_m, y_m, theta_rad) once per sample period."""

    def reset(self, pose: FloatArray) -> None:
        """Start from ``pose`` (x_m, y_m, theta_rad), known at t = 0."""

    def update(self, true_pose: FloatArray, wheel_speed_m_s: FloatArray) -> FloatArray:
        """The estimate at this sample from the true pose and the measured rim speeds (left, right) in m/s."""
        ...


class TruthEstimator:
    """The true pose (``localization = "truth"``)."""

    def __init__(self, vehicle: VehicleParams) -> None:
        del vehicle  # the truth needs no model

    def reset(self, pose: FloatArray) -> None:
        del pose

    def update(self, true_pose: FloatArray, wheel_speed_m_s: FloatArray) -> FloatArray:
        return np.array(true_pose, dtype=float)


class OdometryEstimator:
    """Dead reckoning from the measured wheel speeds with the *believed* wheel base (``localization =
    "odometry"``): the kinematics of eqs 39-43 integrated by the trapezoid rule over each sample."""

    def __init__(self, vehicle: VehicleParams) -> None:
        self.separation_m = vehicle.wheels.separation_m
        self.sample_period_s = vehicle.control.sample_period_s
        self._pose = np.zeros(3)
        self._previous: FloatArray | None = None

    def reset(self, pose: FloatArray) -> None:
        self._pose = np.array(pose, dtype=float)
        self._previous = None

    def update(self, true_pose: FloatArray, wheel_speed_m_s: FloatArray) -> FloatArray:
        ts = self.sample_period_s
        if self._previous is not None:
            v_avg = 0.5 * (wheel_speed_m_s + self._previous)
            speed = 0.5 * (v_avg[0] + v_avg[1])
            dtheta = (v_avg[1] - v_avg[0]) / self.separation_m * ts
            mid = self._pose[2] + 0.5 * dtheta
            self._pose = self._pose + np.array([speed * ts * math.cos(mid), speed * ts * math.sin(mid), dtheta])
        self._previous = wheel_speed_m_s
        return self._pose


ESTIMATORS: dict[str, Callable[[VehicleParams], PoseEstimator]] = {
    "truth": TruthEstimator,
    "odometry": OdometryEstimator,
}
"""The estimators an experiment's ``[controller] localization`` can name, each built from the controller's
vehicle."""
