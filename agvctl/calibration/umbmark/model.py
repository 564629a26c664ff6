"""The UMBmark error model (the package notes' arcs and corners) and the correction it gives."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from agvctl.calibration.common import Estimate
from agvctl.config import document_fields
from agvctl.params import VehicleParams

__all__ = ["Method", "UmbmarkCorrection", "e_max_syst", "square_end_errors", "umbmark_correction"]

Method = Literal["exact", "first_order"]


def square_end_errors(alpha_rad: float, beta_rad: float, side_length_m: float) -> NDArray[np.float64]:
    """The exact return-position errors of the UMBmark error model: four legs, each an arc of length L turning by β
    (a chord of 2(L/β) sin(β/2) at heading θ + β/2), and corners of ∓(90° − α).

    Parameters
    ----------
    alpha_rad : float
        α, the corner turn error (type A), rad.
    beta_rad : float
        β, the heading change over a leg (type B), rad.
    side_length_m : float
        L, the square's side, m.

    Returns
    -------
    ndarray
        ``[[x_cw, y_cw], [x_ccw, y_ccw]]``, m.

    Examples
    --------
    >>> square_end_errors(0.01, 0.0, 4.0).round(4)  # corners 0.01 rad short: both squares miss by about 11 cm
    array([[-0.0792, -0.0816],
           [-0.0792,  0.0816]])
    """
    out = np.empty((2, 2))
    chord = side_length_m if beta_rad == 0 else 2.0 * side_length_m / beta_rad * math.sin(0.5 * beta_rad)
    for row, turn in enumerate((-1.0, 1.0)):
        x = y = theta = 0.0
        for _ in range(4):
            x += chord * math.cos(theta + 0.5 * beta_rad)
            y += chord * math.sin(theta + 0.5 * beta_rad)
            theta += beta_rad + turn * (0.5 * math.pi - alpha_rad)
        out[row] = (x, y)
    return out


def e_max_syst(cw_errors_m: ArrayLike, ccw_errors_m: ArrayLike) -> float:
    """Borenstein & Feng's measure of systematic odometry error, E_max,syst = max(``|c_cw|``, ``|c_ccw|``).

    Parameters
    ----------
    cw_errors_m : array_like
        The clockwise runs' return-position errors, rows (x, y), m.
    ccw_errors_m : array_like
        The counter-clockwise runs', m.

    Returns
    -------
    float
        The larger distance of the two directions' centres of gravity from the origin, m.

    Examples
    --------
    >>> e_max_syst([[0.03, 0.04], [0.03, 0.04]], [[0.01, 0.0]])
    0.05
    """
    c_cw = np.mean(np.asarray(cw_errors_m, dtype=float).reshape(-1, 2), axis=0)
    c_ccw = np.mean(np.asarray(ccw_errors_m, dtype=float).reshape(-1, 2), axis=0)
    return float(max(np.hypot(*c_cw), np.hypot(*c_ccw)))


@document_fields
@dataclass(frozen=True)
class UmbmarkCorrection:
    """What one set of UMBmark runs says about the geometry."""

    alpha_rad: Estimate
    """α, the corner turn error (type A, wheel base): the true corner is 90° − α, rad."""
    beta_rad: Estimate
    """β, the heading change over a leg (type B, unequal wheel diameters), rad."""
    alpha_first_order_rad: float
    """α from Borenstein & Feng's first-order formulas (x and y averaged), rad."""
    beta_first_order_rad: float
    """β from the same formulas, rad."""
    wheel_radius_ratio: Estimate
    """r_r/r_l after correction (the believed ratio times E_d)."""
    diameter_ratio_correction: float
    """E_d = (R + b/2)/(R − b/2), R = (L/2)/sin(β/2): the true ratio over the believed one."""
    separation_m: Estimate
    """b_actual = 90°/(90° − α) · b_believed, m."""
    radius_left_m: Estimate
    """The corrected left wheel radius (the mean radius kept), m."""
    radius_right_m: Estimate
    """The corrected right wheel radius, m."""
    error_m: float
    """E_max,syst of the runs the correction comes from, m."""
    centroid_cw_m: tuple[float, float]
    """The centre of gravity (x, y) of the clockwise runs' errors, m."""
    centroid_ccw_m: tuple[float, float]
    """That of the counter-clockwise runs' errors, m."""
    side_length_m: float
    """The square's side, m."""
    runs_per_direction: tuple[int, int]
    """The runs clockwise and counter-clockwise."""

    def apply(self, vehicle: VehicleParams) -> VehicleParams:
        """``vehicle`` with the corrected wheel radii and wheel base."""
        return vehicle.with_overrides(
            [
                ("wheels.left.radius_m", self.radius_left_m.estimate),
                ("wheels.right.radius_m", self.radius_right_m.estimate),
                ("wheels.separation_m", self.separation_m.estimate),
            ],
            source="UMBmark correction",
        )


