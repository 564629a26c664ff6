"""The rules a vehicle's numbers obey together, by physics: each one line with its reason and the report's equation.

Each number of a vehicle lies in its physically possible range (:mod:`agvctl.params.ranges`); these rules check
what only several numbers together can say: a centre of mass the wheels and the castor carry, an inertia about
it that is positive, a body at least as heavy as the frame and battery it is made of, a torque constant that
matches the back-EMF constant, wheels that fit the frame, an encoder that resolves the wheel speed. A vehicle
that breaks one is refused with a one-line :class:`~agvctl.errors.ConfigError` naming the key, the rule and its
equation; a truly unusual vehicle names the rules it breaks on purpose in its file::

    [checks]
    accept = ["gear_reduces_speed"]   # an overdrive: the wheel turns faster than its motor

:data:`VEHICLE_RULES` is the registry (``docs/guide/vehicles.md`` lists it, with the tolerances' reasons;
``docs/decisions/0031-vehicle-rules.md`` records why a rule is a rule and how far each tolerance reaches).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from agvctl.config import check_fields, did_you_mean, document_fields
from agvctl.errors import ConfigError
from agvctl.params.derived import DerivedConstants
from agvctl.params.tables import inertia_rotation_point

if TYPE_CHECKING:
    from agvctl.params.sides import MotorParams

__all__ = [
    "CENTER_OF_MASS_INERTIA_SHARE",
    "ENCODER_SPEED_STEP_SHARE",
    "FRAME_AND_BATTERY_MASS_SHARE",
    "TORQUE_CONSTANT_FACTOR",
    "VEHICLE_RULES",
    "VehicleChecks",
    "VehicleRule",
    "broken_rules",
]

TORQUE_CONSTANT_FACTOR = 1.5
"""How far k_t (N m/A) may lie from k_e (V s/rad): within a factor 1.5 either way. Equal in SI units for an ideal
motor (the power k_t i ω delivered is the power k_e ω i drawn); a measured motor's differ by its magnets'
temperature (ferrite loses about 0.2 %/K: 20 % over 100 K), armature reaction at high current (5-10 %) and the
measurements' own error (5 %). Every unit mix-up is further off: V/krpm for V s/rad is a factor 105, rpm for rad/s
9.55, mN m for N m 1000, oz in for N m 141."""
FRAME_AND_BATTERY_MASS_SHARE = 0.5
"""The body's mass M is at least this share of the frame's and battery's M_f + M_b: they are parts of it, but a
Monte Carlo or fuzz envelope draws the true body's mass around the file's (±30 % is a usual spread) while the frame
and battery keep their figures. Half still refuses every unit or digit slip: grams for kilograms, 8.5 for 85."""
CENTER_OF_MASS_INERTIA_SHARE = 0.5
"""The inertia about the centre of mass is at least this share of the frame's and battery's own inertias about
their centres (eq 64's assumptions: mass spread evenly over the frame's floor and the battery's base): a real
frame carries part of its mass nearer its middle (motors, electronics), but not most of it."""
ENCODER_SPEED_STEP_SHARE = 0.05
"""One encoder count per control sample is at most this share of the top motor speed: the speed the wheel loops
measure by counting then resolves 20 steps between rest and full speed at least."""


@document_fields
@dataclass(frozen=True)
class VehicleRule:
    """One rule between a vehicle's numbers: its name, its reason and the report's equation it follows from."""

    name: str
    """The rule's name, as ``[checks] accept`` names it."""
    reason: str
    """Why a vehicle must obey it, in a few words."""
    equation: str
    """The report's equation (or model note) it follows from."""
    broken: Callable[[Any, DerivedConstants], Iterator[tuple[str, str]]]
    """``(key, what is wrong)`` for each place a vehicle (and its derived constants) breaks it."""


def _sides(vehicle: Any, *fields: str) -> Iterator[tuple[MotorParams, str]]:
    """Each distinct motor with the table its ``fields`` are named under: ``motor`` when both sides share them,
    else ``motor.left`` and ``motor.right``."""
    left, right = vehicle.motor.left, vehicle.motor.right
    if all(getattr(left, f) == getattr(right, f) for f in fields):
        yield left, "motor"
    else:
        yield left, "motor.left"
        yield right, "motor.right"


def _center_of_mass(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    h, d_wc = v.body.com_behind_axle_m, v.frame.wheel_axis_to_castor_m
    if not 0.0 <= h < d_wc:
        yield (
            "body.com_behind_axle_m",
            f"the centre of mass {h:g} m behind the wheel axle is not between the axle and the castor ({d_wc:g} m "
            "behind it): the vehicle tips over, or its driving wheels carry none of its weight",
        )


def _castor(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    f = v.frame
    if f.front_to_rotation_point_m + f.wheel_axis_to_castor_m > f.length_m:
        yield (
            "frame.wheel_axis_to_castor_m",
            f"the castor {f.wheel_axis_to_castor_m:g} m behind the axle, which is {f.front_to_rotation_point_m:g} m "
            f"from the front, lies beyond the frame's length {f.length_m:g} m",
        )


def _inertia_about_center_of_mass(v: Any) -> float:
    """I about the centre of mass: I_o − M h² (model note 6)."""
    b = v.body
    return float(inertia_rotation_point(b) - b.mass_kg * b.com_behind_axle_m**2)


def _inertia_positive(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    i_cm, b = _inertia_about_center_of_mass(v), v.body
    if not i_cm > 0.0:
        yield (
            "body.inertia_kg_m2",
            f"{b.inertia_kg_m2:g} kg m² about the point of rotation leaves {b.inertia_kg_m2:g} − M h² = "
            f"{b.inertia_kg_m2:g} − {b.mass_kg:g}·{b.com_behind_axle_m:g}² = {i_cm:.4g} kg m² about the centre of "
            "mass, not positive",
        )


def _inertia_at_least_parts(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    f, bat = v.frame, v.battery
    parts = (f.mass_kg * (f.length_m**2 + f.width_m**2) + bat.mass_kg * (bat.length_m**2 + bat.width_m**2)) / 12.0
    i_cm = _inertia_about_center_of_mass(v)
    if 0.0 < i_cm < CENTER_OF_MASS_INERTIA_SHARE * parts:
        yield (
            "body.inertia_kg_m2",
            f"the inertia about the centre of mass, {i_cm:.4g} kg m², is below {CENTER_OF_MASS_INERTIA_SHARE:g} of "
            f"the frame's and battery's own, {parts:.4g} kg m²",
        )


def _inertia_within_footprint(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    f, m = v.frame, v.body.mass_kg
    most = m * (f.length_m**2 + f.width_m**2)
    i_cm = _inertia_about_center_of_mass(v)
    if i_cm > most:
        yield (
            "body.inertia_kg_m2",
            f"the inertia about the centre of mass, {i_cm:.4g} kg m², exceeds M (l² + w²) = {most:.4g} kg m², "
            "all the mass a frame diagonal away from it",
        )


def _mass(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    parts = v.frame.mass_kg + v.battery.mass_kg
    if v.body.mass_kg < FRAME_AND_BATTERY_MASS_SHARE * parts:
        yield (
            "body.mass_kg",
            f"the body's {v.body.mass_kg:g} kg is below {FRAME_AND_BATTERY_MASS_SHARE:g} of the frame and battery "
            f"it is made of ({v.frame.mass_kg:g} + {v.battery.mass_kg:g} kg)",
        )


def _torque_constant(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    for m, table in _sides(v, "torque_constant_n_m_a", "voltage_constant_v_s_rad"):
        ratio = m.torque_constant_n_m_a / m.voltage_constant_v_s_rad
        if not 1.0 / TORQUE_CONSTANT_FACTOR <= ratio <= TORQUE_CONSTANT_FACTOR:
            yield (
                f"{table}.torque_constant_n_m_a",
                f"k_t = {m.torque_constant_n_m_a:g} N m/A is {ratio:.3g} times k_e = "
                f"{m.voltage_constant_v_s_rad:g} V s/rad, not within a factor {TORQUE_CONSTANT_FACTOR:g}",
            )


def _battery(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    f, b = v.frame, v.battery
    frame_sides, battery_sides = sorted((f.length_m, f.width_m)), sorted((b.length_m, b.width_m))
    if battery_sides[0] > frame_sides[0] or battery_sides[1] > frame_sides[1]:
        key = "frame.width_m" if battery_sides[0] > frame_sides[0] else "frame.length_m"
        yield (
            key,
            f"the battery's {b.length_m:g} m × {b.width_m:g} m base does not fit the frame's "
            f"{f.length_m:g} m × {f.width_m:g} m floor",
        )


def _separation(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    b, w = v.wheels.separation_m, v.frame.width_m
    if b > 2.0 * w:
        yield (
            "wheels.separation_m",
            f"b = {b:g} m is more than twice the frame's width {w:g} m: the wheels are not on the frame",
        )


def _radius(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    length = v.frame.length_m
    left, right = v.wheels.left.radius_m, v.wheels.right.radius_m
    named = (
        [("wheels.radius_m", left)]
        if left == right
        else [("wheels.left.radius_m", left), ("wheels.right.radius_m", right)]
    )
    for key, r in named:
        if 2.0 * r > length:
            yield key, f"a wheel {2.0 * r:g} m across does not fit the frame's length {length:g} m"


def _gear(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    for m, table in _sides(v, "gear_ratio"):
        if m.gear_ratio < 1.0:
            yield (
                f"{table}.gear_ratio",
                f"N = {m.gear_ratio:g} turns the wheel faster than its motor; a wheel drive's gear reduces the speed",
            )


def _friction_gain(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    p = v.friction_model.p_factor
    if p < 10.0:
        yield (
            "friction_model.p_factor",
            f"{p:g} makes the friction loop less than 10 times faster than the motor's own (the report: 10 to 100)",
        )


def _encoder(v: Any, d: DerivedConstants) -> Iterator[tuple[str, str]]:
    counts, ts = v.sensors.encoder_counts_per_rev, v.control.sample_period_s
    step = 2.0 * math.pi / (counts * ts)  # rad/s of one count per sample
    top = min(d.left.max_motor_speed_rad_s, d.right.max_motor_speed_rad_s)
    if top > 0.0 and step > ENCODER_SPEED_STEP_SHARE * top:  # a vehicle that cannot move: the planner names why
        yield (
            "sensors.encoder_counts_per_rev",
            f"{counts} counts per revolution resolve the motor speed in steps of {step:.3g} rad/s per sample, more "
            f"than {ENCODER_SPEED_STEP_SHARE:g} of the top speed {top:.3g} rad/s",
        )


VEHICLE_RULES: tuple[VehicleRule, ...] = (
    VehicleRule("body_mass_holds_frame_and_battery", "the frame and battery are parts of the body", "eq 64", _mass),
    VehicleRule("center_of_mass_between_axle_and_castor", "static balance on three wheels", "eq 63", _center_of_mass),
    VehicleRule("castor_on_the_frame", "the castor is a wheel of the frame", "eq 63", _castor),
    VehicleRule(
        "inertia_about_center_of_mass_positive", "a body's inertia is positive", "eqs 12, 16, 47-51", _inertia_positive
    ),
    VehicleRule(
        "inertia_at_least_its_parts",
        "the frame and battery are parts of the body",
        "eqs 12, 64",
        _inertia_at_least_parts,
    ),
    VehicleRule(
        "inertia_within_the_frame",
        "the mass lies within the frame's footprint",
        "eqs 12, 64",
        _inertia_within_footprint,
    ),
    VehicleRule(
        "torque_constant_matches_voltage_constant", "k_t = k_e in SI units", "eq 1, model note 4", _torque_constant
    ),
    VehicleRule("battery_fits_the_frame", "the battery stands on the frame's floor", "eq 64", _battery),
    VehicleRule("wheels_on_the_frame", "the wheels are mounted on the frame", "eqs 24-25, 40", _separation),
    VehicleRule("wheels_fit_the_frame", "a wheel fits within the vehicle's length", "eq 26", _radius),
    VehicleRule("gear_reduces_speed", "a wheel drive's gear is a reduction", "eqs 29-30", _gear),
    VehicleRule(
        "friction_loop_faster_than_the_motor", "the friction model's recommended gain", "eq 62", _friction_gain
    ),
    VehicleRule("encoder_resolves_the_speed", "the wheel loops measure speed by counting", "eqs 29, 33", _encoder),
)
"""Every rule, in the order a vehicle is checked."""


def broken_rules(vehicle: Any, derived: DerivedConstants, accept: tuple[str, ...] = ()) -> Iterator[tuple[str, str]]:
    """``(key, one-line problem)`` for each rule the vehicle breaks and does not accept, in :data:`VEHICLE_RULES`'s
    order.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle.
    derived : DerivedConstants
        Its derived constants.
    accept : tuple of str
        The rules its file accepts (``[checks] accept``).

    Yields
    ------
    tuple of (str, str)
        The key to name, and the problem: what is wrong, the rule's reason and equation, and how to accept it.
    """
    for rule in VEHICLE_RULES:
        if rule.name in accept:
            continue
        for key, problem in rule.broken(vehicle, derived):
            yield key, f"{problem} ({rule.reason}; {rule.equation}; rule {rule.name}, see [checks] accept)"


@document_fields
@dataclass(frozen=True)
class VehicleChecks:
    """``[checks]``: the rules of :data:`VEHICLE_RULES` a truly unusual vehicle breaks on purpose."""

    accept: tuple[str, ...] = ()
    """The names of the rules not to check for this vehicle (an overdrive: ``["gear_reduces_speed"]``)."""

    def __post_init__(self) -> None:
        check_fields(self)
        names = [rule.name for rule in VEHICLE_RULES]
        for i, name in enumerate(self.accept):
            if name not in names:
                raise ConfigError(
                    type(self).__name__, f"accept[{i}]", f"no rule {name!r}" + did_you_mean(name, names, [])
                )
