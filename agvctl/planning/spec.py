"""Path files (``trajectories/*.toml``): the schema, strict loading, and the wheel limits they resolve to.

A path file names a start pose, optional per-wheel limits, how segments join, and a list of segments::

    name = "square-2m"
    start = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }   # optional, default origin
    join = "smooth"      # optional: "smooth" (drive through curvature changes) or "stop" (stop at each)
    [limits]                                             # per wheel; each optional, defaults from the vehicle
    wheel_speed_m_s = 0.8
    wheel_accel_m_s2 = 0.657
    wheel_jerk_m_s3 = 3.0

    [[segments]]
    type = "line"        # straight, length_m (negative = reverse)
    length_m = 2.0
    [[segments]]
    type = "turn"        # spin in place, angle_deg (positive = counter-clockwise)
    angle_deg = 90
    [[segments]]
    type = "arc"         # radius_m >= 0.001 (1 mm), angle_deg signed (positive = left turn)
    radius_m = 1.0
    angle_deg = 180

or, instead of segments, points to pass through (the heading is optional; the start pose is the first
waypoint, heading from ``theta_deg`` or chosen for a smooth path)::

    [[waypoints]]
    x_m = 0.0
    y_m = 0.0
    theta_deg = 0.0
    [[waypoints]]
    x_m = 2.0
    y_m = 1.0

Any segment may carry ``speed_m_s``: a cap on the path speed U of a line or an arc, and on the wheel speed
(ω b/2) of a turn. Every problem raises a one-line :class:`~agvctl.errors.ConfigError` such as
``trajectories/x.toml: segments[2].radius_m: must be >= 0.001 (got 0)``.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from agvctl.config import build, check_fields, did_you_mean, load_toml, number
from agvctl.errors import ConfigError
from agvctl.feasibility import (
    CURRENT_HEADROOM,
    MIN_HEADROOM,
    VOLTAGE_HEADROOM,
    HeadroomWarning,
    actuator_headroom,
    feasible_wheel_limits,
    no_default_limit_reasons,
)
from agvctl.params import VehicleParams

__all__ = [
    "ArcSegment",
    "HeadroomWarning",
    "LineSegment",
    "PathLimits",
    "PathSpec",
    "PhysicalLimitWarning",
    "Segment",
    "StartPose",
    "TurnSegment",
    "Waypoint",
    "WheelLimits",
    "default_jerk_limit_m_s3",
    "load_path",
    "resolve_limits",
]

SEGMENT_TYPES = ("line", "turn", "arc")

JERK_RAMP_SAMPLES = 5
"""The default jerk limit lets the acceleration ramp from 0 to a_lim over this many control periods."""

MAX_WAYPOINT_COORDINATE_M = 1e6
"""The largest |x_m|, |y_m| of a waypoint: a thousand kilometres, beyond a day's drive (the planner's maximum
reference duration) and within the range where the spline fit stays well conditioned."""

MAX_SEGMENTS = 10_000
"""The most segments (or waypoints) of one path: a hundred times the longest hall route, and a bound on the
planning work (each segment is a motion or a join to solve)."""


class PhysicalLimitWarning(UserWarning):
    """A limit above what the vehicle can physically do was accepted because ``force=True``."""


@dataclass(frozen=True)
class StartPose:
    """The start pose as written in a path file (degrees at the user's edge)."""

    x_m: float = number(default=0.0)
    y_m: float = number(default=0.0)
    theta_deg: float = number(default=0.0)

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class PathLimits:
    """Per-wheel limits as written in a path file; ``None`` takes the vehicle's value."""

    wheel_speed_m_s: float | None = number(gt=0, default=None)
    wheel_accel_m_s2: float | None = number(gt=0, default=None)
    wheel_jerk_m_s3: float | None = number(gt=0, default=None)

    def __post_init__(self) -> None:
        check_fields(self)


@dataclass(frozen=True)
class WheelLimits:
    """Resolved per-wheel limits: |wheel speed|, |wheel acceleration| and |wheel jerk| of either wheel.

    Raises
    ------
    ConfigError
        ``WheelLimits: <argument>: must be finite and > 0``.
    """

    wheel_speed_m_s: float
    wheel_accel_m_s2: float
    wheel_jerk_m_s3: float

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value > 0)
            ):
                raise ConfigError("WheelLimits", f.name, f"must be finite and > 0 (got {value!r})")


