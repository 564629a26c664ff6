"""The tables of a fuzz configuration under its top level (:mod:`agvctl.fuzz.spec` has the file's format): how paths
and start poses are drawn, which estimators, and the plant envelope's vehicle values."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from agvctl.config import check_fields, document_fields, join_key, number
from agvctl.config.references import is_reference
from agvctl.errors import ConfigError
from agvctl.estimation.registry import pose_estimators, wheel_speed_estimators
from agvctl.params import VehicleParams

__all__ = [
    "DEFAULT_ENVELOPE",
    "EstimatorsSpec",
    "PathGenSpec",
    "Range",
    "StartSpec",
    "keep_stiction_above_coulomb",
    "nominal_value",
]

Range = tuple[float, float]
"""A relative range ``(low, high)``: a value drawn uniformly in nominal · (1 + [low, high])."""

DEFAULT_ENVELOPE: dict[str, Range] = {
    "wheels.left.radius_m": (-0.01, 0.01),
    "wheels.right.radius_m": (-0.01, 0.01),
    "wheels.separation_m": (-0.02, 0.02),
    "body.mass_kg": (-0.10, 0.30),
    "motor.left.coulomb_friction_n_m": (-0.5, 0.5),
    "motor.left.stiction_n_m": (-0.5, 0.5),
    "motor.right.coulomb_friction_n_m": (-0.5, 0.5),
    "motor.right.stiction_n_m": (-0.5, 0.5),
}
"""The declared plant envelope: each value drawn uniformly in nominal · (1 + [low, high]), each side on its own
(the generator keeps stiction ≥ Coulomb friction, see :mod:`agvctl.fuzz.generate`)."""


def _ordered(
    value: Sequence[float], source: str, key: str, *, low: float | None = None, high: float | None = None
) -> None:
    """A [low, high] range: two numbers, low <= high, within the bounds given."""
    if len(value) != 2:
        raise ConfigError(source, key, f"expected [low, high] (got {len(value)} numbers)")
    lo, hi = value
    if lo > hi:
        raise ConfigError(source, key, f"low {lo:g} is above high {hi:g}")
    if low is not None and lo < low:
        raise ConfigError(source, key, f"must be >= {low:g} (got {lo:g})")
    if high is not None and hi > high:
        raise ConfigError(source, key, f"must be <= {high:g} (got {hi:g})")


@document_fields
@dataclass(frozen=True)
class PathGenSpec:
    """``[paths]``: how random paths are drawn; each range ``(low, high)`` is drawn from uniformly.

    Raises
    ------
    ConfigError
        ``PathGenSpec: <argument>: <problem>``: a range that is not ``(low, high)`` with low <= high within its
        bounds, or an unknown segment type or join.
    """

    segments: tuple[int, ...] = (2, 6)
    """How many segments a path has, inclusive, 1 … 100."""
    segment_types: tuple[str, ...] = ("line", "arc", "turn")
    """The kinds of segment drawn from: ``line``, ``arc``, ``turn``."""
    line_length_m: tuple[float, ...] = (0.3, 2.5)
    """A line's length, m."""
    arc_radius_m: tuple[float, ...] = (0.3, 1.5)
    """An arc's radius, m."""
    arc_angle_deg: tuple[float, ...] = (20.0, 180.0)
    """An arc's angle, its magnitude (left or right at random), °."""
    turn_angle_deg: tuple[float, ...] = (20.0, 180.0)
    """A turn's angle, its magnitude (either way at random), °."""
    join: tuple[str, ...] = ("smooth", "stop")
    """How a path's segments join, drawn from: ``smooth``, ``stop``."""
    explicit_limits_fraction: float = number(
        ge=0.0, le=1.0, default=0.5, doc="The share of paths with a ``[limits]`` table; the others plan with defaults."
    )
    wheel_speed_fraction: tuple[float, ...] = (0.3, 1.0)
    """An explicit wheel speed limit, as a fraction of the vehicle's no-load top speed."""
    wheel_accel_fraction: tuple[float, ...] = (0.3, 1.0)
    """An explicit wheel acceleration limit, as a fraction of the vehicle's a_lim (eq 5)."""

    def __post_init__(self) -> None:
        check_fields(self)
        self.validate(source=type(self).__name__, prefix="")

    def validate(self, *, source: str, prefix: str) -> None:
        def k(name: str) -> str:
            return join_key(prefix, name)

        _ordered(self.segments, source, k("segments"), low=1, high=100)
        _ordered(self.line_length_m, source, k("line_length_m"), low=1e-3, high=1000)
        _ordered(self.arc_radius_m, source, k("arc_radius_m"), low=1e-3, high=1000)
        _ordered(self.arc_angle_deg, source, k("arc_angle_deg"), low=0.1, high=3600)
        _ordered(self.turn_angle_deg, source, k("turn_angle_deg"), low=0.1, high=3600)
        for name in ("wheel_speed_fraction", "wheel_accel_fraction"):
            _ordered(getattr(self, name), source, k(name), low=1e-3, high=1.0)
        for name, allowed in (("segment_types", ("line", "arc", "turn")), ("join", ("smooth", "stop"))):
            values = getattr(self, name)
            if not values:
                raise ConfigError(source, k(name), f"give at least one of {', '.join(map(repr, allowed))}")
            for i, v in enumerate(values):
                if v not in allowed:
                    raise ConfigError(
                        source, f"{k(name)}[{i}]", f"must be one of {', '.join(map(repr, allowed))} (got {v!r})"
                    )


