"""Wheel radii and wheel base by Borenstein & Feng's UMBmark (1996, IEEE Trans. Robotics and Automation 12(6)).

The vehicle drives a square of side L on its own odometry, n times clockwise (cw) and n times counter-clockwise
(ccw), from the same start pose. Each run's return-position error ε = (x_true − x_odometry, y_true − y_odometry)
is measured at the end; the centre of gravity of each direction's error cluster gives the systematic error,
E_max,syst = max(|c_cw|, |c_ccw|).

Conventions (this package's): the start is the origin with heading θ = 0 along +x, y to the left, θ positive
counter-clockwise; ccw turns are +90° (left), cw turns −90°; yaw rate ω = (v_r − v_l)/b (eq 40).

Two systematic errors, first order in small angles:

* type A, the wheel base: the odometry believes b̂, so a turn the odometry counts as 90° is in truth
  90° · b̂/b: every corner turns by α too little (α > 0: the true wheel base is larger);
* type B, unequal wheel diameters: a leg the odometry sees as straight is an arc turning by β (β > 0: to the
  left, the right wheel effectively larger than believed).

Summing the four legs (each a chord of heading θ_k + β/2) gives, for the ccw square,
x_ccw = 2L(β − α), y_ccw = −2L(β − α), and for the cw square x_cw = y_cw = −2L(β + α); hence Borenstein &
Feng's formulas, which hold unchanged in these conventions:

    α = (x_cw + x_ccw)/(−4L) = (y_cw − y_ccw)/(−4L),      β = (x_cw − x_ccw)/(−4L) = (y_cw + y_ccw)/(−4L).

The first-order formulas lose a few per cent of α at the IAU AGV's sizes (second-order terms in β·L), so by
default α and β are refined by least squares on the exact geometry of the same model (arcs and corners), starting
from the first-order values; ``method="first_order"`` uses the four formulas above (each pair averaged).

Corrections (B&F): R = (L/2)/sin(β/2), the radius of a leg's arc; the wheel-diameter ratio
E_d = D_r/D_l = (R + b/2)/(R − b/2); the wheel base b_actual = 90°/(90° − α) · b_nominal. Here b in E_d is the
corrected wheel base (B&F use the nominal; the difference is second order). The corrected radii keep the believed
mean radius: r_l = 2r̄/(E + 1), r_r = 2r̄E/(E + 1), with E the corrected ratio r_r/r_l.

The return-position errors cannot see the mean wheel radius (a square scaled up or down still closes), so it is
kept, and the corrected wheel base is the one consistent with it: b · r̄_believed/r̄_true. That is the
geometry the odometry needs to turn right; calibrate the mean radius by a measured straight run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.calibration.common import Estimate, read_csv_columns
from agvctl.controllers.mpc_common import MpcConfig
from agvctl.controllers.mpc_ltv import LtvMpcController
from agvctl.controllers.pi import PIWheelController
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams
from agvctl.planning import LineSegment, TurnSegment, WheelLimits, plan_segments
from agvctl.sim.controllers import default_pi_gains
from agvctl.sim.loop import run_closed_loop

__all__ = [
    "POSITION_NOISE_M",
    "UMBMARK_LOG_COLUMNS",
    "UmbmarkConfig",
    "UmbmarkCorrection",
    "UmbmarkResult",
    "drive_square",
    "e_max_syst",
    "read_umbmark_log",
    "simulate_umbmark",
    "square_end_errors",
    "umbmark_correction",
]

Direction = Literal["cw", "ccw"]
Method = Literal["exact", "first_order"]

POSITION_NOISE_M = 0.003
"""Standard deviation, per axis, of a measured end position at ``noise_scale = 1`` (m): marking the vehicle's
reference point on the floor and measuring it with a tape."""

UMBMARK_LOG_COLUMNS: dict[str, str] = {
    "direction": "'cw' or 'ccw': the direction the square was driven",
    "x_m": "true end position measured on the floor (m), along the start heading, from the start point",
    "y_m": "true end position (m), to the left of the start heading",
    "est_x_m": "optional: the odometry's end position (m); 0 if absent (it drove back to its start)",
    "est_y_m": "optional: the odometry's end position (m); 0 if absent",
}
"""The UMBmark log's columns (CSV with a header row, one row per run); other columns are ignored."""


