"""The constants derived from a vehicle's parameters: the report's equations they come from, and the records
that hold them.

The equations take plain numbers or CasADi symbols alike, so the plant's symbolic model (:mod:`agvctl.plant.full`)
and the numeric constants share one definition. :class:`DerivedConstants` holds one vehicle's constants;
:func:`agvctl.params.schema.derive` fills it from the vehicle's tables (``vehicle.derived`` calls it, cached).
This module knows nothing of the tables: :mod:`agvctl.params.schema` builds on it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Literal

from agvctl.config import document_fields

__all__ = [
    "DerivedConstants",
    "Side",
    "SideConstants",
    "center_of_mass_from_scales",
    "coupling_constants",
    "equivalent_inertias",
    "motor_damping",
    "motor_from_rim",
    "rim_from_motor",
]

Side = Literal["left", "right"]
"""A side of the vehicle: its left or right wheel and motor."""

Num = Any  # a float or a CasADi symbol: the equations below serve both


def center_of_mass_from_scales(
    mass_left_kg: float, mass_right_kg: float, mass_castor_kg: float, wheel_axis_to_castor_m: float
) -> tuple[float, float]:
    """Total mass M and centre of mass h behind the wheel axle from three scale readings, eq 63.

    h = M_c / (M_l + M_r + M_c) · d_wc (moment balance about the wheel axle).

    Parameters
    ----------
    mass_left_kg, mass_right_kg : float
        The readings M_l and M_r of the scales under the left and right wheel, kg.
    mass_castor_kg : float
        The reading M_c of the scale under the castor, kg.
    wheel_axis_to_castor_m : float
        d_wc, from the wheel axle to the castor, m.

    Returns
    -------
    mass_kg : float
        M, the sum of the readings, kg.
    com_behind_axle_m : float
        h, m.

    Raises
    ------
    ValueError
        A reading that is negative or not finite, or readings that sum to zero.

    Examples
    --------
    >>> center_of_mass_from_scales(36.0, 36.0, 13.0, 0.5)
    (85.0, 0.07647058823529412)
    """
    for name, value in (
        ("mass_left_kg", mass_left_kg),
        ("mass_right_kg", mass_right_kg),
        ("mass_castor_kg", mass_castor_kg),
    ):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite, non-negative mass (got {value})")
    total = mass_left_kg + mass_right_kg + mass_castor_kg
    if total <= 0:
        raise ValueError("the three scale readings sum to zero")
    return total, mass_castor_kg / total * wheel_axis_to_castor_m


def coupling_constants(M: Num, i_o: Num, h: Num, b: Num, r_l: Num, r_r: Num, n_l: Num, n_r: Num) -> tuple[Num, ...]:
    """The coupling constants k_ll, k_rr, k_lr, k_llr, k_lrr of eqs 47-51.

    Written for numbers and CasADi symbols alike. With different gear ratios per side the report's N² and N³
    become N_l², N_r², N_l N_r, N_l² N_r and N_l N_r² (from eqs 29-30 applied per side).

    Parameters
    ----------
    M : float or CasADi symbol
        The vehicle's mass, kg.
    i_o : float or CasADi symbol
        Its inertia about the point of rotation, I + M h², kg m².
    h : float or CasADi symbol
        Its centre of mass behind the wheel axle, m.
    b : float or CasADi symbol
        The wheel separation, m.
    r_l, r_r : float or CasADi symbol
        The left and right wheel radii, m.
    n_l, n_r : float or CasADi symbol
        The left and right gear ratios.

    Returns
    -------
    tuple
        ``(k_ll, k_rr, k_lr, k_llr, k_lrr)``, kg m² each: k_ll, k_rr, k_lr couple the motor accelerations,
        k_llr and k_lrr weigh the centrifugal and coriolis terms, products of the motor speeds.
    """
    trans, rot = M / 4.0, i_o / b**2
    k_ll = r_l**2 / n_l**2 * (trans + rot)  # eq 47
    k_rr = r_r**2 / n_r**2 * (trans + rot)  # eq 48
    k_lr = r_l * r_r / (n_l * n_r) * (trans - rot)  # eq 49
    k_llr = M * h * r_l**2 * r_r / (b**2 * n_l**2 * n_r)  # eq 50
    k_lrr = M * h * r_l * r_r**2 / (b**2 * n_l * n_r**2)  # eq 51
    return k_ll, k_rr, k_lr, k_llr, k_lrr


def equivalent_inertias(j_l: Num, j_r: Num, k_ll: Num, k_rr: Num, k_lr: Num) -> tuple[Num, Num]:
    """The equivalent inertias J̃_l, J̃_r of eqs 60-61 (the left-hand-side coefficients of eqs 58-59).

    Parameters
    ----------
    j_l, j_r : float or CasADi symbol
        The left and right motors' rotor inertias J, kg m².
    k_ll, k_rr, k_lr : float or CasADi symbol
        The coupling constants of eqs 47-49 (:func:`coupling_constants`), kg m².

    Returns
    -------
    tuple
        ``(J̃_l, J̃_r)``, kg m²: each side's inertia as its motor sees it when the other side's speed is held by
        its own loop.
    """
    j_eq_l = j_l + k_ll - k_lr**2 / (j_r + k_rr)  # eq 60
    j_eq_r = j_r + k_rr - k_lr**2 / (j_l + k_ll)  # eq 61
    return j_eq_l, j_eq_r


def motor_damping(k_e: Num, k_t: Num, R: Num, f_m: Num) -> Num:
    """The motor's speed-proportional torque loss k_e k_t/R + f_m: back-EMF through the armature resistance plus
    viscous friction (eq 1; the ω_mot terms of eqs 33-34, 37-38 and 54-55).

    Written for numbers and CasADi symbols alike. Eq 62's friction gain is P = p_factor times it, and the
    decoupled model (eqs 60-61) has the pole −damping/J̃.

    Parameters
    ----------
    k_e : float or CasADi symbol
        The back-EMF constant, V s/rad.
    k_t : float or CasADi symbol
        The torque constant, N m/A.
    R : float or CasADi symbol
        The armature resistance, Ω.
    f_m : float or CasADi symbol
        The viscous friction, N m s/rad.

    Returns
    -------
    float or CasADi symbol
        The damping, N m s/rad.
    """
    return k_e * k_t / R + f_m


def rim_from_motor(motor: Num, radius_m: Num, gear_ratio: Num) -> Num:
    """A motor-shaft angle, speed or acceleration as the travel, speed or acceleration of the wheel's rim, motor · r/N
    (eqs 26, 29). ``motor = 1`` gives r/N, the rim metres per motor radian.

    The product comes first, ``motor * r / N``. Written for numbers and CasADi symbols alike.

    Parameters
    ----------
    motor : float, ndarray or CasADi symbol
        The motor-shaft angle (rad), speed (rad/s) or acceleration (rad/s²).
    radius_m : float or CasADi symbol
        The wheel's radius r, m.
    gear_ratio : float or CasADi symbol
        The gear ratio N.

    Returns
    -------
    float, ndarray or CasADi symbol
        The rim's travel (m), speed (m/s) or acceleration (m/s²).

    Examples
    --------
    >>> rim_from_motor(36.0, 0.1, 36.0)  # 36 rad/s at the motor: 0.1 m/s at the rim
    0.1
    """
    return motor * radius_m / gear_ratio


def motor_from_rim(rim: Num, radius_m: Num, gear_ratio: Num) -> Num:
    """A rim travel, speed or acceleration at the motor shaft, rim · N/r: the inverse of :func:`rim_from_motor`.

    Parameters
    ----------
    rim : float, ndarray or CasADi symbol
        The rim's travel (m), speed (m/s) or acceleration (m/s²).
    radius_m : float or CasADi symbol
        The wheel's radius r, m.
    gear_ratio : float or CasADi symbol
        The gear ratio N.

    Returns
    -------
    float, ndarray or CasADi symbol
        The motor-shaft angle (rad), speed (rad/s) or acceleration (rad/s²).
    """
    return rim * gear_ratio / radius_m


@document_fields
@dataclass(frozen=True)
class SideConstants:
    """Constants of one side (motor, gear, wheel)."""

    radius_m: float
    """The wheel's radius r, m."""
    inertia_equivalent_kg_m2: float
    """J̃, eqs 60-61, kg m²."""
    damping_n_m_s_rad: float
    """k_e k_t/R + f_m (:func:`motor_damping`), N m s/rad."""
    friction_gain_p: float
    """P, eq 62, N m s/rad."""
    mechanical_time_constant_s: float
    """J̃ R / (k_e k_t + f_m R), of the decoupled model (60-61), s."""
    max_motor_speed_rad_s: float
    """Steady motor speed at full DA output, straight line: k_t u/R = (k_e k_t/R + f_m) ω + τ_c (eq 33), rad/s."""
    max_wheel_speed_m_s: float
    """The same speed at the wheel's rim, m/s."""
    breakaway_amplifier_voltage_v: float
    """Smallest amplifier voltage that starts the motor from rest: τ_s R / k_t, V."""
    accel_limit_m_s2: float
    """Eq 5 with this side's constants: the rim's largest acceleration at the current limit, m/s²."""


