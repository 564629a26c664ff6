"""The estimators an experiment can name: pose estimators by ``[controller] localization``, wheel-speed estimators
by ``[controller] wheel_speed``.

A new estimator is one module (a class satisfying :class:`~agvctl.estimation.base.PoseEstimator` or
:class:`~agvctl.estimation.base.WheelSpeedEstimator`, constructed from the controller's vehicle) and one line here;
the experiment loader validates the names against these tables.
"""

from __future__ import annotations

from collections.abc import Callable

from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator
from agvctl.estimation.ekf import PoseEkf
from agvctl.estimation.odometry import OdometryEstimator, TruthEstimator
from agvctl.estimation.wheel_speed import CountDifference, ExactSpeed, KalmanWheelSpeed
from agvctl.params import VehicleParams

__all__ = ["ESTIMATORS", "WHEEL_SPEED_ESTIMATORS"]

ESTIMATORS: dict[str, Callable[[VehicleParams], PoseEstimator]] = {
    "truth": TruthEstimator,
    "odometry": OdometryEstimator,
    "ekf": PoseEkf,
}
"""The estimators an experiment's ``[controller] localization`` can name, each built from the controller's
vehicle."""

WHEEL_SPEED_ESTIMATORS: dict[str, Callable[[VehicleParams], WheelSpeedEstimator]] = {
    "exact": ExactSpeed,
    "count_difference": CountDifference,
    "kalman": KalmanWheelSpeed,
}
"""The wheel-speed estimators an experiment's ``[controller] wheel_speed`` can name, built from the controller's
vehicle."""
