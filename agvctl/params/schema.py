"""The vehicle file's schema (the report's appendix A): one frozen dataclass per table, the loader, and the
derived constants of a vehicle.

A vehicle file is TOML with the tables ``frame``, ``battery``, ``body``, ``wheels`` and ``motor`` (each with
optional ``left`` / ``right`` overrides, :mod:`agvctl.params.sides`), ``amplifier``, ``da``, ``friction_model``,
``control`` and ``sensors``; see ``agvctl/vehicles/iau_agv.toml``. :func:`load_vehicle` reads one (or the
default), applies ``--set`` style overrides and returns a frozen :class:`VehicleParams`; :func:`derive` computes
its :attr:`VehicleParams.derived` by the equations of :mod:`agvctl.params.derived`.

Units are SI throughout and are part of every key's name.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from agvctl.config import apply_overrides, build, check_fields, join_key, load_toml, number, parse_override, to_dict
from agvctl.errors import ConfigError
from agvctl.params.derived import (
    DerivedConstants,
    Side,
    SideConstants,
    coupling_constants,
    equivalent_inertias,
    motor_damping,
    motor_from_rim,
    rim_from_motor,
)
from agvctl.params.sides import MotorPair, MotorParams, WheelParams

__all__ = [
    "AmplifierParams",
    "BatteryParams",
    "BodyParams",
    "ControlParams",
    "DAParams",
    "FrameParams",
    "FrictionModelParams",
    "SensorParams",
    "MAX_PLANT_SUBSTEPS",
    "MAX_SAMPLES_PER_RUN",
    "PLANT_STIFFNESS_STEP",
    "VehicleParams",
    "check_sample_count",
    "default_vehicle_path",
    "derive",
    "inertia_from_dimensions",
    "inertia_rotation_point",
    "load_vehicle",
]

InertiaAbout = Literal["rotation_point", "center_of_mass"]

MAX_SAMPLES_PER_RUN = 10_000_000
"""The most control samples one run may take — a planned reference, an open-loop or a closed-loop simulation:
10^7, 4.6 days at 40 ms. A closed-loop log holds about a hundred columns of 8 bytes, so some 8 GB at the bound."""
PLANT_STIFFNESS_STEP = 0.4
"""Largest h·λ the plant's RK4 substeps allow for the stiffest mode (RK4's real-axis stability limit is 2.78)."""
MAX_PLANT_SUBSTEPS = 4096
"""The most RK4 substeps per control sample: 10 µs steps at 40 ms; a vehicle needing more is refused."""


def check_sample_count(samples: float, source: str, key: str, what: str) -> None:
    """Refuse a run of more than :data:`MAX_SAMPLES_PER_RUN` samples before anything is allocated for it.

    Raises
    ------
    ConfigError
        ``"<source>: <key>: <what> would take <n> samples, above the maximum 10000000 per run"``.
    """
    if not samples <= MAX_SAMPLES_PER_RUN:
        raise ConfigError(
            source, key, f"{what} would take {samples:.4g} samples, above the maximum {MAX_SAMPLES_PER_RUN} per run"
        )


@dataclass(frozen=True)
class FrameParams:
    """The vehicle frame (appendix A, "Frame dimensions")."""

    length_m: float = number(gt=0)
    width_m: float = number(gt=0)
    height_m: float = number(gt=0)
    mass_kg: float = number(gt=0)
    front_to_rotation_point_m: float = number(ge=0, doc="d_of (l_of in eq 64)")
    wheel_axis_to_castor_m: float = number(gt=0, doc="d_wc (eq 63)")

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class BatteryParams:
    """The battery block, centred over the point of rotation (appendix A.1)."""

    length_m: float = number(gt=0)
    width_m: float = number(gt=0)
    height_m: float = number(gt=0)
    mass_kg: float = number(gt=0)

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class BodyParams:
    """Total mass M, moment of inertia I and centre of mass h behind the wheel axle."""

    mass_kg: float = number(gt=0)
    inertia_kg_m2: float = number(gt=0)
    com_behind_axle_m: float = number()
    inertia_about: InertiaAbout = "rotation_point"

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class AmplifierParams:
    """Power amplifier: gain k_pow, and its voltage and current limits (model note 9, docs/model-notes.md)."""

    gain: float = number(gt=0, doc="k_pow")
    current_limit_a: float = number(gt=0, doc="I_max")
    voltage_limit_v: float = number(gt=0, doc="u_max")

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class DAParams:
    """DA converter: output range and resolution."""

    min_v: float = number()
    max_v: float = number()
    bits: int = number(gt=0, le=32)

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        if not self.min_v < self.max_v:
            raise ConfigError(
                source, join_key(prefix, "min_v"), f"must be below max_v (got {self.min_v:g} >= {self.max_v:g})"
            )

    @property
    def volts_per_code(self) -> float:
        """alpha_DA = (max_v - min_v) / 2**bits (10 V / 4096 = 2.44140625e-3 V for the default)."""
        return float(self.max_v - self.min_v) / float(1 << self.bits)

    @property
    def code_min(self) -> int:
        return -(1 << (self.bits - 1))

    @property
    def code_max(self) -> int:
        return (1 << (self.bits - 1)) - 1

    @property
    def mid_v(self) -> float:
        return 0.5 * (self.min_v + self.max_v)


@dataclass(frozen=True)
class FrictionModelParams:
    """The pre-velocity friction model's gain factor: P = p_factor * (k_e k_t + f_m R) / R (eq 62)."""

    p_factor: float = number(gt=0, default=10.0)

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class SensorParams:
    """The vehicle's sensors (docs/guide/estimation.md): incremental encoders on the motor shafts, an
    optional rate gyro, and absolute position fixes from a beacon/laser system. Under ``[plant] set`` these are
    the true sensors; in the vehicle file they are what the estimators believe."""

    encoder_counts_per_rev: int = number(gt=0, default=2000, doc="counts per motor revolution after quadrature")
    gyro_enabled: bool = False
    gyro_sigma_rad_s: float = number(ge=0, default=0.002, doc="white noise of each sample's mean rate")
    gyro_bias_rad_s: float = number(default=0.0, doc="constant bias of the reading")
    gyro_quantum_rad_s: float = number(ge=0, default=0.0008, doc="resolution of the reading (0: none)")
    position_fix_rate_hz: float = number(ge=0, default=4.0, doc="0: no fixes")
    position_fix_sigma_m: float = number(gt=0, default=0.01)
    heading_fix_sigma_deg: float = number(gt=0, default=0.5)
    position_fix_latency_s: float = number(ge=0, le=10.0, default=0.05)

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class ControlParams:
    """Digital control: the sample period T_s."""

    sample_period_s: float = number(ge=1e-4, le=1.0, doc="0.1 ms … 1 s")

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class VehicleParams:
    """Every constant of one vehicle, as in its TOML file. Immutable and hashable."""

    name: str
    frame: FrameParams
    battery: BatteryParams
    body: BodyParams
    wheels: WheelParams
    motor: MotorPair
    amplifier: AmplifierParams
    da: DAParams
    control: ControlParams
    friction_model: FrictionModelParams = dataclasses.field(default_factory=FrictionModelParams)
    sensors: SensorParams = dataclasses.field(default_factory=SensorParams)

    def validate(self, *, source: str, prefix: str) -> None:
        per_sample_hz, rate_hz = 1.0 / self.control.sample_period_s, self.sensors.position_fix_rate_hz
        if rate_hz > per_sample_hz * (1 + 1e-9):
            raise ConfigError(
                source,
                "sensors.position_fix_rate_hz",
                f"at most one fix per control sample: <= {per_sample_hz:g} Hz (got {rate_hz:g})",
            )
        for side, m in (("left", self.motor.left), ("right", self.motor.right)):
            stall = self.amplifier.current_limit_a * m.torque_constant_n_m_a
            if stall <= m.stiction_n_m:
                raise ConfigError(
                    source,
                    "amplifier.current_limit_a",
                    f"motor torque at the current limit ({stall:g} N m, {side}) does not exceed the stiction "
                    f"({m.stiction_n_m:g} N m): the vehicle cannot move",
                )
        try:
            derived = derive(self).as_dict()
        except ArithmeticError:  # e.g. a square that overflows
            derived = {}
        if not derived or not all(math.isfinite(v) for v in derived.values()):
            raise ConfigError(source, prefix, "the derived constants overflow: a value is far out of range")
        try:
            rate_1_s = self.stiffest_rate_1_s()
        except np.linalg.LinAlgError:  # k_ll k_rr − k_lr² cancels to nothing for an inertia far out of range
            raise ConfigError(
                source, prefix, "the motor-side mass matrix is singular: a mass or inertia is far out of range"
            ) from None
        substeps = self.control.sample_period_s * rate_1_s / PLANT_STIFFNESS_STEP
        if not substeps <= MAX_PLANT_SUBSTEPS:
            raise ConfigError(
                source,
                "friction_model.p_factor",
                f"the plant would need {substeps:.3g} RK4 substeps per control sample, above the maximum "
                f"{MAX_PLANT_SUBSTEPS} (the stiction spring P against the motor inertia; lower p_factor)",
            )

    def stiffest_rate_1_s(self) -> float:
        """λ_max (1/s), the largest eigenvalue of M⁻¹·diag(max(P, k_e k_t/R + f_m)), M the motor-side mass matrix
        of eqs 56-57: the stiction spring of eqs 2-3 (or the back-EMF damping, if P is set below it) against the
        inertia. It sets the plant's RK4 substeps (:data:`PLANT_STIFFNESS_STEP`)."""
        d = self.derived
        ml, mr = self.motor.left, self.motor.right
        mass = np.array([[ml.inertia_kg_m2 + d.k_ll, d.k_lr], [d.k_lr, mr.inertia_kg_m2 + d.k_rr]])
        stiffness = [max(side.friction_gain_p, side.damping_n_m_s_rad) for side in (d.left, d.right)]
        return float(np.max(np.abs(np.linalg.eigvals(np.linalg.solve(mass, np.diag(stiffness))))))

    @property
    def derived(self) -> DerivedConstants:
        """The derived constants (cached)."""
        return derive(self)

    def to_rim(self, side: Side, motor: float) -> float:
        """A motor-shaft angle (rad), speed (rad/s) or acceleration of ``side`` at its wheel's rim (m, m/s, m/s²):
        motor · r/N (:func:`~agvctl.params.derived.rim_from_motor`)."""
        return float(rim_from_motor(motor, self.wheels.side(side).radius_m, self.motor.side(side).gear_ratio))

    def to_motor(self, side: Side, rim: float) -> float:
        """A rim travel (m), speed (m/s) or acceleration of ``side`` at its motor shaft: rim · N/r."""
        return float(motor_from_rim(rim, self.wheels.side(side).radius_m, self.motor.side(side).gear_ratio))

    def rim_per_motor_rad(self, side: Side) -> float:
        """r/N of ``side`` (m/rad): the rim metres per motor-shaft radian."""
        return self.to_rim(side, 1.0)

    def with_overrides(self, overrides: Iterable[str | tuple[str, Any]], source: str = "--set") -> VehicleParams:
        """A copy with dotted-key overrides applied, e.g. ``["wheels.right.radius_m=0.101"]``."""
        pairs = [parse_override(o, source) if isinstance(o, str) else o for o in overrides]
        raw = apply_overrides(to_dict(self), pairs, VehicleParams, source)
        return build(VehicleParams, raw, source=source)