def _nonzero(value: float, source: str, prefix: str, key: str) -> None:
    if value == 0:
        raise ConfigError(source, f"{prefix}.{key}" if prefix else key, "must not be zero")


@dataclass(frozen=True, kw_only=True)
class LineSegment:
    """A straight line of ``length_m`` along the current heading; negative drives in reverse."""

    length_m: float = number()
    speed_m_s: float | None = number(gt=0, default=None)
    type: Literal["line"] = "line"

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.length_m, source, prefix, "length_m")


@dataclass(frozen=True, kw_only=True)
class TurnSegment:
    """A spin in place by ``angle_deg`` (positive = counter-clockwise); ``speed_m_s`` caps the wheel speed."""

    angle_deg: float = number()
    speed_m_s: float | None = number(gt=0, default=None)
    type: Literal["turn"] = "turn"

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.angle_deg, source, prefix, "angle_deg")


@dataclass(frozen=True, kw_only=True)
class ArcSegment:
    """A circular arc of ``radius_m`` ≥ 1 mm through ``angle_deg`` (positive = left turn), driven forwards."""

    radius_m: float = number(ge=1e-3, doc='at least 1 mm: a smaller radius is a turn in place (type = "turn")')
    angle_deg: float = number()
    speed_m_s: float | None = number(gt=0, default=None)
    type: Literal["arc"] = "arc"

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.angle_deg, source, prefix, "angle_deg")


@dataclass(frozen=True, kw_only=True)
class Waypoint:
    """A point the path passes through; ``theta_deg`` (optional) is the heading there."""

    x_m: float = number(ge=-MAX_WAYPOINT_COORDINATE_M, le=MAX_WAYPOINT_COORDINATE_M)
    y_m: float = number(ge=-MAX_WAYPOINT_COORDINATE_M, le=MAX_WAYPOINT_COORDINATE_M)
    theta_deg: float | None = number(default=None)

    def __post_init__(self) -> None:
        check_fields(self)


Segment = LineSegment | TurnSegment | ArcSegment
_SEGMENT_CLASSES: dict[str, type[Any]] = {"line": LineSegment, "turn": TurnSegment, "arc": ArcSegment}


@dataclass(frozen=True)
class _AnySegment:
    """Loader shim: dispatches one ``[[segments]]`` table on its ``type`` key."""

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> Segment:
        if "type" not in data:
            raise ConfigError(source, f"{prefix}.type", f"missing key (one of {', '.join(SEGMENT_TYPES)})")
        kind = data["type"]
        if not isinstance(kind, str) or kind not in _SEGMENT_CLASSES:
            hint = did_you_mean(str(kind), SEGMENT_TYPES, []) if isinstance(kind, str) else ""
            expected = ", ".join(SEGMENT_TYPES)
            problem = f"unknown segment type {kind!r} (expected one of {expected})"
            hint = hint.replace("did you mean ", "did you mean type = ")
            raise ConfigError(source, f"{prefix}.type", problem + hint)
        segment: Segment = build(_SEGMENT_CLASSES[kind], data, source=source, prefix=prefix)
        return segment


@dataclass(frozen=True)
class _PathFile:
    segments: tuple[_AnySegment, ...] = ()
    waypoints: tuple[Waypoint, ...] = ()
    join: Literal["smooth", "stop"] = "smooth"
    name: str | None = None
    start: StartPose = dataclasses.field(default_factory=StartPose)
    limits: PathLimits = dataclasses.field(default_factory=PathLimits)