@document_fields
@dataclass(frozen=True)
class StartSpec:
    """``[start]``: how far the true start pose is off the path's start, at most (uniform in distance, direction
    and heading)."""

    offset_max_m: float = number(ge=0.0, le=10.0, default=0.05, doc="The largest offset of the position, m.")
    heading_max_deg: float = number(ge=0.0, le=180.0, default=5.0, doc="The largest offset of the heading, °.")

    def __post_init__(self) -> None:
        check_fields(self)


@document_fields
@dataclass(frozen=True)
class EstimatorsSpec:
    """``[estimators]``: the pose and wheel-speed estimators each scenario draws one of (uniformly); an empty list
    draws none (the ``[controller]`` table's, or the default).

    Raises
    ------
    ConfigError
        A name that is not an estimator's.
    """

    localization: tuple[str, ...] = ()
    """Pose estimators of :data:`~agvctl.estimation.registry.pose_estimators` (names or references)."""
    wheel_speed: tuple[str, ...] = ()
    """Wheel-speed estimators of :data:`~agvctl.estimation.registry.wheel_speed_estimators`."""

    def __post_init__(self) -> None:
        check_fields(self)
        self.validate(source=type(self).__name__, prefix="")

    def validate(self, *, source: str, prefix: str) -> None:
        for name, registry in (("localization", pose_estimators), ("wheel_speed", wheel_speed_estimators)):
            for i, value in enumerate(getattr(self, name)):
                if not isinstance(value, str) or not (value in registry or is_reference(value)):
                    allowed = ", ".join(map(repr, registry.names()))
                    raise ConfigError(
                        source,
                        f"{join_key(prefix, name)}[{i}]",
                        f"must be one of {allowed} or a reference package.module:Name (got {value!r})",
                    )

    def items(self) -> list[tuple[str, tuple[str, ...]]]:
        """The ``[controller]`` keys drawn, with their choices."""
        return [(name, getattr(self, name)) for name in ("localization", "wheel_speed") if getattr(self, name)]


def nominal_value(vehicle: VehicleParams, key: str) -> float | None:
    """The value of a dotted vehicle key.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle.
    key : str
        The dotted key, e.g. ``"motor.left.stiction_n_m"``.

    Returns
    -------
    float or None
        Its value, in the unit of the key; None if it names no number.

    Examples
    --------
    >>> from agvctl.params import load_vehicle
    >>> nominal_value(load_vehicle(), "wheels.left.radius_m"), nominal_value(load_vehicle(), "wheels.left")
    (0.1, None)
    """
    node: Any = vehicle
    for part in key.split("."):
        if not dataclasses.is_dataclass(node) or part not in {f.name for f in dataclasses.fields(node)}:
            return None
        node = getattr(node, part)
    if isinstance(node, bool) or not isinstance(node, float):
        return None
    return node


def _side_value(values: Mapping[str, float], vehicle: VehicleParams, side: str, what: str) -> float:
    for key in (f"motor.{side}.{what}", f"motor.{what}"):
        if key in values:
            return values[key]
    nominal = nominal_value(vehicle, f"motor.{side}.{what}")
    assert nominal is not None
    return nominal


def keep_stiction_above_coulomb(values: Mapping[str, float], vehicle: VehicleParams) -> dict[str, float]:
    """Plant overrides with stiction at or above Coulomb friction on each side, as a vehicle needs.

    Parameters
    ----------
    values : Mapping of str to float
        The overrides by dotted vehicle key, each in the unit of its key.
    vehicle : VehicleParams
        The nominal vehicle, for the values the overrides leave as they are.

    Returns
    -------
    dict of str to float
        The overrides; where a side's Coulomb friction exceeds its stiction, the two values are exchanged if both
        are overridden, else the side's stiction is raised to the Coulomb friction.
    """
    out = dict(values)
    for side in ("left", "right"):
        coulomb = _side_value(out, vehicle, side, "coulomb_friction_n_m")
        stiction = _side_value(out, vehicle, side, "stiction_n_m")
        if coulomb <= stiction:
            continue
        c_key, s_key = f"motor.{side}.coulomb_friction_n_m", f"motor.{side}.stiction_n_m"
        if c_key in out and s_key in out:
            out[c_key], out[s_key] = out[s_key], out[c_key]
        else:
            out[s_key] = coulomb
    return out