@dataclass(frozen=True)
class UmbmarkConfig:
    """The simulated UMBmark runs."""

    side_length_m: float = 4.0
    """L, the side of the square (Borenstein & Feng: 4 m; smaller works, with less resolution)."""
    runs_per_direction: int = 5
    """n: measured end positions per direction."""
    wheel_speed_m_s: float = 0.5
    wheel_accel_m_s2: float = 0.5
    wheel_jerk_m_s3: float = 3.0
    settle_s: float = 2.0
    """Time after the reference ends for the controller to come to rest on its odometry."""

    def __post_init__(self) -> None:
        for name in ("side_length_m", "wheel_speed_m_s", "wheel_accel_m_s2", "wheel_jerk_m_s3"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"UmbmarkConfig.{name} must be > 0 (got {value})")
        if self.runs_per_direction < 1:
            raise ValueError(f"UmbmarkConfig.runs_per_direction must be >= 1 (got {self.runs_per_direction})")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0):
            raise ValueError(f"UmbmarkConfig.settle_s must be >= 0 (got {self.settle_s})")


# ----------------------------------------------------------------------------------------------------------------
# The error model and the corrections


def square_end_errors(alpha_rad: float, beta_rad: float, side_length_m: float) -> NDArray[np.float64]:
    """The exact return-position errors ``[[x_cw, y_cw], [x_ccw, y_ccw]]`` of the UMBmark error model: four
    legs, each an arc of length L turning by β (a chord of 2(L/β) sin(β/2) at heading θ + β/2), and corners
    of ∓(90° − α)."""
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
    """Borenstein & Feng's measure of systematic odometry error: max(|c_cw|, |c_ccw|), c the centre of gravity of
    each direction's return-position errors (rows (x, y) in m)."""
    c_cw = np.mean(np.asarray(cw_errors_m, dtype=float).reshape(-1, 2), axis=0)
    c_ccw = np.mean(np.asarray(ccw_errors_m, dtype=float).reshape(-1, 2), axis=0)
    return float(max(np.hypot(*c_cw), np.hypot(*c_ccw)))


