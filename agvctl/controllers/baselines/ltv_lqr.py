"""WPILib's linear time-varying (LTV) unicycle controller (``pose = "ltv_lqr"``): a yardstick and a fallback.

The pose error in the robot frame, e = (e_x, e_y, e_θ) (see :mod:`agvctl.controllers.baselines.unicycle`), of a unicycle
ẋ = v cos θ, ẏ = v sin θ, θ̇ = ω linearised about the reference at speed v_d (e_θ small) obeys

    ė = A(v_d) e + B δu,   A = [[0, 0, 0], [0, 0, v_d], [0, 0, 0]],   B = [[1, 0], [0, 0], [0, 1]]

with δu = (v − v_d, ω − ω_d). Discretised with a zero-order hold over the sample period T_s (exactly, from the
matrix exponential), each v_d gets the infinite-horizon discrete LQR gain K(v_d) = (BᵀSB + R)⁻¹BᵀSA of the
weights (Bryson's rule, as WPILib builds them)

    Q = diag(1/e_x,tol², 1/e_y,tol², 1/e_θ,tol²),   R = diag(1/v_effort², 1/ω_effort²)

and the command is (v, ω) = (v_d, ω_d) + K(v_d) e. The gains are computed at construction on a grid of v_d
from −v_max to v_max in steps of ``schedule_step_m_s`` and interpolated linearly in v_d. At v_d = 0 the lateral
error is not controllable (the Riccati equation is ill-posed), so, as in WPILib, ``|v_d|`` below 10⁻⁴ m/s is
linearised at 10⁻⁴ m/s: the vehicle then corrects e_x and e_θ and leaves e_y alone. The setpoints are the
wheel speeds of (v, ω) (eqs 39-43), scaled down together to the wheel-speed limit.

Defaults are WPILib's: tolerances 0.0625 m, 0.125 m, 2 rad; efforts 1 m/s, 2 rad/s; the vehicle's T_s and max
speed in place of WPILib's dt and maxVelocity.

References: WPILib's "LTV Unicycle Controller" documentation (docs.wpilib.org, advanced controls →
trajectories); T. Veness, *Controls Engineering in FRC*, section "Linear time-varying unicycle controller".
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from agvctl.config import check_fields, document_fields, number
from agvctl.controllers.baselines.unicycle import UnicycleTracker
from agvctl.controllers.ranges import MAX_DISTANCE_M, MAX_WHEEL_SPEED_M_S, MIN_WHEEL_SPEED_M_S
from agvctl.errors import expect_instance
from agvctl.params import VehicleParams

__all__ = ["LtvLqrConfig", "LtvLqrController", "gain_schedule", "unicycle_error_model", "unicycle_lqr_gain"]

FloatArray = NDArray[np.float64]

MIN_LINEARISATION_SPEED_M_S = 1e-4
"""``|v_d|`` below this is linearised at this speed (WPILib's choice): at rest e_y is not controllable."""


@document_fields
@dataclass(frozen=True)
class LtvLqrConfig:
    """Settings of the LTV unicycle controller, as in an experiment file's ``[controller]`` table.

    The tolerances and efforts are at least 10⁻⁴ (Q = 1/tol², R = 1/effort² stay below 10⁸, within what the
    Riccati solver resolves); :mod:`agvctl.controllers.ranges` gives the other ranges' reasons."""

    tolerance_x_m: float = number(
        ge=1e-4, le=MAX_DISTANCE_M, default=0.0625, doc="Largest wanted error ahead (Q = 1/tol²), m."
    )
    tolerance_y_m: float = number(ge=1e-4, le=MAX_DISTANCE_M, default=0.125, doc="Largest wanted error to the side, m.")
    tolerance_heading_rad: float = number(ge=1e-4, le=10.0, default=2.0, doc="Largest wanted heading error, rad.")
    effort_speed_m_s: float = number(
        ge=1e-4, le=MAX_WHEEL_SPEED_M_S, default=1.0, doc="Largest wanted speed correction (R = 1/effort²), m/s."
    )
    effort_yaw_rate_rad_s: float = number(
        ge=1e-4, le=100.0, default=2.0, doc="Largest wanted yaw-rate correction, rad/s."
    )
    schedule_step_m_s: float = number(
        ge=MIN_WHEEL_SPEED_M_S,
        le=1.0,
        default=0.01,
        doc="Spacing of the gain schedule in v_d, at least 1 mm/s (one Riccati solution per step up to the top "
        "speed), m/s.",
    )
    max_wheel_speed_m_s: float | None = number(
        ge=MIN_WHEEL_SPEED_M_S,
        le=MAX_WHEEL_SPEED_M_S,
        default=None,
        doc="The wheel-speed limit of the setpoints (None: the vehicle's max speed), m/s.",
    )

    def __post_init__(self) -> None:
        check_fields(self)


def unicycle_error_model(speed_m_s: float, sample_period_s: float) -> tuple[FloatArray, FloatArray]:
    """The robot-frame error dynamics linearised at a reference speed, discretised with a zero-order hold.

    Parameters
    ----------
    speed_m_s : float
        The reference speed v_d (``|v_d|`` raised to :data:`MIN_LINEARISATION_SPEED_M_S`), m/s.
    sample_period_s : float
        The discretisation step, s.

    Returns
    -------
    A_d : ndarray
        3 × 3, the error (e_x, e_y, e_θ) from sample to sample.
    B_d : ndarray
        3 × 2, the effect of the correction (δv, δω) held over the sample.
    """
    v = (
        speed_m_s
        if abs(speed_m_s) >= MIN_LINEARISATION_SPEED_M_S
        else math.copysign(MIN_LINEARISATION_SPEED_M_S, speed_m_s)
    )
    m = np.zeros((5, 5))
    m[1, 2] = v  # A
    m[0, 3] = m[2, 4] = 1.0  # B
    phi = scipy.linalg.expm(m * sample_period_s)
    return phi[:3, :3], phi[:3, 3:]


def unicycle_lqr_gain(speed_m_s: float, sample_period_s: float, config: LtvLqrConfig) -> FloatArray:
    """The discrete LQR gain at a reference speed: the correction δu = K e.

    Parameters
    ----------
    speed_m_s : float
        The reference speed v_d, m/s.
    sample_period_s : float
        The discretisation step, s.
    config : LtvLqrConfig
        The tolerances and efforts that weigh Q and R.

    Returns
    -------
    ndarray
        K, 2 × 3: from the error (e_x in m, e_y in m, e_θ in rad) to the correction (δv in m/s, δω in rad/s).
    """
    import control

    a_d, b_d = unicycle_error_model(speed_m_s, sample_period_s)
    q = np.diag(1.0 / np.array([config.tolerance_x_m, config.tolerance_y_m, config.tolerance_heading_rad]) ** 2)
    r = np.diag(1.0 / np.array([config.effort_speed_m_s, config.effort_yaw_rate_rad_s]) ** 2)
    k, _, _ = control.dlqr(a_d, b_d, q, r)
    return np.asarray(k, dtype=np.float64)


@functools.lru_cache(maxsize=32)
def gain_schedule(sample_period_s: float, max_speed_m_s: float, config: LtvLqrConfig) -> tuple[FloatArray, FloatArray]:
    """(v_d, K): the reference speeds (m/s) from −v_max to v_max at most ``config.schedule_step_m_s`` apart, and
    the gains K(v_d) flattened row-wise (one row of 6 per speed: K[0, :], K[1, :]). Cached (about 1 ms per
    Riccati solution); the arrays are read-only."""
    n = max(1, math.ceil(max_speed_m_s / config.schedule_step_m_s))
    speeds = np.linspace(-max_speed_m_s, max_speed_m_s, 2 * n + 1)
    gains = np.stack([unicycle_lqr_gain(float(v), sample_period_s, config).ravel() for v in speeds])
    speeds.setflags(write=False)
    gains.setflags(write=False)
    return speeds, gains


class LtvLqrController(UnicycleTracker):
    """The LTV unicycle controller as a :class:`~agvctl.controllers.base.PoseController`.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: wheel separation b (m), sample period T_s (s, the discretisation step) and its
        derived max speed (the default wheel-speed limit and the range of the gain schedule).
    config : LtvLqrConfig or None
        LQR tolerances and efforts, the schedule's spacing and the wheel-speed limit (m/s); None: WPILib's
        defaults.
    """

    def __init__(self, vehicle: VehicleParams, config: LtvLqrConfig | None = None) -> None:
        expect_instance(vehicle, VehicleParams, "LtvLqrController", "vehicle")
        if config is not None:
            expect_instance(config, LtvLqrConfig, "LtvLqrController", "config")
        super().__init__(vehicle)
        self.config = config if config is not None else LtvLqrConfig()
        limit = self.config.max_wheel_speed_m_s
        self.max_wheel_speed_m_s = float(limit if limit is not None else vehicle.derived.max_speed_m_s)
        self.schedule_speeds_m_s, self.schedule_gains = gain_schedule(
            self.sample_period_s, self.max_wheel_speed_m_s, self.config
        )

    def gain(self, speed_m_s: float) -> FloatArray:
        """K (2×3) at reference speed ``speed_m_s``: linear interpolation in the schedule (clamped at ±v_max)."""
        v = self.schedule_speeds_m_s
        j = int(np.clip(np.searchsorted(v, speed_m_s) - 1, 0, len(v) - 2))
        w = min(max((speed_m_s - v[j]) / (v[j + 1] - v[j]), 0.0), 1.0)
        k: FloatArray = ((1.0 - w) * self.schedule_gains[j] + w * self.schedule_gains[j + 1]).reshape(2, 3)
        return k

    def _law(self, error: tuple[float, float, float], speed_m_s: float, yaw_rate_rad_s: float) -> tuple[float, float]:
        k = self.gain(speed_m_s)  # K e, each row's sum written out (as the generated C computes it)
        e_x, e_y, e_theta = error
        du_speed = float(k[0, 0]) * e_x + float(k[0, 1]) * e_y + float(k[0, 2]) * e_theta
        du_yaw_rate = float(k[1, 0]) * e_x + float(k[1, 1]) * e_y + float(k[1, 2]) * e_theta
        return speed_m_s + du_speed, yaw_rate_rad_s + du_yaw_rate
