"""Pose estimators: what the controllers believe the pose is (``[controller] localization``).

An estimator sees, every sample, the :class:`~agvctl.sim.sensors.Measurements` of the true vehicle's sensors:
latched encoder counts, the gyro, the position fixes arriving, the rim speeds the wheel loops measured, and the
true pose (a perfect pose sensor, for the ``truth`` estimator only). A new estimator is a class satisfying
:class:`PoseEstimator`, constructed from the controller's vehicle, and one line in :data:`ESTIMATORS`. One that
also has a ``pose_covariance`` (3×3) and a ``last_nis`` attribute is checked for consistency (NEES, NIS) in the
log, as :class:`~agvctl.sim.ekf.PoseEkf` is.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.params import VehicleParams
from agvctl.sim.ekf import PoseEkf
from agvctl.sim.log import SimLog
from agvctl.sim.sensors import Measurements

__all__ = [
    "ESTIMATORS",
    "OdometryEstimator",
    "PoseEstimator",
    "TruthEstimator",
    "consistency",
    "estimate_heading_error_rad",
    "estimate_position_error_m",
]

FloatArray = NDArray[np.float64]


class PoseEstimator(Protocol):
    """Estimates the pose (x_m, y_m, theta_rad) once per sample period."""

    def reset(self, pose: FloatArray) -> None:
        """Start from ``pose`` (x_m, y_m, theta_rad), known at t = 0."""

    def update(self, measurements: Measurements) -> FloatArray:
        """The estimate at this sample from this sample's measurements."""
        ...


class TruthEstimator:
    """The true pose (``localization = "truth"``)."""

    def __init__(self, vehicle: VehicleParams) -> None:
        del vehicle  # the truth needs no model

    def reset(self, pose: FloatArray) -> None:
        del pose

    def update(self, measurements: Measurements) -> FloatArray:
        return measurements.true_pose


class OdometryEstimator:
    """Dead reckoning from the encoder counts with the *believed* wheel radii and base (``localization =
    "odometry"``): each sample's travel Δn·q·r/N per wheel (eqs 26, 29), eqs 39-43 with the midpoint heading."""

    def __init__(self, vehicle: VehicleParams) -> None:
        w, m = vehicle.wheels, vehicle.motor
        q = 2.0 * math.pi / vehicle.sensors.encoder_counts_per_rev
        self.metres_per_count = np.array(
            [q * w.radius_left_m / m.left.gear_ratio, q * w.radius_right_m / m.right.gear_ratio]
        )
        self.separation_m = w.separation_m
        self._pose = np.zeros(3)
        self._previous: NDArray[np.int64] | None = None

    def reset(self, pose: FloatArray) -> None:
        self._pose = np.array(pose, dtype=float)
        self._previous = None

    def update(self, measurements: Measurements) -> FloatArray:
        counts = measurements.encoder_counts
        if self._previous is not None:
            d_l, d_r = (counts - self._previous) * self.metres_per_count
            ds = 0.5 * (d_l + d_r)  # eq 39
            dtheta = (d_r - d_l) / self.separation_m  # eq 40
            mid = self._pose[2] + 0.5 * dtheta
            self._pose = self._pose + np.array([ds * math.cos(mid), ds * math.sin(mid), dtheta])  # eqs 41-43
        self._previous = counts
        return self._pose


def consistency(estimator: object, estimate: FloatArray, true_pose: FloatArray) -> tuple[float, ...]:
    """``(σ_x m, σ_y m, σ_θ rad, NEES, NIS)`` of an estimator with a ``pose_covariance``, NaN for one without.

    NEES is eᵀP⁻¹e with e the estimate's error against the truth (heading wrapped), 3 degrees of freedom; NIS the
    estimator's ``last_nis`` (NaN at samples without a fix). In plain floats (Cramer's rule on the symmetric 3×3
    P): it runs every sample, where numpy's per-call cost would exceed the arithmetic.
    """
    cov = getattr(estimator, "pose_covariance", None)
    if cov is None:
        return (math.nan,) * 5
    (a, b, c), (_, d, e), (_, _, f) = np.asarray(cov, dtype=float).tolist()
    x, y, t = (np.asarray(estimate, dtype=float) - true_pose).tolist()
    t = wrap_angle(t)
    # adj(P) of P = [[a b c] [b d e] [c e f]], and det P
    A, B, C = d * f - e * e, c * e - b * f, b * e - c * d
    D, E, F = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * A + b * B + c * C
    nees = (A * x * x + D * y * y + F * t * t + 2 * (B * x * y + C * x * t + E * y * t)) / det
    nis = float(getattr(estimator, "last_nis", math.nan))
    return (math.sqrt(a), math.sqrt(d), math.sqrt(f), nees, nis)


def estimate_position_error_m(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """|estimated − true position| per sample (m)."""
    return np.asarray(np.hypot(log["est_x_m"] - log["x_m"], log["est_y_m"] - log["y_m"]))


def estimate_heading_error_rad(log: SimLog, ts: float = 0.0) -> NDArray[np.float64]:
    """|estimated − true heading| per sample, wrapped (rad)."""
    return np.asarray(np.abs(wrap_angle(log["est_theta_rad"] - log["theta_rad"])))


ESTIMATORS: dict[str, Callable[[VehicleParams], PoseEstimator]] = {
    "truth": TruthEstimator,
    "odometry": OdometryEstimator,
    "ekf": PoseEkf,
}
"""The estimators an experiment's ``[controller] localization`` can name, each built from the controller's
vehicle."""
