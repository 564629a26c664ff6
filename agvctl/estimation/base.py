"""The estimators' protocols, and the consistency of an estimate against the truth.

Every sample the closed loop hands the pose estimator the :class:`~agvctl.sensing.Measurements` of the true
vehicle's sensors (latched encoder counts, the gyro, the position fixes arriving, the rim speeds the wheel loops
measured, and the true pose: a perfect pose sensor, for the ``truth`` estimator only), and the wheel-speed estimator
the latched counts. An estimator that also has a ``pose_covariance`` (3×3) and a ``last_nis`` attribute is checked
for consistency (NEES, NIS) in the log, as :class:`~agvctl.estimation.ekf.PoseEkf` is; one that also has a
``calibration`` and a ``calibration_sigma`` (ε_l, ε_r, ε_b) and a ``fix_counts`` has them logged too
(:data:`CALIBRATION_COLUMNS`, :func:`calibration_readout`).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.sensing import Measurements

__all__ = ["CALIBRATION_COLUMNS", "PoseEstimator", "WheelSpeedEstimator", "calibration_readout", "consistency"]

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
    """Motor speeds (left, right) in rad/s at t_k, from the latched counts (and the true speeds, for ``exact``)."""

    def reset(self) -> None:
        """Forget the past (the vehicle starts at rest)."""

    def update(self, encoder_counts: NDArray[np.int64], true_omega_rad_s: FloatArray) -> FloatArray:
        """The speeds at this sample."""
        ...

    def applied(self, da_command_v: FloatArray) -> None:
        """The DA voltage command (left, right, V) held over the coming sample."""


def consistency(estimator: object, estimate: FloatArray, true_pose: FloatArray) -> tuple[float, ...]:
    """How consistent a pose estimator's covariance is with its actual error, at one sample.

    NEES is eᵀP⁻¹e with e the estimate's error against the truth (heading wrapped), 3 degrees of freedom; NIS the
    estimator's ``last_nis`` (NaN at samples without a fix). In plain floats (Cramer's rule on the symmetric 3×3
    P): it runs every sample, where numpy's per-call cost would exceed the arithmetic.

    Parameters
    ----------
    estimator : object
        The pose estimator; one with a ``pose_covariance`` (and ``last_nis``) is judged.
    estimate : ndarray
        Its estimate: x (m), y (m), heading (rad).
    true_pose : ndarray
        The true pose, in the same units.

    Returns
    -------
    tuple of float
        (σ_x in m, σ_y in m, σ_θ in rad, NEES, NIS); all NaN for an estimator without a covariance.
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


def calibration_readout(estimator: object) -> tuple[float, ...]:
    """The values of :data:`CALIBRATION_COLUMNS` for an estimator, at one sample.

    Parameters
    ----------
    estimator : object
        The pose estimator: its own ``readout()`` when it has one (it runs every sample), else its
        ``calibration``, ``calibration_sigma`` and ``fix_counts`` (:class:`~agvctl.estimation.ekf.PoseEkf`).

    Returns
    -------
    tuple of float
        One value per column, in order; all NaN for an estimator that learns no calibration.
    """
    readout = getattr(estimator, "readout", None)
    if readout is not None:
        return tuple(readout())
    cal = getattr(estimator, "calibration", None)
    if cal is None:
        return (math.nan,) * len(CALIBRATION_COLUMNS)
    counts = getattr(estimator, "fix_counts", {})
    sigma = getattr(estimator, "calibration_sigma", np.full(3, math.nan))
    return (
        *np.asarray(cal, dtype=float).tolist(),
        *np.asarray(sigma, dtype=float).tolist(),
        *(float(counts.get(k, math.nan)) for k in ("rejected", "dropped", "reordered")),
    )
