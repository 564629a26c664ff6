"""The Ramsete unicycle tracking law, as WPILib ships it (``pose = "ramsete"``): a yardstick and a fallback.

With the robot-frame pose error (e_x, e_y, e_θ) and the reference's speed v_d and yaw rate ω_d at the current
sample (see :mod:`agvctl.controllers.baselines.unicycle`):

    k = 2 ζ √(ω_d² + b v_d²)
    v = v_d cos e_θ + k e_x
    ω = ω_d + k e_θ + b v_d sinc(e_θ) e_y,   sinc(x) = sin(x)/x

b > 0 (rad²/m²) acts like a proportional gain on the lateral error and ζ ∈ (0, 1] is the damping of the
linearised error dynamics. WPILib's defaults, b = 2 rad²/m² and ζ = 0.7, are this module's. The setpoints are
the wheel speeds of (v, ω) (eqs 39-43), scaled down together to the wheel-speed limit.

References: Oriolo, De Luca and Vendittelli, "Control of wheeled mobile robots: an experimental overview", in
*RAMSETE: Articulated and Mobile Robotics for Services and Technologies*, LNCIS 270, Springer 2001, eq 5.12
(the law, after Samson's time-varying tracking feedback); WPILib's "Ramsete Controller" documentation
(docs.wpilib.org, advanced controls → trajectories) for the form and the default gains.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agvctl.config import check_fields, document_fields, number
from agvctl.controllers.baselines.unicycle import UnicycleTracker
from agvctl.controllers.ranges import MAX_WEIGHT, MAX_WHEEL_SPEED_M_S, MIN_WHEEL_SPEED_M_S
from agvctl.errors import expect_instance
from agvctl.params import VehicleParams

__all__ = ["RamseteConfig", "RamseteController", "ramsete_law"]


@document_fields
@dataclass(frozen=True)
class RamseteConfig:
    """Settings of the Ramsete law, as in an experiment file's ``[controller]`` table."""

    b_rad2_m2: float = number(
        gt=0, le=MAX_WEIGHT, default=2.0, doc="b, the convergence gain on the lateral error (at most 10⁶), rad²/m²."
    )
    zeta: float = number(gt=0, le=1, default=0.7, doc="ζ, the damping ratio of the error dynamics.")
    max_wheel_speed_m_s: float | None = number(
        ge=MIN_WHEEL_SPEED_M_S,
        le=MAX_WHEEL_SPEED_M_S,
        default=None,
        doc="The wheel-speed limit of the setpoints (None: the vehicle's max speed), m/s.",
    )

    def __post_init__(self) -> None:
        check_fields(self)


def ramsete_law(
    error: tuple[float, float, float], speed_m_s: float, yaw_rate_rad_s: float, b_rad2_m2: float, zeta: float
) -> tuple[float, float]:
    """The speed and yaw rate the Ramsete law commands (see the module notes).

    Parameters
    ----------
    error : tuple of float
        The robot-frame pose error (e_x in m, e_y in m, e_θ in rad), reference minus vehicle.
    speed_m_s : float
        The reference's speed v_d, m/s.
    yaw_rate_rad_s : float
        The reference's yaw rate ω_d, rad/s.
    b_rad2_m2 : float
        b, the convergence gain on the lateral error, rad²/m².
    zeta : float
        ζ, the damping ratio of the error dynamics.

    Returns
    -------
    speed_m_s : float
        v, m/s.
    yaw_rate_rad_s : float
        ω, rad/s.

    Examples
    --------
    >>> ramsete_law((0.0, 0.0, 0.0), 0.5, 0.1, 2.0, 0.7)  # on the reference: its own speed and yaw rate
    (0.5, 0.1)
    """
    e_x, e_y, e_theta = error
    k = 2.0 * zeta * math.sqrt(yaw_rate_rad_s * yaw_rate_rad_s + b_rad2_m2 * (speed_m_s * speed_m_s))
    sinc = math.sin(e_theta) / e_theta if e_theta != 0.0 else 1.0
    speed = speed_m_s * math.cos(e_theta) + k * e_x
    yaw_rate = yaw_rate_rad_s + k * e_theta + b_rad2_m2 * speed_m_s * sinc * e_y
    return speed, yaw_rate


class RamseteController(UnicycleTracker):
    """The Ramsete law as a :class:`~agvctl.controllers.base.PoseController`.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its wheel separation b (m) turns (v, ω) into wheel speeds, its sample period
        is the control grid, and its derived max speed is the default wheel-speed limit.
    config : RamseteConfig or None
        Gains and the wheel-speed limit (m/s); None: WPILib's defaults.
    """

    def __init__(self, vehicle: VehicleParams, config: RamseteConfig | None = None) -> None:
        expect_instance(vehicle, VehicleParams, "RamseteController", "vehicle")
        if config is not None:
            expect_instance(config, RamseteConfig, "RamseteController", "config")
        super().__init__(vehicle)
        self.config = config if config is not None else RamseteConfig()
        limit = self.config.max_wheel_speed_m_s
        self.max_wheel_speed_m_s = float(limit if limit is not None else vehicle.derived.max_speed_m_s)

    def _law(self, error: tuple[float, float, float], speed_m_s: float, yaw_rate_rad_s: float) -> tuple[float, float]:
        return ramsete_law(error, speed_m_s, yaw_rate_rad_s, self.config.b_rad2_m2, self.config.zeta)
