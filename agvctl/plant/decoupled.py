"""The decoupled per-wheel model (eqs 60-61) as python-control transfer functions.

All nonlinear terms and the cross-coupling dropped; each motor sees the equivalent inertia J̃ of eqs 60-61:
``J̃ ω̇ = k_t/R u − (k_e k_t/R + f_m) ω``, so ``ω(s)/u(s) = (k_t/R) / (J̃ s + k_e k_t/R + f_m)``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

from agvctl.errors import expect_instance
from agvctl.params import VehicleParams

if TYPE_CHECKING:
    import control

__all__ = ["DecoupledModels", "decoupled_wheel_coefficients", "decoupled_wheel_models"]


class DecoupledModels(NamedTuple):
    """Left and right motor: voltage (V) → motor speed (rad/s).

    Parameters
    ----------
    left : control.TransferFunction
        The left motor's model, from its voltage (V) to its speed (rad/s).
    right : control.TransferFunction
        The right motor's.
    """

    left: control.TransferFunction
    right: control.TransferFunction


def decoupled_wheel_coefficients(vehicle: VehicleParams) -> tuple[tuple[list[float], list[float]], ...]:
    """The coefficients of the per-wheel transfer functions of eqs 60-61, without python-control.

    Parameters
    ----------
    vehicle : VehicleParams
        Its equivalent inertias and damping (eqs 60-62) are the coefficients.

    Returns
    -------
    tuple
        ``((num, den), (num, den))`` of the left and the right motor, in descending powers of s: ``[k_t/R]`` and
        ``[J̃, k_e k_t/R + f_m]``, from motor voltage (V) to motor speed (rad/s).
    """
    expect_instance(vehicle, VehicleParams, "decoupled_wheel_coefficients", "vehicle")
    d = vehicle.derived
    out = []
    for side, consts in (("left", d.left), ("right", d.right)):
        m = vehicle.motor.side(side)  # type: ignore[arg-type]
        k_u = m.torque_constant_n_m_a / m.resistance_ohm
        out.append(([k_u], [consts.inertia_equivalent_kg_m2, consts.damping_n_m_s_rad]))
    return tuple(out)


def decoupled_wheel_models(vehicle: VehicleParams) -> DecoupledModels:
    """The per-wheel transfer functions of eqs 60-61.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle whose equivalent inertia and damping (eqs 60-62) give each side's first-order model.

    Returns
    -------
    DecoupledModels
        ``(left, right)``: each a ``control.TransferFunction`` from motor voltage (V) to motor speed (rad/s), with
        the coefficients of :func:`decoupled_wheel_coefficients`.
    """
    import control

    expect_instance(vehicle, VehicleParams, "decoupled_wheel_models", "vehicle")
    out = [
        control.tf(
            num,
            den,
            inputs=f"voltage_{side}_v",
            outputs=f"omega_motor_{side}_rad_s",
            name=f"agv_wheel_{side}",
        )
        for side, (num, den) in zip(("left", "right"), decoupled_wheel_coefficients(vehicle), strict=True)
    ]
    return DecoupledModels(*out)
