"""The vehicle tables that come once per side: the wheels and the motors.

In a file, each is one table of common values whose ``left`` / ``right`` sub-tables override any of them for one
side: ``[wheels]`` holds ``separation_m`` and the common ``radius_m``, ``[wheels.left]`` a left radius of its own;
``[motor]`` holds every motor constant, ``[motor.right]`` the right motor's differences. Written back
(``to_file``), a value both sides share is the common one and a value they differ in goes to the sides' tables.
In Python both sides are always complete: ``vehicle.wheels.left.radius_m``, ``vehicle.motor.side("right")``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

from agvctl.config import (
    as_file_error,
    check_fields,
    convert_value,
    did_you_mean,
    document_fields,
    join_key,
    number,
    renamed,
)
from agvctl.errors import ConfigError
from agvctl.params.derived import Side
from agvctl.params.ranges import check_ranges, physical

__all__ = ["SIDES", "MotorPair", "MotorParams", "WheelParams", "WheelSide"]

SIDES: tuple[Side, Side] = ("left", "right")

_MOTOR_CONSTANT = (1e-5, 1e3, "a watch motor's 10 µV s/rad to a ship's 1 kV s/rad")
"""The physically possible range of k_e (V s/rad) and k_t (N m/A), and its reason."""
_TORQUE = (0.0, 1e5, "below a hundred kilonewton metres")
"""The physically possible range of a motor's friction torques (N m, N m s/rad), and its reason."""

T = TypeVar("T")


def _sides_from_file(side_cls: type[T], data: Mapping[str, Any], *, source: str, prefix: str) -> tuple[T, T]:
    """The left and right ``side_cls`` of a pair's file table: the common values of ``side_cls``'s keys in
    ``data``, each side's table in ``data["left"]`` / ``data["right"]`` overriding them. The pair checks the other
    keys of its own table."""
    meta = {f.name: f.metadata for f in dataclasses.fields(side_cls)}  # type: ignore[arg-type]
    base = {k: convert_value(float, v, source, join_key(prefix, k), meta[k]) for k, v in data.items() if k in meta}
    sides: list[T] = []
    for side in SIDES:
        side_prefix = join_key(prefix, side)
        override = data.get(side, {})
        if not isinstance(override, Mapping):
            raise ConfigError(source, side_prefix, "expected a table")
        for k in override:
            if k not in meta:
                raise ConfigError(
                    source, join_key(side_prefix, k), "unknown key" + did_you_mean(k, meta, [side_prefix])
                )
        merged = dict(base)
        merged.update(
            {k: convert_value(float, v, source, join_key(side_prefix, k), meta[k]) for k, v in override.items()}
        )
        for k in meta:
            if k not in merged:
                raise ConfigError(source, join_key(prefix, k), "missing key")
        with as_file_error(side_cls, source, side_prefix if override else prefix):
            sides.append(side_cls(**merged))
    return sides[0], sides[1]


def _sides_to_file(left: Any, right: Any) -> dict[str, Any]:
    """The file form of two sides: the values they share, then each side's table of the values they differ in."""
    lv, rv = dataclasses.asdict(left), dataclasses.asdict(right)
    out: dict[str, Any] = {k: lv[k] for k in lv if lv[k] == rv[k]}
    for side, values in (("left", lv), ("right", rv)):
        diff = {k: values[k] for k in values if lv[k] != rv[k]}
        if diff:
            out[side] = diff
    return out


@document_fields
@dataclass(frozen=True)
class WheelSide:
    """One driving wheel."""

    radius_m: float = physical(1e-3, 10.0, "a millimetre to ten metres", gt=0, doc="Its radius r (r_l or r_r), m.")

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)


_WHEEL_SIDE_KEYS = tuple(f.name for f in dataclasses.fields(WheelSide))
_TOLERANCE_KEYS = ("radius_tolerance", "separation_tolerance")
_RENAMED_WHEEL_KEYS = {"radius_left_m": "left.radius_m", "radius_right_m": "right.radius_m"}


