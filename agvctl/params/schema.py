"""The vehicle file's schema (the report's appendix A): the vehicle of all its tables, the loader, and the
derived constants of a vehicle.

A vehicle file is TOML with the tables ``frame``, ``battery``, ``body``, ``wheels`` and ``motor`` (each with
optional ``left`` / ``right`` overrides, :mod:`agvctl.params.sides`), ``amplifier``, ``da``, ``friction_model``,
``control`` and ``sensors`` (:mod:`agvctl.params.tables`); see ``agvctl/vehicles/iau_agv.toml``.
:func:`load_vehicle` reads one (or the default), applies ``--set`` style overrides and returns a frozen
:class:`VehicleParams`; :func:`derive` computes its :attr:`VehicleParams.derived` by the equations of
:mod:`agvctl.params.derived`.

Units are SI throughout and are part of every key's name.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.config import apply_overrides, build, check_fields, document_fields, load_toml, override_pairs, to_dict
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
from agvctl.params.rules import VehicleChecks, broken_rules
from agvctl.params.sides import MotorPair, MotorParams, WheelParams
from agvctl.params.tables import (
    AmplifierParams,
    BatteryParams,
    BodyParams,
    ControlParams,
    DAParams,
    FrameParams,
    FrictionModelParams,
    SensorParams,
    inertia_from_dimensions,
    inertia_rotation_point,
)

__all__ = [  # the once-per-vehicle tables are agvctl.params.tables's, and still importable from here
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

MAX_SAMPLES_PER_RUN = 10_000_000
"""The most control samples one run may take — a planned reference, an open-loop or a closed-loop simulation:
10^7, 4.6 days at 40 ms. A closed-loop log holds about a hundred columns of 8 bytes, so some 8 GB at the bound."""
PLANT_STIFFNESS_STEP = 0.4
"""Largest h·λ the plant's RK4 substeps allow for the stiffest mode (RK4's real-axis stability limit is 2.78)."""
MAX_PLANT_SUBSTEPS = 4096
"""The most RK4 substeps per control sample: 10 µs steps at 40 ms; a vehicle needing more is refused."""


def check_sample_count(samples: float, source: str, key: str, what: str) -> None:
    """Refuse a run of more than :data:`MAX_SAMPLES_PER_RUN` samples before anything is allocated for it.

    Parameters
    ----------
    samples : float
        The samples the run would take (a float: a duration over a period may be huge or infinite).
    source : str
        What the error names as the file or function.
    key : str
        The key or argument that sets the run's length.
    what : str
        The run, as the message names it (``"the reference"``).

    Raises
    ------
    ConfigError
        ``"<source>: <key>: <what> would take <n> samples, above the maximum 10000000 per run"``.
    """
    if not samples <= MAX_SAMPLES_PER_RUN:
        raise ConfigError(
            source, key, f"{what} would take {samples:.4g} samples, above the maximum {MAX_SAMPLES_PER_RUN} per run"
        )


@document_fields
@dataclass(frozen=True)
class VehicleParams:
    """Every constant of one vehicle, as in its TOML file. Immutable and hashable.

    :func:`load_vehicle` reads one from a file; ``vehicle.derived`` holds the constants derived from it.
    """

    name: str
    """The vehicle's name, for reports."""
    frame: FrameParams
    """The frame's dimensions and mass (``[frame]``)."""
    battery: BatteryParams
    """The battery block's dimensions and mass (``[battery]``)."""
    body: BodyParams
    """The vehicle's mass, inertia and centre of mass (``[body]``)."""
    wheels: WheelParams
    """The driving wheels' radii and separation (``[wheels]``)."""
    motor: MotorPair
    """The two motors with their gears (``[motor]``)."""
    amplifier: AmplifierParams
    """The power amplifier (``[amplifier]``)."""
    da: DAParams
    """The DA converter (``[da]``)."""
    control: ControlParams
    """The sample period of the digital control (``[control]``)."""
    friction_model: FrictionModelParams = dataclasses.field(default_factory=FrictionModelParams)
    """The friction model's gain factor (``[friction_model]``)."""
    sensors: SensorParams = dataclasses.field(default_factory=SensorParams)
    """The encoders, gyro and position fixes (``[sensors]``)."""

    checks: VehicleChecks = dataclasses.field(default_factory=VehicleChecks)
    """The rules between its numbers it breaks on purpose (``[checks] accept``, :mod:`agvctl.params.rules`)."""

    def __post_init__(self) -> None:
        """Check the vehicle as its file is checked: each table's fields, then the rules between tables, the
        derived constants and the plant's stiffness. Construction and ``dataclasses.replace`` run it alike."""
        check_fields(self)
        src = type(self).__name__
        per_sample_hz, rate_hz = 1.0 / self.control.sample_period_s, self.sensors.position_fix_rate_hz
        if rate_hz > per_sample_hz * (1 + 1e-9):
            raise ConfigError(
                src,
                "sensors.position_fix_rate_hz",
                f"at most one fix per control sample: <= {per_sample_hz:g} Hz (got {rate_hz:g})",
            )
        for side, m in (("left", self.motor.left), ("right", self.motor.right)):
            stall = self.amplifier.current_limit_a * m.torque_constant_n_m_a
            if stall <= m.stiction_n_m:
                raise ConfigError(
                    src,
                    "amplifier.current_limit_a",
                    f"motor torque at the current limit ({stall:g} N m, {side}) does not exceed the stiction "
                    f"({m.stiction_n_m:g} N m): the vehicle cannot move",
                )
        try:
            derived = derive(self)
            values = derived.as_dict()
        except ArithmeticError:  # within the fields' ranges (agvctl.params.ranges) no constant overflows
            values = {}
        if not values or not all(math.isfinite(v) for v in values.values()):
            raise ConfigError(src, "", "the derived constants overflow: a value is far out of range")
        for key, problem in broken_rules(self, derived, self.checks.accept):
            raise ConfigError(src, key, problem)
        try:
            rate_1_s = self.stiffest_rate_1_s()
        except np.linalg.LinAlgError:  # k_ll k_rr − k_lr² cancels to nothing for an inertia far out of range
            raise ConfigError(
                src,
                "body.inertia_kg_m2",
                "the motor-side mass matrix is singular: a mass or inertia is far out of range",
            ) from None
        substeps = self.control.sample_period_s * rate_1_s / PLANT_STIFFNESS_STEP
        if not substeps <= MAX_PLANT_SUBSTEPS:
            stiff = self.friction_model.p_factor > 10.0  # above eq 62's preferred 10, the gain is what to lower
            tau_s = min(c.inertia_equivalent_kg_m2 / c.friction_gain_p for c in (derived.left, derived.right))
            raise ConfigError(
                src,
                "friction_model.p_factor" if stiff else "motor.inertia_kg_m2",
                f"the plant would need {substeps:.3g} RK4 substeps per control sample, above the maximum "
                f"{MAX_PLANT_SUBSTEPS} (the stiction spring P of eq 62 against the inertia J̃ of eqs 60-61: "
                f"J̃/P = {tau_s:.3g} s; "
                + ("lower p_factor)" if stiff else "the motor is far too fast for its inertia)"),
            )

    def stiffest_rate_1_s(self) -> float:
        """λ_max (1/s), the largest eigenvalue of M⁻¹·diag(max(P, k_e k_t/R + f_m)), M the motor-side mass matrix
        of eqs 56-57: the stiction spring of eqs 2-3 (or the back-EMF damping, if P is set below it) against the
        inertia. It sets the plant's RK4 substeps (:data:`PLANT_STIFFNESS_STEP`)."""
        d = self.derived
        ml, mr = self.motor.left, self.motor.right
        mass = np.array([[ml.inertia_kg_m2 + d.k_ll, d.k_lr], [d.k_lr, mr.inertia_kg_m2 + d.k_rr]])
        stiffness = np.array([max(side.friction_gain_p, side.damping_n_m_s_rad) for side in (d.left, d.right)])
        scale = float(np.max(stiffness))  # scaled so that a huge gain gives a huge rate, never an overflow inside
        rates = np.linalg.eigvals(np.linalg.solve(mass, np.diag(stiffness / scale)))
        with np.errstate(over="ignore"):
            return float(scale * np.max(np.abs(rates)))

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
        raw = apply_overrides(to_dict(self), override_pairs(overrides, source), VehicleParams, source)
        return build(VehicleParams, raw, source=source)


