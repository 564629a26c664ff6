"""The odometry calibration the pose EKF learns online: against the truth, and as a calibrated vehicle file.

The EKF's calibration states are the relative errors ε of the believed left and right wheel radii and wheel base
(true = believed · (1 + ε)), logged per sample (:data:`~agvctl.estimation.base.CALIBRATION_COLUMNS`). Appendix A.1
of the report calibrates the same parameters offline (UMBmark, :mod:`agvctl.calibration.umbmark`); here they come
from the fixes the vehicle already gets. :func:`calibrated_vehicle` writes them back into a vehicle, its tolerances
narrowed to what the filter knows (3σ), so the next run starts from them.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvctl.log import SimLog
from agvctl.params import VehicleParams

__all__ = ["CALIBRATION_PARAMETERS", "calibrated_vehicle", "calibration_summary", "calibration_truth"]

FloatArray = NDArray[np.float64]

CALIBRATION_PARAMETERS = ("wheels.left.radius_m", "wheels.right.radius_m", "wheels.separation_m")
"""The vehicle keys the calibration states (ε_l, ε_r, ε_b) scale."""

_ESTIMATE = ("est_radius_error_left", "est_radius_error_right", "est_separation_error")
_SIGMA = ("est_sigma_radius_error_left", "est_sigma_radius_error_right", "est_sigma_separation_error")


def _geometry(vehicle: VehicleParams) -> FloatArray:
    w = vehicle.wheels
    return np.array([w.left.radius_m, w.right.radius_m, w.separation_m])


def calibration_truth(believed: VehicleParams, true: VehicleParams) -> FloatArray:
    """The true calibration errors (ε_l, ε_r, ε_b) of a believed vehicle: true = believed · (1 + ε).

    Parameters
    ----------
    believed : VehicleParams
        The vehicle the estimator believes in.
    true : VehicleParams
        The true vehicle.

    Returns
    -------
    ndarray
        The relative errors of the left and right radii and of the wheel base.
    """
    return _geometry(true) / _geometry(believed) - 1.0


def calibrated_vehicle(vehicle: VehicleParams, calibration: FloatArray, sigma: FloatArray) -> VehicleParams:
    """``vehicle`` with its radii and wheel base scaled by (1 + ε) and its tolerances narrowed to 3σ (never widened).

    Parameters
    ----------
    vehicle : VehicleParams
        The believed vehicle the calibration refers to.
    calibration : ndarray
        (ε_l, ε_r, ε_b), relative errors of the believed left and right radii and wheel base.
    sigma : ndarray
        Their σ.

    Returns
    -------
    VehicleParams
        The calibrated vehicle.

    Raises
    ------
    ConfigError
        A calibration that makes no valid vehicle (a non-positive radius).
    """
    eps, sig = np.asarray(calibration, dtype=float), np.asarray(sigma, dtype=float)
    values = _geometry(vehicle) * (1.0 + eps)
    w = vehicle.wheels
    radius_tol = min(w.radius_tolerance, 3.0 * float(max(sig[0], sig[1])))
    separation_tol = min(w.separation_tolerance, 3.0 * float(sig[2]))
    overrides: list[tuple[str, object]] = [(k, float(v)) for k, v in zip(CALIBRATION_PARAMETERS, values, strict=True)]
    overrides += [("wheels.radius_tolerance", radius_tol), ("wheels.separation_tolerance", separation_tol)]
    return vehicle.with_overrides(overrides, source="calibration")


def calibration_summary(
    log: SimLog, believed: VehicleParams, true: VehicleParams | None = None
) -> dict[str, dict[str, float]] | None:
    """The calibration at the end of a logged run.

    Parameters
    ----------
    log : SimLog
        The run's log, with the estimator's calibration columns.
    believed : VehicleParams
        The vehicle the estimator believed in.
    true : VehicleParams or None
        The true vehicle, if known.

    Returns
    -------
    dict or None
        Per vehicle key of :data:`CALIBRATION_PARAMETERS`: ``believed``, ``estimate`` and ``sigma`` (m), and with
        ``true`` the ``truth`` (m) and the estimate's error in σ (``error_sigmas``); None for a log without
        calibration (an estimator other than the EKF).
    """
    if _ESTIMATE[0] not in log or not math.isfinite(float(log[_ESTIMATE[0]][-1])):
        return None
    eps = np.array([float(log[c][-1]) for c in _ESTIMATE])
    sig = np.array([float(log[c][-1]) for c in _SIGMA])
    base = _geometry(believed)
    out: dict[str, dict[str, float]] = {}
    for i, key in enumerate(CALIBRATION_PARAMETERS):
        entry = {
            "believed": float(base[i]),
            "estimate": float(base[i] * (1 + eps[i])),
            "sigma": float(base[i] * sig[i]),
        }
        if true is not None:
            entry["truth"] = float(_geometry(true)[i])
            entry["error_sigmas"] = (entry["estimate"] - entry["truth"]) / entry["sigma"] if sig[i] > 0 else math.nan
        out[key] = entry
    return out