def _first_order(centroids: NDArray[np.float64], side_length_m: float) -> tuple[float, float]:
    """Borenstein & Feng's α, β from the centroids ``[[x_cw, y_cw], [x_ccw, y_ccw]]`` (x and y averaged)."""
    (x_cw, y_cw), (x_ccw, y_ccw) = centroids
    k = -4.0 * side_length_m
    alpha = 0.5 * ((x_cw + x_ccw) / k + (y_cw - y_ccw) / k)
    beta = 0.5 * ((x_cw - x_ccw) / k + (y_cw + y_ccw) / k)
    return alpha, beta


def _fit_exact(centroids: NDArray[np.float64], side_length_m: float, start: tuple[float, float]) -> NDArray[np.float64]:
    """Least squares of :func:`square_end_errors` to the four centroid coordinates, from ``start``
    (Levenberg-Marquardt, every tolerance at machine precision)."""
    target = centroids.ravel()

    def residuals(p: NDArray[np.float64]) -> NDArray[np.float64]:
        return square_end_errors(float(p[0]), float(p[1]), side_length_m).ravel() - target

    eps = float(np.finfo(float).eps)
    fit = least_squares(
        residuals,
        np.array(start, dtype=float),
        jac=lambda p: _jacobian(p, side_length_m),
        method="lm",
        ftol=eps,
        xtol=eps,
        gtol=eps,
    )
    return np.asarray(fit.x, dtype=float)


def _jacobian(p: NDArray[np.float64], side_length_m: float) -> NDArray[np.float64]:
    """d(square_end_errors)/d(α, β), 4 × 2, by central differences (step 1e-7 rad)."""
    h = 1e-7
    cols = []
    for i in range(2):
        d = np.zeros(2)
        d[i] = h
        plus = square_end_errors(float(p[0] + d[0]), float(p[1] + d[1]), side_length_m).ravel()
        minus = square_end_errors(float(p[0] - d[0]), float(p[1] - d[1]), side_length_m).ravel()
        cols.append((plus - minus) / (2 * h))
    return np.column_stack(cols)


def _geometry(alpha: float, beta: float, vehicle: VehicleParams, side_length_m: float) -> NDArray[np.float64]:
    """(ratio r_r/r_l, b, r_l, r_r) after correcting ``vehicle``'s believed geometry by α, β."""
    w = vehicle.wheels
    separation = 0.5 * math.pi / (0.5 * math.pi - alpha) * w.separation_m  # b_actual = 90°/(90° − α) b_nominal
    if beta == 0.0:
        e_d = 1.0
    else:
        radius = 0.5 * side_length_m / math.sin(0.5 * beta)  # R = (L/2)/sin(β/2)
        e_d = (radius + 0.5 * separation) / (radius - 0.5 * separation)  # E_d = (R + b/2)/(R − b/2)
    ratio = w.right.radius_m / w.left.radius_m * e_d
    mean = 0.5 * (w.left.radius_m + w.right.radius_m)
    return np.array([ratio, separation, 2.0 * mean / (ratio + 1.0), 2.0 * mean * ratio / (ratio + 1.0)])


def _truths(
    truth: VehicleParams | None, vehicle: VehicleParams, side_length_m: float
) -> tuple[list[float | None], list[float | None]]:
    """The true (ratio r_r/r_l, wheel base the odometry needs, r_l, r_r) and (α, β) of a simulation whose true
    vehicle is ``truth`` and believed one ``vehicle``; all None without a truth."""
    if truth is None:
        return [None] * 4, [None, None]
    tw, bw = truth.wheels, vehicle.wheels
    mean_believed = 0.5 * (bw.left.radius_m + bw.right.radius_m)
    mean_true = 0.5 * (tw.left.radius_m + tw.right.radius_m)
    ratio_true = tw.right.radius_m / tw.left.radius_m
    base_m = tw.separation_m * mean_believed / mean_true
    true_geom: list[float | None] = [
        ratio_true,
        base_m,
        2.0 * mean_believed / (ratio_true + 1.0),
        2.0 * mean_believed * ratio_true / (ratio_true + 1.0),
    ]
    alpha_true = 0.5 * math.pi * (1.0 - bw.separation_m / base_m)
    # a leg the odometry sees straight: s_r/s_l = (r_r/r̂_r)/(r_l/r̂_l); its heading change over L
    rel = (tw.right.radius_m / bw.right.radius_m) / (tw.left.radius_m / bw.left.radius_m)
    beta_true = side_length_m * 2.0 * (rel - 1.0) / ((rel + 1.0) * base_m)
    return true_geom, [alpha_true, beta_true]