# -- the derived constants ----------------------------------------------------------------------------------------


def _full_scale_amplifier_voltage(v: VehicleParams) -> float:
    """Amplifier output at the DA's largest code: min(k_pow · v_DA(code_max), u_max)."""
    v_da = v.da.mid_v + v.da.code_max * v.da.volts_per_code
    return min(v.amplifier.gain * abs(v_da), v.amplifier.voltage_limit_v)


@functools.lru_cache(maxsize=256)
def derive(v: VehicleParams) -> DerivedConstants:
    """The derived constants of a vehicle, each by the report's equation it names (cached per parameter set).

    Parameters
    ----------
    v : VehicleParams
        The vehicle.

    Returns
    -------
    DerivedConstants
        Its derived constants, what ``v.derived`` returns.
    """
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
    """The shipped default vehicle file: the IAU AGV of the report's appendix A.

    Returns
    -------
    Path
        The file ``agvctl/vehicles/iau_agv.toml`` of the installed package.
    """
    return Path(__file__).resolve().parent.parent / "vehicles" / "iau_agv.toml"


def load_vehicle(
    path: str | Path | None = None, overrides: Iterable[str | tuple[str, Any]] = (), *, override_source: str = "--set"
) -> VehicleParams:
    """Load a vehicle file and apply dotted-key overrides.

    Parameters
    ----------
    path : str, Path or None
        A vehicle TOML file; ``None`` or ``"default"``: the shipped IAU AGV (the report's appendix A).
    overrides : iterable of str or (str, object)
        Dotted-key overrides applied on top of the file, as ``"KEY=VALUE"`` strings
        (``"wheels.right.radius_m=0.101"``) or ``(key, value)`` pairs; values in the key's unit.
    override_source : str
        How the overrides are named in error messages (the command line's ``--set``).

    Returns
    -------
    VehicleParams
        The validated, frozen vehicle; ``.derived`` holds the derived constants (eqs 5, 47-51, 60-64).

    Raises
    ------
    ConfigError
        A one-line message naming the file (or ``--set``) and the key.

    Examples
    --------
    >>> vehicle = load_vehicle(overrides=["wheels.right.radius_m=0.101"])
    >>> vehicle.wheels.left.radius_m, vehicle.wheels.right.radius_m
    (0.1, 0.101)
    >>> print(f"{vehicle.derived.accel_limit_m_s2:.3f} m/s²")
    0.652 m/s²
    """
    if path is not None and (not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str)):
        raise ConfigError(
            "load_vehicle", "path", f"expected a file name as a str or a Path (got {type(path).__name__})"
        )
    if path is None or str(path) == "default":
        path = default_vehicle_path()
    raw = load_toml(path)
    pairs = override_pairs(overrides, override_source)
    if pairs:
        raw = apply_overrides(raw, pairs, VehicleParams, override_source)
        source = f"{path} (with {override_source})"
    else:
        source = str(path)
    return build(VehicleParams, raw, source=source)
