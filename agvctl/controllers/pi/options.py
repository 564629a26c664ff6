"""The settings of the PI wheel-speed loops: their gains and the choices they offer, each with its one default.

:class:`PIGains` is the controller ``C(z) = k_p + k_i T_s · z / (z − 1)`` of
:mod:`~agvctl.controllers.pi.wheel_loop`; :class:`WheelLoopOptions` holds every choice the loops offer (the
Coulomb feed-forward, anti-windup, how hard they brake, steering priority), read by every entry point that builds
them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import TYPE_CHECKING

from agvctl.config import check_fields, document_fields, number
from agvctl.errors import expect_instance
from agvctl.planning.spec import BodyLimits

if TYPE_CHECKING:
    import control

__all__ = ["FEEDFORWARD_RAMP_RAD_S", "Braking", "PIGains", "WheelLoopOptions", "braking_for"]


FEEDFORWARD_RAMP_RAD_S = 2.0
"""ω_ε: the Coulomb feed-forward ramps in linearly up to this motor speed (≈ 5.6 mm/s at the wheel)."""


@document_fields
@dataclass(frozen=True)
class PIGains:
    """Gains of the discrete PI ``C(z) = kp + ki·dt_s·z/(z − 1)``, motor-speed error (rad/s) → motor
    voltage (V)."""

    kp: float = number(ge=0)
    """Proportional gain k_p, V/(rad/s) = V s/rad."""
    ki: float = number(ge=0)
    """Integral gain k_i, V/rad (per second of integrated error in rad/s)."""
    dt_s: float = number(gt=0)
    """Sample period T_s, s."""

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def num(self) -> tuple[float, float]:
        """Numerator of C(z) in descending powers of z: ``(kp + ki·dt_s, −kp)``."""
        return (self.kp + self.ki * self.dt_s, -self.kp)

    @property
    def den(self) -> tuple[float, float]:
        """Denominator of C(z) in descending powers of z: ``(1, −1)``."""
        return (1.0, -1.0)

    def transfer_function(self) -> control.TransferFunction:
        """C(z) as a discrete python-control transfer function with ``dt = dt_s``."""
        import control

        return control.tf(
            list(self.num), list(self.den), self.dt_s, inputs="speed_error_rad_s", outputs="motor_voltage_v"
        )


class Braking(enum.Enum):
    """How hard the loops may brake a wheel (see :func:`symmetric_braking_current_a`)."""

    FULL = "full"
    """With the full current limit, as when accelerating."""
    SYMMETRIC = "symmetric"
    """Always with the current that, helped by friction, decelerates no harder than a_lim (eq 5)."""
    GENTLE_STOP = "gentle_stop"
    """With that current only in the last sample before a wheel stops; at speed with the full limit."""


def braking_for(body: BodyLimits) -> Braking:
    """The braking an experiment's wheel loops take unless it names one: gentle stops on a path that limits the
    body's acceleration (a payload's ``linear_accel_m_s2`` or ``angular_accel_rad_s2``), full braking elsewhere.

    A wheel braked at the full current near a stop decelerates at up to 2.7 a_lim and then stops dead, its friction
    jumping as it does; the load feels both. Limited to a_lim in the last sample before the stop, the wheel comes to
    rest as gently as the plan brings it there, and at speed it keeps its full authority.

    Parameters
    ----------
    body : BodyLimits
        The path's limits on the body's motion.

    Returns
    -------
    Braking
        :attr:`Braking.GENTLE_STOP` where an acceleration limit is set, else :attr:`Braking.FULL`.
    """
    limited = body.linear_accel_m_s2 is not None or body.angular_accel_rad_s2 is not None
    return Braking.GENTLE_STOP if limited else Braking.FULL


@document_fields
@dataclass(frozen=True)
class WheelLoopOptions:
    """The choices of the PI wheel loops, each with its one default.

    Every entry point that builds the loops (an experiment's ``[controller]``, :class:`PIWheelController`,
    ``agvctl tune``'s verification, the calibration experiments) takes its options from here.
    """

    coulomb_feedforward: bool = True
    """Add τ_c R/k_t to the PI output, ramped in over the last :data:`FEEDFORWARD_RAMP_RAD_S` to zero speed. On:
    the wheels then answer small setpoints instead of sitting in the friction until the integrator winds up
    (``docs/decisions/0009-pi-wheel-loops.md``)."""
    anti_windup: bool = True
    """Clamp the output to the window of predicted current ((u − k_e ω)/R within ±I_max) and the DA range, and stop
    the integrator there."""
    braking: Braking = Braking.FULL
    """How hard the loops may brake a wheel (an experiment's loops: :func:`braking_for` its path unless it names
    one)."""
    steering_priority: bool = True
    """When both loops ask for more than their usable voltage the same way, the one asking more gets its limit and
    the other the same current less: the difference of the currents they ask, the torque that turns the vehicle, is
    kept and the speed gives way (``docs/decisions/0026-steering-priority.md``)."""

    def __post_init__(self) -> None:
        for name in ("coulomb_feedforward", "anti_windup", "steering_priority"):
            expect_instance(getattr(self, name), bool, "WheelLoopOptions", name)
        expect_instance(self.braking, Braking, "WheelLoopOptions", "braking")
