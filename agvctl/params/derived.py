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

    h = M_c / (M_l + M_r + M_c) · d_wc (moment balance about the wheel axle). Returns ``(M, h)``.
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
    """k_ll, k_rr, k_lr, k_llr, k_lrr of eqs 47-51, with ``i_o`` = I + M h² (about the point of rotation).

    Written for numbers and CasADi symbols alike. With different gear ratios per side the report's N² and N³
    become N_l², N_r², N_l N_r, N_l² N_r and N_l N_r² (from eqs 29-30 applied per side).
    """
    trans, rot = M / 4.0, i_o / b**2
    k_ll = r_l**2 / n_l**2 * (trans + rot)  # eq 47
    k_rr = r_r**2 / n_r**2 * (trans + rot)  # eq 48
    k_lr = r_l * r_r / (n_l * n_r) * (trans - rot)  # eq 49
    k_llr = M * h * r_l**2 * r_r / (b**2 * n_l**2 * n_r)  # eq 50
    k_lrr = M * h * r_l * r_r**2 / (b**2 * n_l * n_r**2)  # eq 51
    return k_ll, k_rr, k_lr, k_llr, k_lrr


def equivalent_inertias(j_l: Num, j_r: Num, k_ll: Num, k_rr: Num, k_lr: Num) -> tuple[Num, Num]:
    """J̃_l, J̃_r of eqs 60-61 (the left-hand-side coefficients of eqs 58-59)."""
    j_eq_l = j_l + k_ll - k_lr**2 / (j_r + k_rr)  # eq 60
    j_eq_r = j_r + k_rr - k_lr**2 / (j_l + k_ll)  # eq 61
    return j_eq_l, j_eq_r


def motor_damping(k_e: Num, k_t: Num, R: Num, f_m: Num) -> Num:
    """k_e k_t/R + f_m (N m s/rad): the motor's speed-proportional torque loss, back-EMF through the armature
    resistance plus viscous friction (eq 1; the ω_mot terms of eqs 33-34, 37-38 and 54-55).

    Written for numbers and CasADi symbols alike. Eq 62's friction gain is P = p_factor times it, and the
    decoupled model (eqs 60-61) has the pole −damping/J̃.
    """
    return k_e * k_t / R + f_m


def rim_from_motor(motor: Num, radius_m: Num, gear_ratio: Num) -> Num:
    """motor · r/N: a motor-shaft angle (rad), speed (rad/s) or acceleration (rad/s²) as the travel (m), speed (m/s)
    or acceleration (m/s²) of the wheel's rim (eqs 26, 29). ``motor = 1`` gives r/N, the rim metres per motor
    radian.

    The product comes first, ``motor * r / N``. Written for numbers and CasADi symbols alike.
    """
    return motor * radius_m / gear_ratio


def motor_from_rim(rim: Num, radius_m: Num, gear_ratio: Num) -> Num:
    """rim · N/r: the inverse of :func:`rim_from_motor`, a rim travel, speed or acceleration at the motor shaft."""
    return rim * gear_ratio / radius_m


@dataclass(frozen=True)
class SideConstants:
    """Constants of one side (motor, gear, wheel)."""

    radius_m: float
    inertia_equivalent_kg_m2: float
    """J̃, eqs 60-61."""
    damping_n_m_s_rad: float
    """k_e k_t/R + f_m (:func:`motor_damping`)."""
    friction_gain_p: float
    """P, eq 62 (N m s/rad)."""
    mechanical_time_constant_s: float
    """J̃ R / (k_e k_t + f_m R), of the decoupled model (60-61)."""
    max_motor_speed_rad_s: float
    """Steady motor speed at full DA output, straight line: k_t u/R = (k_e k_t/R + f_m) ω + τ_c (eq 33)."""
    max_wheel_speed_m_s: float
    breakaway_amplifier_voltage_v: float
    """Smallest amplifier voltage that starts the motor from rest: τ_s R / k_t."""
    accel_limit_m_s2: float
    """eq 5 with this side's constants."""


@dataclass(frozen=True)
class DerivedConstants:
    """Constants computed from :class:`VehicleParams`, each from the report's equation it names."""

    inertia_from_dimensions_kg_m2: float
    """eq 64."""
    inertia_rotation_point_kg_m2: float
    """I + M h² of eqs 16-28, about the point of rotation (model note 6, docs/model-notes.md)."""
    k_ll: float
    """eq 47: r_l²/N_l² (M/4 + (I+Mh²)/b²)."""
    k_rr: float
    """eq 48: r_r²/N_r² (M/4 + (I+Mh²)/b²)."""
    k_lr: float
    """eq 49: r_l r_r/(N_l N_r) (M/4 − (I+Mh²)/b²)."""
    k_llr: float
    """eq 50: M h r_l² r_r / (b² N_l² N_r)."""
    k_lrr: float
    """eq 51: M h r_l r_r² / (b² N_l N_r²)."""
    accel_limit_m_s2: float
    """eq 5: (I_max k_t − τ_c)/J_tot · r/N, J_tot = J + M r²/(2N²); the smaller of the two sides."""
    da_volts_per_bit: float
    max_speed_m_s: float
    """Steady straight-line speed at full DA output, friction included (the slower side's wheel speed)."""
    mechanical_time_constant_s: float
    """The larger of the two sides' J̃ R/(k_e k_t + f_m R)."""
    left: SideConstants
    right: SideConstants

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