def _propagated(
    params: NDArray[np.float64], var: NDArray[np.float64], method: Method, vehicle: VehicleParams, side_length_m: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The geometry of (α, β) = ``params``, and the standard errors of α, β and the geometry from the centroids'
    variances ``var``: linearly to α, β, then by the delta method."""
    if method == "first_order":
        # the linear map from the centroids (x_cw, y_cw, x_ccw, y_ccw) to (α, β), x and y formulas averaged
        k = -4.0 * side_length_m
        G: NDArray[np.float64] = 0.5 / k * np.array([[1.0, 1.0, 1.0, -1.0], [1.0, 1.0, -1.0, 1.0]])
    else:
        J = _jacobian(params, side_length_m)
        G = np.asarray(np.linalg.pinv(J), dtype=float)
    cov_p: NDArray[np.float64] = np.asarray(G @ np.diag(var) @ G.T, dtype=float)
    geom = _geometry(float(params[0]), float(params[1]), vehicle, side_length_m)
    h = 1e-8
    Jg = np.column_stack(
        [
            (
                _geometry(float(params[0]) + h * (i == 0), float(params[1]) + h * (i == 1), vehicle, side_length_m)
                - _geometry(float(params[0]) - h * (i == 0), float(params[1]) - h * (i == 1), vehicle, side_length_m)
            )
            / (2 * h)
            for i in range(2)
        ]
    )
    cov_g = Jg @ cov_p @ Jg.T
    return geom, np.sqrt(np.diag(cov_p)), np.sqrt(np.diag(cov_g))


def umbmark_correction(
    cw_errors_m: ArrayLike,
    ccw_errors_m: ArrayLike,
    *,
    side_length_m: float,
    vehicle: VehicleParams,
    method: Method = "exact",
    truth: VehicleParams | None = None,
) -> UmbmarkCorrection:
    """The corrected wheel radii and wheel base from UMBmark return-position errors.

    Standard errors come from each cluster's scatter (the centroid's standard error per coordinate, s/√n),
    propagated to α, β linearly and on to the geometry by the delta method; with one run per direction they are
    NaN.

    Parameters
    ----------
    cw_errors_m : array_like
        The clockwise squares' return-position errors, n × 2 (x, y): true minus odometry, in the start frame, m.
    ccw_errors_m : array_like
        The counter-clockwise squares', m.
    side_length_m : float
        The squares' side, m.
    vehicle : VehicleParams
        The geometry the squares were driven with (believed).
    method : {'exact', 'first_order'}
        Fit α, β to the exact error model (:func:`square_end_errors`), or take Borenstein & Feng's first-order
        formulas.
    truth : VehicleParams or None
        The true vehicle (simulations only): fills the truths of the geometry estimates; the ``separation_m``
        truth is b·r̄_believed/r̄_true, the wheel base the odometry needs (see the notes of
        :mod:`agvctl.calibration.umbmark`).

    Returns
    -------
    UmbmarkCorrection
        α, β and the corrected geometry with their standard errors.

    Raises
    ------
    ValueError
        A side that is not positive, or a direction without runs.
    """
    cw = np.asarray(cw_errors_m, dtype=float).reshape(-1, 2)
    ccw = np.asarray(ccw_errors_m, dtype=float).reshape(-1, 2)
    if not (math.isfinite(side_length_m) and side_length_m > 0):
        raise ValueError(f"side_length_m must be > 0 (got {side_length_m})")
    if len(cw) < 1 or len(ccw) < 1:
        raise ValueError("umbmark_correction: at least one run per direction")
    centroids = np.array([cw.mean(axis=0), ccw.mean(axis=0)])
    var = np.full(4, math.nan)
    if len(cw) > 1 and len(ccw) > 1:
        var = np.concatenate([cw.var(axis=0, ddof=1) / len(cw), ccw.var(axis=0, ddof=1) / len(ccw)])
        var[var < 1e-24] = 0.0  # identical runs: rounding, not scatter
    a1, b1 = _first_order(centroids, side_length_m)
    params = np.array([a1, b1]) if method == "first_order" else _fit_exact(centroids, side_length_m, (a1, b1))
    geom, se_p, se_g = _propagated(params, var, method, vehicle, side_length_m)

    true_geom, true_ab = _truths(truth, vehicle, side_length_m)

    def est(i: int) -> Estimate:
        return Estimate(float(geom[i]), float(se_g[i]), true_geom[i])

    return UmbmarkCorrection(
        alpha_rad=Estimate(float(params[0]), float(se_p[0]), true_ab[0]),
        beta_rad=Estimate(float(params[1]), float(se_p[1]), true_ab[1]),
        alpha_first_order_rad=a1,
        beta_first_order_rad=b1,
        wheel_radius_ratio=est(0),
        diameter_ratio_correction=float(geom[0]) / (vehicle.wheels.right.radius_m / vehicle.wheels.left.radius_m),
        separation_m=est(1),
        radius_left_m=est(2),
        radius_right_m=est(3),
        error_m=e_max_syst(cw, ccw),
        centroid_cw_m=(float(centroids[0, 0]), float(centroids[0, 1])),
        centroid_ccw_m=(float(centroids[1, 0]), float(centroids[1, 1])),
        side_length_m=side_length_m,
        runs_per_direction=(len(cw), len(ccw)),
    )