@document_fields
@dataclass(frozen=True)
class WheelParams:
    """The driving wheels: the left and right wheel (radii r_l, r_r) and their separation b. In a file,
    ``[wheels]`` holds ``separation_m`` and the common ``radius_m``; ``[wheels.left]`` / ``[wheels.right]``
    override it for one side. The tolerances say how well the file knows them (appendix A.1: "Wheel base and wheel
    radius ... are particularly important to know precisely"); the pose EKF's calibration priors follow from them."""

    left: WheelSide
    """The left wheel."""
    right: WheelSide
    """The right wheel."""
    separation_m: float = physical(
        1e-3,
        100.0,
        "a millimetre to a hundred metres",
        gt=0,
        doc="b, the distance between the wheels' contact points, m.",
    )
    radius_tolerance: float = number(
        ge=0.0, le=0.2, default=0.01, doc="Relative half-width of the range each true radius lies in (±)."
    )
    separation_tolerance: float = number(
        ge=0.0, le=0.2, default=0.02, doc="Relative half-width of the range the true separation lies in (±)."
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)

    @classmethod
    def extra_file_keys(cls) -> dict[str, Any]:
        return {k: float for k in _WHEEL_SIDE_KEYS}

    @classmethod
    def renamed_file_keys(cls) -> dict[str, str]:
        return dict(_RENAMED_WHEEL_KEYS)

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> WheelParams:
        allowed = ["separation_m", *_TOLERANCE_KEYS, *_WHEEL_SIDE_KEYS, "left", "right"]
        for k in data:
            if k in _RENAMED_WHEEL_KEYS:
                raise ConfigError(source, join_key(prefix, k), renamed(join_key(prefix, _RENAMED_WHEEL_KEYS[k])))
            if k not in allowed:
                raise ConfigError(source, join_key(prefix, k), "unknown key" + did_you_mean(k, allowed, [prefix]))
        key = join_key(prefix, "separation_m")
        if "separation_m" not in data:
            raise ConfigError(source, key, "missing key")
        meta = {f.name: f.metadata for f in dataclasses.fields(cls)}
        separation = convert_value(float, data["separation_m"], source, key, meta["separation_m"])
        tolerances = {
            k: convert_value(float, data[k], source, join_key(prefix, k), meta[k]) for k in _TOLERANCE_KEYS if k in data
        }
        left, right = _sides_from_file(WheelSide, data, source=source, prefix=prefix)
        with as_file_error(cls, source, prefix):
            return cls(separation_m=separation, left=left, right=right, **tolerances)

    def to_file(self) -> dict[str, Any]:
        tolerances = {k: getattr(self, k) for k in _TOLERANCE_KEYS}
        return {"separation_m": self.separation_m, **tolerances, **_sides_to_file(self.left, self.right)}

    def side(self, name: Side) -> WheelSide:
        return self.left if name == "left" else self.right


@document_fields
@dataclass(frozen=True)
class MotorParams:
    """One armature-controlled DC motor with its gear (eqs 1-4, appendix A "Actuator characteristics")."""

    inertia_kg_m2: float = physical(
        1e-12, 1e3, "a watch motor's rotor to a ship's", gt=0, doc="J, the rotor's moment of inertia, kg m²."
    )
    resistance_ohm: float = physical(
        1e-4, 1e4, "a traction motor's 0.1 mΩ to a micro-motor's 10 kΩ", gt=0, doc="R, the armature resistance, Ω."
    )
    voltage_constant_v_s_rad: float = physical(*_MOTOR_CONSTANT, gt=0, doc="k_e, the back-EMF constant, V s/rad.")
    torque_constant_n_m_a: float = physical(*_MOTOR_CONSTANT, gt=0, doc="k_t, the torque constant, N m/A.")
    viscous_friction_n_m_s_rad: float = physical(*_TORQUE, ge=0, doc="f_m, the viscous friction, N m s/rad.")
    coulomb_friction_n_m: float = physical(*_TORQUE, ge=0, doc="τ_c, the Coulomb (sliding) friction, N m.")
    stiction_n_m: float = physical(*_TORQUE, ge=0, doc="τ_s, the stiction (break-away) torque, at least τ_c, N m.")
    gear_ratio: float = physical(
        1e-3, 1e5, "a thousandth to a hundred thousand", gt=0, doc="N, motor turns per wheel turn."
    )

    def __post_init__(self) -> None:
        check_fields(self)
        check_ranges(self)
        if self.coulomb_friction_n_m > self.stiction_n_m:  # model note 5
            raise ConfigError(
                type(self).__name__,
                "coulomb_friction_n_m",
                f"Coulomb friction {self.coulomb_friction_n_m:g} N m exceeds stiction {self.stiction_n_m:g} N m; "
                "the break-away torque must be at least the sliding friction",
            )


_MOTOR_KEYS = tuple(f.name for f in dataclasses.fields(MotorParams))


@document_fields
@dataclass(frozen=True)
class MotorPair:
    """The left and right motors. In a file, ``[motor]`` holds the common values and ``[motor.left]`` /
    ``[motor.right]`` override any of them for one side."""

    left: MotorParams
    """The left motor."""
    right: MotorParams
    """The right motor."""

    @classmethod
    def extra_file_keys(cls) -> dict[str, Any]:
        return {k: float for k in _MOTOR_KEYS}

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> MotorPair:
        allowed = [*_MOTOR_KEYS, "left", "right"]
        for k in data:
            if k not in allowed:
                raise ConfigError(source, join_key(prefix, k), "unknown key" + did_you_mean(k, allowed, [prefix]))
        left, right = _sides_from_file(MotorParams, data, source=source, prefix=prefix)
        return cls(left=left, right=right)

    def to_file(self) -> dict[str, Any]:
        return _sides_to_file(self.left, self.right)

    def side(self, name: Side) -> MotorParams:
        return self.left if name == "left" else self.right
