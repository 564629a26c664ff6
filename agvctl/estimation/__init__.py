"""Estimation: what the controllers believe about the vehicle, from its sensors.

* :mod:`~agvctl.estimation.base` — the protocols a pose estimator and a wheel-speed estimator follow, and the
  consistency (NEES) of an estimate against the truth.
* :mod:`~agvctl.estimation.odometry` — the true pose, and dead reckoning from the encoder counts (eqs 39-46 with
  the controller's belief of the radii and the wheel base).
* :mod:`~agvctl.estimation.ekf` — an extended Kalman filter fusing odometry, the gyro and late position fixes.
* :mod:`~agvctl.estimation.wheel_speed` — the motor speeds the wheel loops see: exact, count differences, or a
  Kalman filter on the decoupled motor model (eqs 60-61).
* :mod:`~agvctl.estimation.registry` — the names an experiment file chooses them by.
* :mod:`~agvctl.estimation.offline` — every estimator, and an RTS smoother, run again over a logged run.
"""

from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator, consistency
from agvctl.estimation.ekf import EkfSettings, PoseEkf
from agvctl.estimation.odometry import OdometryEstimator, TruthEstimator
from agvctl.estimation.registry import ESTIMATORS, WHEEL_SPEED_ESTIMATORS
from agvctl.estimation.wheel_speed import CountDifference, ExactSpeed, KalmanWheelSpeed

__all__ = [
    "ESTIMATORS",
    "WHEEL_SPEED_ESTIMATORS",
    "CountDifference",
    "EkfSettings",
    "ExactSpeed",
    "KalmanWheelSpeed",
    "OdometryEstimator",
    "PoseEkf",
    "PoseEstimator",
    "TruthEstimator",
    "WheelSpeedEstimator",
    "consistency",
]
