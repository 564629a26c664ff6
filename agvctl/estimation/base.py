"""The estimators' protocols, and the consistency of an estimate against the truth.

Every sample the closed loop hands the pose estimator the :class:`~agvctl.sensing.Measurements` of the true
vehicle's sensors (latched encoder counts, the gyro, the position fixes arriving, the rim speeds the wheel loops
measured), and the wheel-speed estimator the latched counts: what a real one would receive. The truth stays on
the simulator's side; only a component that declares itself a perfect sensor (:class:`TruthSensor`: the ``exact``
wheel speeds and the ``truth`` localization) is handed it, and the loop checks that once, at set-up.

The optional parts are small protocols of their own, checked once at set-up too: an estimator with a covariance
(:class:`PoseCovarianceEstimator`) is checked for consistency (NEES, NIS) in the log, as
:class:`~agvctl.estimation.ekf.PoseEkf` is; one that learns the odometry calibration (:class:`CalibrationEstimator`)
has it logged (:data:`CALIBRATION_COLUMNS`).
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.sensing import Measurements

__all__ = [
    "CALIBRATION_COLUMNS",
    "CalibrationEstimator",
    "PoseCovarianceEstimator",
    "PoseEstimator",
    "TruthSensor",
    "WheelSpeedEstimator",
    "consistency",
]

CALIBRATION_COLUMNS = (
    "est_radius_error_left",
    "est_radius_error_right",
    "est_separation_error",
    "est_sigma_radius_error_left",
    "est_sigma_radius_error_right",
    "est_sigma_separation_error",
    "fixes_rejected",
    "fixes_dropped",
    "fixes_reordered",
)
"""The log columns of an estimator's odometry calibration and its fix bookkeeping at each sample: the relative
errors ε of the believed left and right wheel radii and wheel base (true = believed · (1 + ε)) and their σ, and
the fixes rejected by the gate, dropped as too old and applied out of order since the start (NaN for an estimator
without them)."""

FloatArray = NDArray[np.float64]


class PoseEstimator(Protocol):
    """Estimates the pose (x_m, y_m, theta_rad) once per sample period."""

    def reset(self, pose: FloatArray) -> None:
        """Start from ``pose`` (x_m, y_m, theta_rad), known at t = 0."""

    def update(self, measurements: Measurements) -> FloatArray:
        """The estimate at this sample from this sample's measurements."""
        ...


class WheelSpeedEstimator(Protocol):
    """Motor speeds (left, right) in rad/s at t_k, from the latched counts."""

    def reset(self) -> None:
        """Forget the past (the vehicle starts at rest)."""

    def update(self, encoder_counts: NDArray[np.int64]) -> FloatArray:
        """The speeds at this sample."""
        ...

    def applied(self, da_command_v: FloatArray) -> None:
        """The DA voltage command (left, right, V) held over the coming sample."""


@runtime_checkable
class TruthSensor(Protocol):
    """A perfect sensor in an estimator's place (``wheel_speed = "exact"``, ``localization = "truth"``): the
    simulator hands it the true state every sample, before the estimator's ``update``. Only a component that declares
    this method is handed the truth; a real estimator never is."""

    def observe_truth(self, pose: FloatArray, omega_motor_rad_s: FloatArray) -> None:
        """The true pose (x_m, y_m, theta_rad) and motor speeds (left, right, rad/s) at this sample."""


@runtime_checkable
class PoseCovarianceEstimator(Protocol):
    """A pose estimator that knows its uncertainty: logged as σ, NEES and NIS (:func:`consistency`), and handed to a
    pose controller that observes it (:class:`~agvctl.controllers.base.PoseCovarianceObserver`)."""

    @property
    def pose_covariance(self) -> FloatArray:
        """The pose's 3×3 covariance (m², m rad, rad²) after the latest update."""
        ...

    @property
    def last_nis(self) -> float:
        """The NIS of the last fix arriving at the latest update (NaN when none did)."""
        ...


@runtime_checkable
class CalibrationEstimator(Protocol):
    """A pose estimator that learns the odometry calibration: logged every sample (:data:`CALIBRATION_COLUMNS`)."""

    def readout(self) -> tuple[float, ...]:
        """The values of :data:`CALIBRATION_COLUMNS` at this sample, as plain floats."""
        ...


def consistency(estimator: PoseCovarianceEstimator, estimate: FloatArray, true_pose: FloatArray) -> tuple[float, ...]:
    """How consistent a pose estimator's covariance is with its actual error, at one sample.

    NEES is eᵀP⁻¹e with e the estimate's error against the truth (heading wrapped), 3 degrees of freedom; NIS the
    estimator's ``last_nis`` (NaN at samples without a fix). In plain floats (Cramer's rule on the symmetric 3×3
    P): it runs every sample, where numpy's per-call cost would exceed the arithmetic.

    Parameters
    ----------
    estimator : PoseCovarianceEstimator
        The pose estimator, with its covariance.
    estimate : ndarray
        Its estimate: x (m), y (m), heading (rad).
    true_pose : ndarray
        The true pose, in the same units.

    Returns
    -------
    tuple of float
        (σ_x in m, σ_y in m, σ_θ in rad, NEES, NIS).
    """
    (a, b, c), (_, d, e), (_, _, f) = np.asarray(estimator.pose_covariance, dtype=float).tolist()
    x, y, t = (np.asarray(estimate, dtype=float) - true_pose).tolist()
    t = wrap_angle(t)
    # adj(P) of P = [[a b c] [b d e] [c e f]], and det P
    A, B, C = d * f - e * e, c * e - b * f, b * e - c * d
    D, E, F = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * A + b * B + c * C
    nees = (A * x * x + D * y * y + F * t * t + 2 * (B * x * y + C * x * t + E * y * t)) / det
    nis = float(estimator.last_nis)
    return (math.sqrt(a), math.sqrt(d), math.sqrt(f), nees, nis)