@dataclass(frozen=True)
class PathSpec:
    """A path: its segments (or waypoints), start pose, the limits the file sets, how segments join
    (``"smooth"``: drive through curvature changes; ``"stop"``: stop at each), and where it came from."""

    segments: tuple[Segment, ...] = ()
    name: str = "path"
    start: StartPose = dataclasses.field(default_factory=StartPose)
    limits: PathLimits = dataclasses.field(default_factory=PathLimits)
    source: str = "<path>"
    waypoints: tuple[Waypoint, ...] = ()
    join: Literal["smooth", "stop"] = "smooth"

    def __post_init__(self) -> None:
        check_fields(self)
        object.__setattr__(self, "segments", tuple(self.segments))
        object.__setattr__(self, "waypoints", tuple(self.waypoints))
        for key in ("segments", "waypoints"):
            if len(getattr(self, key)) > MAX_SEGMENTS:
                raise ConfigError(self.source, key, f"at most {MAX_SEGMENTS} (got {len(getattr(self, key))})")
        if self.segments and self.waypoints:
            raise ConfigError(self.source, "waypoints", "give either [[segments]] or [[waypoints]], not both")
        if self.waypoints:
            check_waypoints(self.waypoints, self.source)
        elif not self.segments:
            raise ConfigError(self.source, "segments", "at least one segment is required")


def check_waypoints(waypoints: Sequence[Waypoint], source: str) -> None:
    """At least two waypoints, no two consecutive ones on the same point; else a ConfigError naming ``source``."""
    if len(waypoints) < 2:
        raise ConfigError(source, "waypoints", f"at least 2 waypoints are required (got {len(waypoints)})")
    for i in range(1, len(waypoints)):
        a, b = waypoints[i - 1], waypoints[i]
        if math.hypot(b.x_m - a.x_m, b.y_m - a.y_m) < 1e-6:
            raise ConfigError(
                source,
                f"waypoints[{i}]",
                f"same point as waypoints[{i - 1}] ({b.x_m:g}, {b.y_m:g}); remove one of them",
            )


def load_path(path: str | Path) -> PathSpec:
    """Read and check a path file.

    Parameters
    ----------
    path
        The path file (TOML): segments or waypoints, and optional limits.

    Returns
    -------
    PathSpec
        The validated path, for :func:`~agvctl.planning.plan`.

    Raises
    ------
    ConfigError
        A one-line message naming the file, segment and key.
    """
    source = str(path)
    raw = load_toml(path)
    for key in ("segments", "waypoints"):  # before any of them is built
        if isinstance(raw.get(key), list) and len(raw[key]) > MAX_SEGMENTS:
            raise ConfigError(source, key, f"at most {MAX_SEGMENTS} (got {len(raw[key])})")
    data = build(_PathFile, raw, source=source)  # unknown keys are reported first
    if "segments" not in raw and "waypoints" not in raw:
        raise ConfigError(source, "segments", "missing key (add [[segments]] or [[waypoints]] tables)")
    if "waypoints" in raw:
        if "start" in raw:
            raise ConfigError(source, "start", "a waypoint path starts at its first waypoint; remove start")
        if "segments" not in raw:
            check_waypoints(data.waypoints, source)
    segments: Sequence[Any] = data.segments
    return PathSpec(
        segments=tuple(segments),
        waypoints=data.waypoints,
        join=data.join,
        name=data.name if data.name is not None else Path(path).stem,
        start=data.start,
        limits=data.limits,
        source=source,
    )


def default_jerk_limit_m_s3(vehicle: VehicleParams) -> float:
    """Default wheel jerk limit: a_lim reached in :data:`JERK_RAMP_SAMPLES` control periods (a planning
    convention, not a physical limit: 0.657 / (5 · 0.04 s) = 3.29 m/s³ for the default vehicle)."""
    return vehicle.derived.accel_limit_m_s2 / (JERK_RAMP_SAMPLES * vehicle.control.sample_period_s)