# -- the derived constants ----------------------------------------------------------------------------------------


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


def inertia_rotation_point(body: BodyParams) -> float:
    """I + M h², the inertia about the point of rotation used by eqs 16-28 (model note 6, docs/model-notes.md)."""
    if body.inertia_about == "rotation_point":
        return body.inertia_kg_m2  # the table's 5.46 kg m² is about O: it already is I + M h²
    return body.inertia_kg_m2 + body.mass_kg * body.com_behind_axle_m**2  # literal eq 12: I about the CoM


def _full_scale_amplifier_voltage(v: VehicleParams) -> float:
    """Amplifier output at the DA's largest code: min(k_pow · v_DA(code_max), u_max)."""
    v_da = v.da.mid_v + v.da.code_max * v.da.volts_per_code
    return min(v.amplifier.gain * abs(v_da), v.amplifier.voltage_limit_v)


@functools.lru_cache(maxsize=256)
def derive(v: VehicleParams) -> DerivedConstants:
    """Compute the derived constants of a vehicle (cached per parameter set)."""
    M, h, b = v.body.mass_kg, v.body.com_behind_axle_m, v.wheels.separation_m
    r_l, r_r = v.wheels.left.radius_m, v.wheels.right.radius_m
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
        a_lim = rim_from_motor(
            (v.amplifier.current_limit_a * m.torque_constant_n_m_a - m.coulomb_friction_n_m) / j_tot, r, m.gear_ratio
        )
        return SideConstants(
            radius_m=r,
            inertia_equivalent_kg_m2=j_eq,
            damping_n_m_s_rad=damping,
            friction_gain_p=p_gain,
            mechanical_time_constant_s=j_eq / damping,
            max_motor_speed_rad_s=omega_max,
            max_wheel_speed_m_s=rim_from_motor(omega_max, r, m.gear_ratio),
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


def default_vehicle_path() -> Path:
    """Path of the shipped default vehicle file (the report's appendix A)."""
    return Path(__file__).resolve().parent.parent / "vehicles" / "iau_agv.toml"


def load_vehicle(
    path: str | Path | None = None, overrides: Iterable[str | tuple[str, Any]] = (), *, override_source: str = "--set"
) -> VehicleParams:
    """Load a vehicle file and apply dotted-key overrides.

    Parameters
    ----------
    path
        A vehicle TOML file; ``None`` or ``"default"``: the shipped IAU AGV (the report's appendix A).
    overrides
        Dotted-key overrides applied on top of the file, as ``"KEY=VALUE"`` strings
        (``"wheels.right.radius_m=0.101"``) or ``(key, value)`` pairs; values in the key's unit.
    override_source
        How the overrides are named in error messages (the command line's ``--set``).

    Returns
    -------
    VehicleParams
        The validated, frozen vehicle; ``.derived`` holds the derived constants (eqs 5, 47-51, 60-64).

    Raises
    ------
    ConfigError
        A one-line message naming the file (or ``--set``) and the key.
    """
    if path is None or str(path) == "default":
        path = default_vehicle_path()
    raw = load_toml(path)
    pairs = [parse_override(o, override_source) if isinstance(o, str) else o for o in overrides]
    if pairs:
        raw = apply_overrides(raw, pairs, VehicleParams, override_source)
        source = f"{path} (with {override_source})"
    else:
        source = str(path)
    return build(VehicleParams, raw, source=source)
