"""The full nonlinear model: coupled motors with pre-velocity friction, centrifugal and coriolis terms, unequal
wheel radii, per-side motor constants and the armature current limit, plus unicycle kinematics.

Built symbolically in CasADi, as the report derives it: eqs 2-4 (friction), 47-51 (coupling constants), 52-59
(coupled motor dynamics with the algebraic loop removed), 39-43 (kinematics). The vehicle enters as a numeric
parameter vector (:func:`parameter_vector`), so one compiled function serves every vehicle and a batch of
parameter variants.

State ``x`` (5): pre-velocities ω̃_l, ω̃_r of the two motors (rad/s, see :mod:`agvctl.plant.friction`), and the
pose x, y (m), θ (rad) of the point of rotation. Input ``u`` (2): the amplifier's output voltages u_l, u_r (V),
that is after the DA converter and the amplifier's voltage limit (:mod:`agvctl.actuator`). The current limit
is applied inside the right-hand side, continuously.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from agvctl.config import document_fields
from agvctl.params import (
    SIDES,
    VehicleParams,
    coupling_constants,
    inertia_rotation_point,
    motor_damping,
    rim_from_motor,
)
from agvctl.plant.friction import friction_torque, motor_speed

__all__ = [
    "AUX_NAMES",
    "FullModel",
    "INPUT_NAMES",
    "PARAMETER_NAMES",
    "PlantOptions",
    "STATE_NAMES",
    "parameter_vector",
    "state_from_motor_speeds",
]

STATE_NAMES = ("omega_pre_left_rad_s", "omega_pre_right_rad_s", "x_m", "y_m", "theta_rad")
INPUT_NAMES = ("voltage_left_v", "voltage_right_v")
AUX_NAMES = (
    "omega_motor_left_rad_s",
    "omega_motor_right_rad_s",
    "current_left_a",
    "current_right_a",
    "current_limited_left",
    "current_limited_right",
    "wheel_accel_left_m_s2",
    "wheel_accel_right_m_s2",
    "speed_m_s",
    "yaw_rate_rad_s",
)
_SIDE_KEYS = (
    "radius_m",
    "inertia_kg_m2",
    "resistance_ohm",
    "voltage_constant_v_s_rad",
    "torque_constant_n_m_a",
    "viscous_friction_n_m_s_rad",
    "coulomb_friction_n_m",
    "stiction_n_m",
    "gear_ratio",
)
PARAMETER_NAMES = (
    "mass_kg",
    "inertia_rotation_point_kg_m2",
    "com_behind_axle_m",
    "separation_m",
    "current_limit_a",
    "p_factor",
    *(f"{k}_left" for k in _SIDE_KEYS),
    *(f"{k}_right" for k in _SIDE_KEYS),
)


def parameter_vector(vehicle: VehicleParams) -> np.ndarray:
    """The plant's numeric parameter vector for a vehicle: the ``p`` of :attr:`FullModel.rhs`.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle.

    Returns
    -------
    ndarray
        Its constants laid out as :data:`PARAMETER_NAMES`, each in the unit its name ends in.
    """
    values: list[float] = [
        vehicle.body.mass_kg,
        inertia_rotation_point(vehicle.body),
        vehicle.body.com_behind_axle_m,
        vehicle.wheels.separation_m,
        vehicle.amplifier.current_limit_a,
        vehicle.friction_model.p_factor,
    ]
    for side in SIDES:
        m = vehicle.motor.side(side)
        values += [
            vehicle.wheels.side(side).radius_m,
            m.inertia_kg_m2,
            m.resistance_ohm,
            m.voltage_constant_v_s_rad,
            m.torque_constant_n_m_a,
            m.viscous_friction_n_m_s_rad,
            m.coulomb_friction_n_m,
            m.stiction_n_m,
            m.gear_ratio,
        ]
    return np.array(values, dtype=float)


@document_fields
@dataclass(frozen=True)
class PlantOptions:
    """Which nonlinear effects the model includes. All on is the full model of eqs 31-34 / 52-59."""

    friction: bool = True
    """Coulomb friction and stiction (eqs 2-4). Off: ω_mot = ω̃ and no friction torque besides f_m."""
    centrifugal: bool = True
    """The centrifugal and coriolis torques (the k_llr, k_lrr terms of eqs 52-55)."""
    current_limit: bool = True
    """Clip the armature current at ±I_max inside the right-hand side."""


@dataclass(frozen=True)
class _Side:
    r: Any
    J: Any
    R: Any
    k_e: Any
    k_t: Any
    f_m: Any
    tau_c: Any
    tau_s: Any
    N: Any


class FullModel:
    """The nonlinear AGV model as CasADi expressions and functions.

    ``FullModel().rhs`` is a ``casadi.Function`` ``(x[5], u[2], p[n]) -> (xdot[5], aux[10])``: the state
    :data:`STATE_NAMES`, the motor voltages :data:`INPUT_NAMES` and the parameters :func:`parameter_vector` give
    the state's derivative and the quantities named in :data:`AUX_NAMES` at that instant.

    Parameters
    ----------
    options : PlantOptions or None
        The nonlinear effects it includes (None: all of them).
    """

    def __init__(self, options: PlantOptions | None = None) -> None:
        self.options = options or PlantOptions()
        x = ca.SX.sym("x", len(STATE_NAMES))
        u = ca.SX.sym("u", len(INPUT_NAMES))
        p = ca.SX.sym("p", len(PARAMETER_NAMES))
        xdot, aux = self._equations(x, u, p)
        self.x, self.u, self.p, self.xdot, self.aux = x, u, p, xdot, aux
        tag = "".join(str(int(v)) for v in dataclasses.astuple(self.options))
        self.rhs = ca.Function(f"agv_rhs_{tag}", [x, u, p], [xdot, aux], ["x", "u", "p"], ["xdot", "aux"])

    def _equations(self, x: ca.SX, u: ca.SX, p: ca.SX) -> tuple[ca.SX, ca.SX]:
        opt = self.options
        par = {name: p[i] for i, name in enumerate(PARAMETER_NAMES)}
        M, i_o, h, b = (
            par["mass_kg"],
            par["inertia_rotation_point_kg_m2"],
            par["com_behind_axle_m"],
            par["separation_m"],
        )
        i_max, p_factor = par["current_limit_a"], par["p_factor"]
        sides = [_Side(*(par[f"{k}_{s}"] for k in _SIDE_KEYS)) for s in ("left", "right")]
        L, Rt = sides
        k_ll, k_rr, k_lr, k_llr, k_lrr = coupling_constants(M, i_o, h, b, L.r, Rt.r, L.N, Rt.N)  # eqs 47-51
        if not opt.centrifugal:
            k_llr, k_lrr = 0.0, 0.0

        omega_pre = [x[0], x[1]]
        omega, friction, current, limited = [], [], [], []
        for s, w_pre, u_s in zip(sides, omega_pre, [u[0], u[1]], strict=True):
            P = p_factor * motor_damping(s.k_e, s.k_t, s.R, s.f_m)  # eq 62
            if opt.friction:
                w = motor_speed(w_pre, s.tau_s, P)  # eq 2 (corrected)
                friction.append(friction_torque(w_pre, w, s.tau_s, s.tau_c, P))  # eqs 3-4: τ₁ − τ₂
            else:
                w = w_pre
                friction.append(0.0)
            i_raw = (u_s - s.k_e * w) / s.R  # armature current, inductance neglected (eq 1)
            if opt.current_limit:
                current.append(ca.fmin(ca.fmax(i_raw, -i_max), i_max))
                limited.append(ca.fabs(i_raw) > i_max)
            else:
                current.append(i_raw)
                limited.append(ca.SX(0))
            omega.append(w)
        w_l, w_r = omega
        # eqs 54-55; k_t i is k_t/R u − k_e k_t/R ω_mot of eq 33 with the current limit applied
        tau_l = L.k_t * current[0] - L.f_m * w_l - friction[0] - k_lrr * w_r**2 + k_llr * w_r * w_l  # eq 54
        tau_r = Rt.k_t * current[1] - Rt.f_m * w_r - friction[1] - k_llr * w_l**2 + k_lrr * w_r * w_l  # eq 55
        a_l, a_r = L.J + k_ll, Rt.J + k_rr
        dw_l = (tau_l - k_lr / a_r * tau_r) / (a_l - k_lr**2 / a_r)  # eq 58
        dw_r = (tau_r - k_lr / a_l * tau_l) / (a_r - k_lr**2 / a_l)  # eq 59

        v_l, v_r = rim_from_motor(w_l, L.r, L.N), rim_from_motor(w_r, Rt.r, Rt.N)  # eqs 26, 29: wheel rim speeds
        speed = (v_r + v_l) / 2.0  # eq 39
        yaw_rate = (v_r - v_l) / b  # eq 40
        theta = x[4]
        xdot = ca.vertcat(dw_l, dw_r, speed * ca.cos(theta), speed * ca.sin(theta), yaw_rate)  # eqs 41-43
        # dω_mot/dt = dω̃/dt while sliding, 0 while sticking (eq 2)
        moving = [ca.fabs(w) > 0 for w in omega] if opt.friction else [1.0, 1.0]
        accel_l = rim_from_motor(1.0, L.r, L.N) * dw_l * moving[0]  # r/N · dω_mot/dt
        accel_r = rim_from_motor(1.0, Rt.r, Rt.N) * dw_r * moving[1]
        aux = ca.vertcat(w_l, w_r, current[0], current[1], limited[0], limited[1], accel_l, accel_r, speed, yaw_rate)
        return xdot, aux

    def linearize(self, x0: np.ndarray, u0: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Jacobians ``(A, B)`` of the right-hand side at ``(x0, u0)``, computed symbolically by CasADi."""
        jac = ca.Function(
            "agv_jacobians", [self.x, self.u, self.p], [ca.jacobian(self.xdot, self.x), ca.jacobian(self.xdot, self.u)]
        )
        A, B = jac(x0, u0, p)
        return np.asarray(A, dtype=float), np.asarray(B, dtype=float)


def state_from_motor_speeds(
    vehicle: VehicleParams, omega_motor_rad_s: tuple[float, float], pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
) -> np.ndarray:
    """The state vector for given motor speeds, sliding in their direction, and pose: the inverse of eq 2.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its stiction and friction gain P set the dead zone between ω̃ and ω_mot.
    omega_motor_rad_s : tuple of float
        The motor speeds (left, right), rad/s.
    pose : tuple of float
        x (m), y (m) and heading (rad).

    Returns
    -------
    ndarray
        The state, laid out as :data:`STATE_NAMES`.
    """
    d = vehicle.derived
    state = [0.0, 0.0, *pose]
    for i, (w, side) in enumerate(zip(omega_motor_rad_s, (vehicle.motor.left, vehicle.motor.right), strict=True)):
        P = (d.left if i == 0 else d.right).friction_gain_p
        state[i] = w + np.sign(w) * side.stiction_n_m / P
    return np.array(state, dtype=float)