def resolve_limits(spec: PathSpec, vehicle: VehicleParams, *, force: bool = False) -> WheelLimits:
    """The wheel limits of ``spec`` with the vehicle's defaults filled in, checked against the vehicle.

    Defaults leave headroom for feedback (:func:`~agvctl.actuator.feasible_wheel_limits`: the plan uses at most
    80 % of I_max and of the full-scale voltage) and :func:`default_jerk_limit_m_s3`. A wheel speed limit (or a
    segment's ``speed_m_s``) above the no-load top speed, or an acceleration limit above a_lim (eq 5), raises a
    :class:`ConfigError` naming both values, unless ``force`` is true: then a :class:`PhysicalLimitWarning` is
    issued instead. Explicit limits the actuator can deliver but with less than
    :data:`~agvctl.actuator.MIN_HEADROOM` of current or voltage left get a :class:`~agvctl.actuator.HeadroomWarning`.
    A limit left to its default when the vehicle has none (it cannot move, or not with the headroom) raises a
    :class:`ConfigError` naming the vehicle keys why, ``force`` or not.
    """
    top, a_lim = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2
    lim = spec.limits
    checks: list[tuple[str, float | None, float, str, str]] = [
        ("limits.wheel_speed_m_s", lim.wheel_speed_m_s, top, "m/s", "no-load top speed"),
        ("limits.wheel_accel_m_s2", lim.wheel_accel_m_s2, a_lim, "m/s²", "acceleration limit a_lim (eq 5)"),
    ]
    checks += [
        (f"segments[{i}].speed_m_s", seg.speed_m_s, top, "m/s", "no-load top speed")
        for i, seg in enumerate(spec.segments)
    ]
    over = set()
    for key, value, physical, unit, what in checks:
        if value is not None and value > physical:
            over.add(key)
            problem = f"{value:g} {unit} is above the vehicle's {what} of {physical:.4g} {unit}"
            if not force:
                raise ConfigError(spec.source, key, problem + " (use --force to plan anyway)")
            warnings.warn(
                f"{spec.source}: {key}: {problem}; planning anyway (--force)", PhysicalLimitWarning, stacklevel=2
            )
    _warn_headroom(spec, vehicle, skip=over)
    default = feasible_wheel_limits(vehicle)
    for key, why in no_default_limit_reasons(vehicle, default).items():
        if getattr(lim, key) is None:
            raise ConfigError(spec.source, f"limits.{key}", f"no default for this vehicle: {why}")
    jerk = lim.wheel_jerk_m_s3 if lim.wheel_jerk_m_s3 is not None else default_jerk_limit_m_s3(vehicle)
    return WheelLimits(
        wheel_speed_m_s=lim.wheel_speed_m_s if lim.wheel_speed_m_s is not None else default.wheel_speed_m_s,
        wheel_accel_m_s2=lim.wheel_accel_m_s2 if lim.wheel_accel_m_s2 is not None else default.wheel_accel_m_s2,
        wheel_jerk_m_s3=jerk,
    )


def _warn_headroom(spec: PathSpec, vehicle: VehicleParams, skip: set[str]) -> None:
    """A :class:`HeadroomWarning` for each explicit limit that leaves less than MIN_HEADROOM for feedback (but
    those in ``skip``, already above the physical limit)."""
    lim = spec.limits
    if lim.wheel_accel_m_s2 is not None and "limits.wheel_accel_m_s2" not in skip:
        a = lim.wheel_accel_m_s2
        current, _ = actuator_headroom(vehicle, [[1e-9, 1e-9]], [[a, a]])
        if current < MIN_HEADROOM:
            warnings.warn(
                f"{spec.source}: limits.wheel_accel_m_s2: {a:g} m/s² leaves {max(current, 0):.0%} of the current "
                f"limit for feedback (at least {MIN_HEADROOM:.0%} advised; the default "
                f"{feasible_wheel_limits(vehicle).wheel_accel_m_s2:.3g} m/s² leaves {CURRENT_HEADROOM:.0%})",
                HeadroomWarning,
                stacklevel=3,
            )
    speeds = [("limits.wheel_speed_m_s", lim.wheel_speed_m_s)]
    speeds += [(f"segments[{i}].speed_m_s", seg.speed_m_s) for i, seg in enumerate(spec.segments)]
    for key, v in speeds:
        if v is None or key in skip:
            continue
        _, voltage = actuator_headroom(vehicle, [[v, v]], [[0.0, 0.0]])
        if voltage < MIN_HEADROOM:
            warnings.warn(
                f"{spec.source}: {key}: {v:g} m/s leaves {max(voltage, 0):.0%} of the full-scale voltage for "
                f"feedback at cruise (at least {MIN_HEADROOM:.0%} advised; the default "
                f"{feasible_wheel_limits(vehicle).wheel_speed_m_s:.3g} m/s leaves {VOLTAGE_HEADROOM:.0%})",
                HeadroomWarning,
                stacklevel=3,
            )