@document_fields
@dataclass(frozen=True)
class DerivedConstants:
    """Constants computed from :class:`~agvctl.params.VehicleParams`, each from the report's equation it names."""

    inertia_from_dimensions_kg_m2: float
    """The inertia from the frame's and battery's dimensions, eq 64, kg m²."""
    inertia_rotation_point_kg_m2: float
    """I + M h² of eqs 16-28, about the point of rotation (model note 6, docs/model-notes.md), kg m²."""
    k_ll: float
    """Eq 47: r_l²/N_l² (M/4 + (I+Mh²)/b²), kg m²."""
    k_rr: float
    """Eq 48: r_r²/N_r² (M/4 + (I+Mh²)/b²), kg m²."""
    k_lr: float
    """Eq 49: r_l r_r/(N_l N_r) (M/4 − (I+Mh²)/b²), kg m²."""
    k_llr: float
    """Eq 50: M h r_l² r_r / (b² N_l² N_r), kg m²."""
    k_lrr: float
    """Eq 51: M h r_l r_r² / (b² N_l N_r²), kg m²."""
    accel_limit_m_s2: float
    """Eq 5: (I_max k_t − τ_c)/J_tot · r/N, J_tot = J + M r²/(2N²); the smaller of the two sides, m/s²."""
    da_volts_per_bit: float
    """The DA converter's step, V."""
    max_speed_m_s: float
    """Steady straight-line speed at full DA output, friction included (the slower side's wheel speed), m/s."""
    mechanical_time_constant_s: float
    """The larger of the two sides' J̃ R/(k_e k_t + f_m R), s."""
    left: SideConstants
    """The left side's constants."""
    right: SideConstants
    """The right side's constants."""

    def side(self, name: Side) -> SideConstants:
        return self.left if name == "left" else self.right

    def as_dict(self) -> dict[str, float]:
        """Flat mapping used by ``agvctl params --json``."""
        out: dict[str, float] = {k: v for k, v in dataclasses.asdict(self).items() if not isinstance(v, dict)}
        for side in ("left", "right"):
            sc: SideConstants = getattr(self, side)
            out[f"inertia_equivalent_{side}_kg_m2"] = sc.inertia_equivalent_kg_m2
            out[f"damping_{side}_n_m_s_rad"] = sc.damping_n_m_s_rad
            out[f"friction_gain_p_{side}"] = sc.friction_gain_p
            out[f"mechanical_time_constant_{side}_s"] = sc.mechanical_time_constant_s
            out[f"max_motor_speed_{side}_rad_s"] = sc.max_motor_speed_rad_s
            out[f"max_wheel_speed_{side}_m_s"] = sc.max_wheel_speed_m_s
            out[f"breakaway_amplifier_voltage_{side}_v"] = sc.breakaway_amplifier_voltage_v
        return out