@dataclass(frozen=True)
class UmbmarkCorrection:
    """What one set of UMBmark runs says about the geometry."""

    alpha_rad: Estimate
    """α, the corner turn error (type A, wheel base): the true corner is 90° − α."""
    beta_rad: Estimate
    """β, the heading change over a leg (type B, unequal wheel diameters)."""
    alpha_first_order_rad: float
    """α from Borenstein & Feng's first-order formulas (x and y averaged)."""
    beta_first_order_rad: float
    wheel_radius_ratio: Estimate
    """r_r/r_l after correction (the believed ratio times E_d)."""
    diameter_ratio_correction: float
    """E_d = (R + b/2)/(R − b/2), R = (L/2)/sin(β/2): the true ratio over the believed one."""
    separation_m: Estimate
    """b_actual = 90°/(90° − α) · b_believed."""
    radius_left_m: Estimate
    radius_right_m: Estimate
    error_m: float
    """E_max,syst of the runs the correction comes from."""
    centroid_cw_m: tuple[float, float]
    centroid_ccw_m: tuple[float, float]
    side_length_m: float
    runs_per_direction: tuple[int, int]

    def apply(self, vehicle: VehicleParams) -> VehicleParams:
        """``vehicle`` with the corrected wheel radii and wheel base."""
        return vehicle.with_overrides(
            [
                ("wheels.radius_left_m", self.radius_left_m.estimate),
                ("wheels.radius_right_m", self.radius_right_m.estimate),
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
    """Least squares of :func:`square_end_errors` to the four centroid coordinates (Gauss-Newton)."""
    p = np.array(start, dtype=float)
    target = centroids.ravel()
    for _ in range(30):
        r = square_end_errors(p[0], p[1], side_length_m).ravel() - target
        J = _jacobian(p, side_length_m)
        dp = np.linalg.lstsq(J, -r, rcond=None)[0]
        p = p + dp
        if np.max(np.abs(dp)) < 1e-13:
            break
    return p


def _jacobian(p: NDArray[np.float64], side_length_m: float) -> NDArray[np.float64]:
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
    ratio = w.radius_right_m / w.radius_left_m * e_d
    mean = 0.5 * (w.radius_left_m + w.radius_right_m)
    return np.array([ratio, separation, 2.0 * mean / (ratio + 1.0), 2.0 * mean * ratio / (ratio + 1.0)])


def umbmark_correction(
    cw_errors_m: ArrayLike,
    ccw_errors_m: ArrayLike,
    *,
    side_length_m: float,
    vehicle: VehicleParams,
    method: Method = "exact",
    truth: VehicleParams | None = None,
) -> UmbmarkCorrection:
    """The corrected wheel radii and wheel base from UMBmark return-position errors (n × 2 arrays of (x, y) in m,
    true minus odometry, in the start frame) of squares of side ``side_length_m`` driven with ``vehicle``'s
    (believed) geometry.

    Standard errors come from each cluster's scatter (the centroid's standard error per coordinate, s/√n),
    propagated to α, β linearly and on to the geometry by the delta method; with one run per direction they are
    NaN. ``truth`` (simulations only) fills the truths of the geometry estimates; the ``separation_m`` truth is
    b·r̄_believed/r̄_true, the wheel base the odometry needs (see the module notes).
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
    Jg = np.column_stack([
        (_geometry(float(params[0]) + h * (i == 0), float(params[1]) + h * (i == 1), vehicle, side_length_m)
         - _geometry(float(params[0]) - h * (i == 0), float(params[1]) - h * (i == 1), vehicle, side_length_m))
        / (2 * h)
        for i in range(2)
    ])
    cov_g = Jg @ cov_p @ Jg.T
    se_p = np.sqrt(np.diag(cov_p))
    se_g = np.sqrt(np.diag(cov_g))

    true_geom: list[float | None] = [None] * 4
    true_ab: list[float | None] = [None, None]
    if truth is not None:
        tw, bw = truth.wheels, vehicle.wheels
        mean_believed = 0.5 * (bw.radius_left_m + bw.radius_right_m)
        mean_true = 0.5 * (tw.radius_left_m + tw.radius_right_m)
        ratio_true = tw.radius_right_m / tw.radius_left_m
        true_geom = [
            ratio_true,
            tw.separation_m * mean_believed / mean_true,
            2.0 * mean_believed / (ratio_true + 1.0),
            2.0 * mean_believed * ratio_true / (ratio_true + 1.0),
        ]
        alpha_true = 0.5 * math.pi * (1.0 - bw.separation_m / (tw.separation_m * mean_believed / mean_true))
        # a leg the odometry sees straight: s_r/s_l = (r_r/r̂_r)/(r_l/r̂_l); its heading change over L
        rel = (tw.radius_right_m / bw.radius_right_m) / (tw.radius_left_m / bw.radius_left_m)
        beta_true = side_length_m * 2.0 * (rel - 1.0) / ((rel + 1.0) * true_geom[1])  # type: ignore[operator]
        true_ab = [alpha_true, beta_true]

    def est(i: int) -> Estimate:
        return Estimate(float(geom[i]), float(se_g[i]), true_geom[i])

    return UmbmarkCorrection(
        alpha_rad=Estimate(float(params[0]), float(se_p[0]), true_ab[0]),
        beta_rad=Estimate(float(params[1]), float(se_p[1]), true_ab[1]),
        alpha_first_order_rad=a1,
        beta_first_order_rad=b1,
        wheel_radius_ratio=est(0),
        diameter_ratio_correction=float(geom[0]) / (vehicle.wheels.radius_right_m / vehicle.wheels.radius_left_m),
        separation_m=est(1),
        radius_left_m=est(2),
        radius_right_m=est(3),
        error_m=e_max_syst(cw, ccw),
        centroid_cw_m=(float(centroids[0, 0]), float(centroids[0, 1])),
        centroid_ccw_m=(float(centroids[1, 0]), float(centroids[1, 1])),
        side_length_m=side_length_m,
        runs_per_direction=(len(cw), len(ccw)),
    )


# ----------------------------------------------------------------------------------------------------------------
# Simulation


def drive_square(
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    direction: Direction,
    config: UmbmarkConfig | None = None,
) -> NDArray[np.float64]:
    """Drive one UMBmark square closed-loop on odometry and return its return-position error (x, y) in m.

    The LTV MPC pose controller and the PI wheel loops (with Coulomb feed-forward and gentle stops, as in
    ``experiments/square.toml``) are designed for ``controller_vehicle`` and see the pose integrated from the
    measured wheel speeds with its radii and wheel base; the plant is ``plant_vehicle``. The error is the true
    end position minus the odometry's, in the start frame.
    """
    cfg = config or UmbmarkConfig()
    turn = 90.0 if direction == "ccw" else -90.0
    segments = [seg for _ in range(4) for seg in (LineSegment(length_m=cfg.side_length_m), TurnSegment(angle_deg=turn))]
    reference = plan_segments(
        segments,
        limits=WheelLimits(cfg.wheel_speed_m_s, cfg.wheel_accel_m_s2, cfg.wheel_jerk_m_s3),
        separation_m=controller_vehicle.wheels.separation_m,
        sample_period_s=controller_vehicle.control.sample_period_s,
        name=f"umbmark-{direction}",
    )
    gains, loop_tau_s = default_pi_gains(controller_vehicle)
    mpc = LtvMpcController(controller_vehicle, MpcConfig(wheel_loop_time_constant_s=loop_tau_s))
    wheels = PIWheelController(controller_vehicle, gains, coulomb_feedforward=True, gentle_stop=True)
    result = run_closed_loop(
        plant_vehicle=plant_vehicle,
        controller_vehicle=controller_vehicle,
        reference=reference,
        pose_controller=mpc,
        wheel_controller=wheels,
        settle_s=cfg.settle_s,
        localization="odometry",
    )
    log = result.log
    return np.array([log["x_m"][-1] - log["est_x_m"][-1], log["y_m"][-1] - log["est_y_m"][-1]], dtype=float)


@dataclass(frozen=True)
class UmbmarkResult:
    """A simulated UMBmark: runs with the believed geometry, the correction, runs with the corrected one."""

    correction: UmbmarkCorrection
    corrected_vehicle: VehicleParams
    errors_before_m: dict[str, NDArray[np.float64]]
    """Measured return-position errors per direction (n × 2), believed geometry."""
    errors_after_m: dict[str, NDArray[np.float64]]
    """The same with the corrected geometry."""
    error_before_m: float
    """E_max,syst before the correction."""
    error_after_m: float
    """E_max,syst after it."""
    notes: tuple[str, ...] = field(default=())


def _measured_runs(
    true_error: NDArray[np.float64], n: int, sigma_m: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    runs = np.repeat(true_error[None, :], n, axis=0)
    if sigma_m > 0:
        runs = runs + rng.normal(0.0, sigma_m, runs.shape)
    return runs


def simulate_umbmark(
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    config: UmbmarkConfig | None = None,
    *,
    noise_scale: float = 0.0,
    seed: int | None = None,
    method: Method = "exact",
) -> UmbmarkResult:
    """UMBmark on the simulator: squares cw and ccw with the believed geometry (``controller_vehicle``) on the
    true plant, the correction, and the squares again with the corrected geometry.

    The simulator is deterministic, so each direction is simulated once and its n runs differ only by the
    measurement noise on the end position (``noise_scale`` × :data:`POSITION_NOISE_M` per axis).
    """
    cfg = config or UmbmarkConfig()
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be >= 0 (got {noise_scale})")
    rng = np.random.default_rng(seed)
    sigma = noise_scale * POSITION_NOISE_M
    n = cfg.runs_per_direction

    def runs(believed: VehicleParams) -> dict[str, NDArray[np.float64]]:
        return {d: _measured_runs(drive_square(plant_vehicle, believed, d, cfg), n, sigma, rng)
                for d in ("cw", "ccw")}

    before = runs(controller_vehicle)
    correction = umbmark_correction(
        before["cw"], before["ccw"], side_length_m=cfg.side_length_m, vehicle=controller_vehicle, method=method,
        truth=plant_vehicle,
    )
    corrected = correction.apply(controller_vehicle)
    after = runs(corrected)
    notes = (
        f"each direction simulated once (the simulator is deterministic); its {n} runs differ by the "
        f"end-position measurement noise only (σ = {sigma * 1000:g} mm per axis)",
    )
    return UmbmarkResult(
        correction=correction,
        corrected_vehicle=corrected,
        errors_before_m=before,
        errors_after_m=after,
        error_before_m=e_max_syst(before["cw"], before["ccw"]),
        error_after_m=e_max_syst(after["cw"], after["ccw"]),
        notes=notes,
    )


# ----------------------------------------------------------------------------------------------------------------
# Logs


def read_umbmark_log(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read measured UMBmark end positions (CSV, :data:`UMBMARK_LOG_COLUMNS`) and return the return-position
    errors ``(cw, ccw)``, each n × 2 (x, y) in m. Raises :class:`ConfigError` (one line) for a missing column,
    a non-finite cell, a direction other than cw/ccw, or a direction without runs."""
    source = str(path)
    values, text = read_csv_columns(path, ["x_m", "y_m"], ["direction"])
    try:
        est, _ = read_csv_columns(path, ["est_x_m", "est_y_m"])
    except ConfigError as exc:
        if "missing column" not in exc.problem:
            raise
        est = {"est_x_m": np.zeros_like(values["x_m"]), "est_y_m": np.zeros_like(values["y_m"])}
    directions = [d.lower() for d in text["direction"]]
    for i, d in enumerate(directions):
        if d not in ("cw", "ccw"):
            raise ConfigError(source, f"row {i + 1}", f"direction must be cw or ccw (got {d or 'empty'!r})")
    errors = np.column_stack([values["x_m"] - est["est_x_m"], values["y_m"] - est["est_y_m"]])
    mask = np.array([d == "cw" for d in directions])
    for name, m in (("cw", mask), ("ccw", ~mask)):
        if not np.any(m):
            raise ConfigError(source, "direction", f"no {name} runs; UMBmark needs both directions")
    return errors[mask], errors[~mask]
