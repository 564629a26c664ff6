"""The constants derived from a vehicle's parameters, each from the report's equation it names.

:func:`derive` computes them all for one :class:`~agvctl.params.VehicleParams` (``vehicle.derived`` calls it,
cached). The equations that the plant also builds symbolically (:func:`coupling_constants`,
:func:`equivalent_inertias`, :func:`motor_damping`) take plain numbers or CasADi symbols alike, so the model and
the constants share one definition.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the schema's types, for annotations only: the schema imports this module
    from agvctl.params.schema import BatteryParams, BodyParams, FrameParams, MotorParams, VehicleParams

__all__ = [
    "DerivedConstants",
    "SideConstants",
    "center_of_mass_from_scales",
    "coupling_constants",
    "derive",
    "equivalent_inertias",
    "inertia_from_dimensions",
    "inertia_rotation_point",
    "motor_damping",
]

Num = Any  # a float or a CasADi symbol: the equations below serve both


def inertia_from_dimensions(frame: FrameParams, battery: BatteryParams) -> float:
    """Moment of inertia about the point of rotation from the frame and battery dimensions, eq 64.

    I = M_f (l² + w²)/12 + M_f (l/2 − l_of)² + M_b (l_b² + w_b²)/12: frame mass spread over its floor, battery
    mass over its bottom sheet and centred above the point of rotation. 5.46 kg m² for the IAU AGV.
    """
    m_f, length, w, l_of = frame.mass_kg, frame.length_m, frame.width_m, frame.front_to_rotation_point_m
    m_b, l_b, w_b = battery.mass_kg, battery.length_m, battery.width_m
    i_frame = m_f * (length**2 + w**2) / 12.0 + m_f * (length / 2.0 - l_of) ** 2  # eq 64, I_f
    i_battery = m_b * (l_b**2 + w_b**2) / 12.0  # eq 64, I_b
    return i_frame + i_battery


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


def inertia_rotation_point(body: BodyParams) -> float:
    """I + M h², the inertia about the point of rotation used by eqs 16-28 (README, model note 6)."""
    if body.inertia_about == "rotation_point":
        return body.inertia_kg_m2  # the table's 5.46 kg m² is about O: it already is I + M h²
    return body.inertia_kg_m2 + body.mass_kg * body.com_behind_axle_m**2  # literal eq 12: I about the CoM


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
    """I + M h² of eqs 16-28, about the point of rotation (README, model note 6)."""
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


def _full_scale_amplifier_voltage(v: VehicleParams) -> float:
    """Amplifier output at the DA's largest code: min(k_pow · v_DA(code_max), u_max)."""
    v_da = v.da.mid_v + v.da.code_max * v.da.volts_per_code
    return min(v.amplifier.gain * abs(v_da), v.amplifier.voltage_limit_v)


@functools.lru_cache(maxsize=256)
def derive(v: VehicleParams) -> DerivedConstants:
    """Compute the derived constants of a vehicle (cached per parameter set)."""
    M, h, b = v.body.mass_kg, v.body.com_behind_axle_m, v.wheels.separation_m
    r_l, r_r = v.wheels.radius_left_m, v.wheels.radius_right_m
    ml, mr = v.motor.left, v.motor.right
    n_l, n_r = ml.gear_ratio, mr.gear_ratio
    i_o = inertia_rotation_point(v.body)
    k_ll, k_rr, k_lr, k_llr, k_lrr = coupling_constants(M, i_o, h, b, r_l, r_r, n_l, n_r)
    j_eq_l, j_eq_r = equivalent_inertias(ml.inertia_kg_m2, mr.inertia_kg_m2, k_ll, k_rr, k_lr)
    u_full = _full_scale_amplifier_voltage(v)

    def side(m: MotorParams, r: float, j_eq: float) -> SideConstants:
        damping = motor_damping(
            m.voltage_constant_v_s_rad, m.torque_constant_n_m_a, m.resistance_ohm, m.viscous_friction_n_m_s_rad
        )
        p_gain = v.friction_model.p_factor * damping  # eq 62: P = p_factor (k_e k_t + f_m R)/R
        omega_max = max(0.0, (m.torque_constant_n_m_a * u_full / m.resistance_ohm - m.coulomb_friction_n_m) / damping)
        j_tot = m.inertia_kg_m2 + 0.5 * M * r**2 / m.gear_ratio**2  # eq 5
        a_lim = (
            (v.amplifier.current_limit_a * m.torque_constant_n_m_a - m.coulomb_friction_n_m) / j_tot * r / m.gear_ratio
        )
        return SideConstants(
            radius_m=r,
            inertia_equivalent_kg_m2=j_eq,
            damping_n_m_s_rad=damping,
            friction_gain_p=p_gain,
            mechanical_time_constant_s=j_eq / damping,
            max_motor_speed_rad_s=omega_max,
            max_wheel_speed_m_s=omega_max * r / m.gear_ratio,
            breakaway_amplifier_voltage_v=m.stiction_n_m * m.resistance_ohm / m.torque_constant_n_m_a,
            accel_limit_m_s2=a_lim,
        )

    left, right = side(ml, r_l, j_eq_l), side(mr, r_r, j_eq_r)
    return DerivedConstants(
        inertia_from_dimensions_kg_m2=inertia_from_dimensions(v.frame, v.battery),
        inertia_rotation_point_kg_m2=i_o,
        k_ll=k_ll,
        k_rr=k_rr,
        k_lr=k_lr,
        k_llr=k_llr,
        k_lrr=k_lrr,
        accel_limit_m_s2=min(left.accel_limit_m_s2, right.accel_limit_m_s2),
        da_volts_per_bit=v.da.volts_per_code,
        max_speed_m_s=min(left.max_wheel_speed_m_s, right.max_wheel_speed_m_s),
        mechanical_time_constant_s=max(left.mechanical_time_constant_s, right.mechanical_time_constant_s),
        left=left,
        right=right,
    )
