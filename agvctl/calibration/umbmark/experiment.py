"""UMBmark on the simulator: the squares driven closed loop on odometry, before and after the correction."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.calibration.umbmark.model import Method, UmbmarkCorrection, e_max_syst, umbmark_correction
from agvctl.config import document_fields
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.options import Braking, WheelLoopOptions
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.controllers.registry import default_pi_gains
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams
from agvctl.planning import LineSegment, TurnSegment, WheelLimits, plan_segments
from agvctl.sim.loop import run_closed_loop

__all__ = [
    "POSITION_NOISE_M",
    "UMBMARK_WHEEL_LOOPS",
    "Direction",
    "UmbmarkConfig",
    "UmbmarkResult",
    "drive_square",
    "simulate_umbmark",
]

Direction = Literal["cw", "ccw"]

POSITION_NOISE_M = 0.003
"""Standard deviation, per axis, of a measured end position at ``noise_scale = 1`` (m): marking the vehicle's
reference point on the floor and measuring it with a tape."""

UMBMARK_WHEEL_LOOPS = WheelLoopOptions(braking=Braking.GENTLE_STOP)
"""The wheel loops that drive the square: each corner is a turn in place, which stops a wheel to reverse it, so the
loops brake gently in the last sample before a wheel stops (as ``experiments/square.toml``)."""


MAX_SIDE_LENGTH_M = 100.0
"""The largest UMBmark square: 25 times Borenstein & Feng's 4 m, beyond any hall an AGV is calibrated in."""
MAX_RUNS_PER_DIRECTION = 100
"""The most runs per direction: 20 times the usual 5; each is a simulated square."""


@document_fields
@dataclass(frozen=True)
class UmbmarkConfig:
    """The simulated UMBmark runs.

    Raises
    ------
    ConfigError
        Naming the argument: a size or limit not finite and > 0, a side above :data:`MAX_SIDE_LENGTH_M`, runs not
        within 1 … :data:`MAX_RUNS_PER_DIRECTION`, a settling time not within 0 … 600 s.
    """

    side_length_m: float = 4.0
    """L, the side of the square (Borenstein & Feng: 4 m; smaller works, with less resolution), m."""
    runs_per_direction: int = 5
    """n: measured end positions per direction."""
    wheel_speed_m_s: float = 0.5
    """The squares' wheel speed limit, m/s."""
    wheel_accel_m_s2: float = 0.5
    """Their wheel acceleration limit, m/s²."""
    wheel_jerk_m_s3: float = 3.0
    """Their wheel jerk limit, m/s³."""
    settle_s: float = 2.0
    """Time after the reference ends for the controller to come to rest on its odometry, s."""

    def __post_init__(self) -> None:
        for name in ("side_length_m", "wheel_speed_m_s", "wheel_accel_m_s2", "wheel_jerk_m_s3"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ConfigError("UmbmarkConfig", name, f"must be finite and > 0 (got {value})")
        if self.side_length_m > MAX_SIDE_LENGTH_M:
            raise ConfigError(
                "UmbmarkConfig", "side_length_m", f"must be <= {MAX_SIDE_LENGTH_M:g} m (got {self.side_length_m:g})"
            )
        if not 1 <= self.runs_per_direction <= MAX_RUNS_PER_DIRECTION:
            raise ConfigError(
                "UmbmarkConfig",
                "runs_per_direction",
                f"must be within 1 … {MAX_RUNS_PER_DIRECTION} (got {self.runs_per_direction})",
            )
        if not (math.isfinite(self.settle_s) and 0 <= self.settle_s <= 600):
            raise ConfigError("UmbmarkConfig", "settle_s", f"must be within 0 … 600 s (got {self.settle_s})")


def drive_square(
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    direction: Direction,
    config: UmbmarkConfig | None = None,
) -> NDArray[np.float64]:
    """Drive one UMBmark square closed-loop on odometry and return its return-position error.

    The LTV MPC pose controller and the PI wheel loops (with Coulomb feed-forward and gentle stops, as in
    ``experiments/square.toml``) see the pose integrated from the measured wheel speeds.

    Parameters
    ----------
    plant_vehicle : VehicleParams
        The true vehicle.
    controller_vehicle : VehicleParams
        What the controllers are designed for and the odometry integrates with (its radii and wheel base).
    direction : {'cw', 'ccw'}
        Clockwise or counter-clockwise.
    config : UmbmarkConfig or None
        The square's size and limits (None: the defaults).

    Returns
    -------
    ndarray
        The true end position minus the odometry's, (x, y) in the start frame, m.
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
    wheels = PIWheelController(controller_vehicle, gains, UMBMARK_WHEEL_LOOPS)
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


@document_fields
@dataclass(frozen=True)
class UmbmarkResult:
    """A simulated UMBmark: runs with the believed geometry, the correction, runs with the corrected one."""

    correction: UmbmarkCorrection
    """What the runs with the believed geometry say."""
    corrected_vehicle: VehicleParams
    """The controller's vehicle with the corrected geometry."""
    errors_before_m: dict[str, NDArray[np.float64]]
    """Measured return-position errors per direction (n × 2), believed geometry, m."""
    errors_after_m: dict[str, NDArray[np.float64]]
    """The same with the corrected geometry, m."""
    error_before_m: float
    """E_max,syst before the correction, m."""
    error_after_m: float
    """E_max,syst after it, m."""
    notes: tuple[str, ...] = field(default=())
    """How the runs were simulated."""


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
    """UMBmark on the simulator: squares cw and ccw with the believed geometry on the true plant, the correction,
    and the squares again with the corrected geometry.

    The simulator is deterministic, so each direction is simulated once and its n runs differ only by the
    measurement noise on the end position.

    Parameters
    ----------
    plant_vehicle : VehicleParams
        The true vehicle.
    controller_vehicle : VehicleParams
        The believed one, whose geometry is corrected.
    config : UmbmarkConfig or None
        The squares (None: Borenstein & Feng's 4 m, 5 runs per direction).
    noise_scale : float
        The noise of each measured end position, per axis, in units of :data:`POSITION_NOISE_M` (0: none).
    seed : int or None
        The noise's seed.
    method : {'exact', 'first_order'}
        How α and β are found (:func:`~agvctl.calibration.umbmark.model.umbmark_correction`).

    Returns
    -------
    UmbmarkResult
        The correction, the corrected vehicle, and the errors before and after.

    Raises
    ------
    ValueError
        A negative or non-finite ``noise_scale``.
    """
    cfg = config or UmbmarkConfig()
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be >= 0 (got {noise_scale})")
    rng = np.random.default_rng(seed)
    sigma = noise_scale * POSITION_NOISE_M
    n = cfg.runs_per_direction

    def runs(believed: VehicleParams) -> dict[str, NDArray[np.float64]]:
        return {d: _measured_runs(drive_square(plant_vehicle, believed, d, cfg), n, sigma, rng) for d in ("cw", "ccw")}

    before = runs(controller_vehicle)
    correction = umbmark_correction(
        before["cw"],
        before["ccw"],
        side_length_m=cfg.side_length_m,
        vehicle=controller_vehicle,
        method=method,
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
