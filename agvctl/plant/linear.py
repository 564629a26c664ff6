"""The simplified linear model (eqs 35-38) as python-control state-space systems.

Coriolis and centrifugal forces and Coulomb friction/stiction neglected; the coupling through the vehicle's
inertia (k_ll, k_rr, k_lr of eqs 47-49) kept. States and outputs are the motor speeds, inputs the motor
(amplifier output) voltages. Signals are named, so the systems compose with ``control.interconnect``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from agvctl.errors import expect_instance
from agvctl.params import VehicleParams

if TYPE_CHECKING:
    import control

__all__ = ["linear_model", "linear_model_speed_yaw_rate", "linear_model_matrices"]

_STATES = ["omega_motor_left_rad_s", "omega_motor_right_rad_s"]
_INPUTS = ["voltage_left_v", "voltage_right_v"]


def linear_model_matrices(vehicle: VehicleParams) -> tuple[np.ndarray, np.ndarray]:
    """The matrices of eqs 35-38 written as ``M ω̇ = K u − D ω`` and solved for ω̇.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle whose constants fill the matrices.

    Returns
    -------
    A : ndarray
        2 × 2, from the motor speeds (rad/s) to their derivatives, 1/s.
    B : ndarray
        2 × 2, from the motor voltages (V) to the motor accelerations, rad/(V s²).
    """
    d = vehicle.derived
    ml, mr = vehicle.motor.left, vehicle.motor.right
    # eqs 35 + 37 and 36 + 38: (J + k_ll) ω̇_l + k_lr ω̇_r = k_t/R u_l − (k_e k_t/R + f_m) ω_l, and mirrored
    mass = np.array([[ml.inertia_kg_m2 + d.k_ll, d.k_lr], [d.k_lr, mr.inertia_kg_m2 + d.k_rr]])
    gain = np.diag([m.torque_constant_n_m_a / m.resistance_ohm for m in (ml, mr)])
    damping = np.diag([d.left.damping_n_m_s_rad, d.right.damping_n_m_s_rad])
    A = -np.linalg.solve(mass, damping)
    B = np.linalg.solve(mass, gain)
    return A, B


def linear_model(vehicle: VehicleParams) -> control.StateSpace:
    """Eqs 35-38: motor voltages (V) → motor speeds (rad/s), continuous time.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle whose constants (and derived constants) fill the matrices.

    Returns
    -------
    control.StateSpace
        Inputs ``voltage_left_v``, ``voltage_right_v`` (V); states and outputs ``omega_motor_left_rad_s``,
        ``omega_motor_right_rad_s``.
    """
    import control

    expect_instance(vehicle, VehicleParams, "linear_model", "vehicle")
    A, B = linear_model_matrices(vehicle)
    return control.ss(
        A, B, np.eye(2), np.zeros((2, 2)), states=_STATES, inputs=_INPUTS, outputs=_STATES, name="agv_linear"
    )


def linear_model_speed_yaw_rate(vehicle: VehicleParams) -> control.StateSpace:
    """Eqs 35-38 with the vehicle's speed U and yaw rate ω as outputs (eqs 39-40).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle whose constants fill the matrices.

    Returns
    -------
    control.StateSpace
        Inputs ``voltage_left_v``, ``voltage_right_v`` (V); states the motor speeds (rad/s); outputs
        ``speed_m_s`` (m/s) and ``yaw_rate_rad_s`` (rad/s).
    """
    import control

    A, B = linear_model_matrices(vehicle)
    r_l, r_r, b = vehicle.wheels.left.radius_m, vehicle.wheels.right.radius_m, vehicle.wheels.separation_m
    n_l, n_r = vehicle.motor.left.gear_ratio, vehicle.motor.right.gear_ratio
    C = np.array([[r_l / (2 * n_l), r_r / (2 * n_r)], [-r_l / (b * n_l), r_r / (b * n_r)]])  # eqs 39-40, 29
    return control.ss(
        A,
        B,
        C,
        np.zeros((2, 2)),
        states=_STATES,
        inputs=_INPUTS,
        outputs=["speed_m_s", "yaw_rate_rad_s"],
        name="agv_linear_u_omega",
    )
