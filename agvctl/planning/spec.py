"""Path files (``trajectories/*.toml``): the schema, strict loading, and the wheel limits they resolve to.

A path file names a start pose, optional per-wheel limits, how segments join, and a list of segments::

    name = "square-2m"
    start = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }   # optional, default origin
    join = "smooth"      # optional: "smooth" (drive through curvature changes) or "stop" (stop at each)
    [limits]                                             # per wheel; each optional, defaults from the vehicle
    wheel_speed_m_s = 0.8
    wheel_accel_m_s2 = 0.657
    wheel_jerk_m_s3 = 3.0
    drawn_path_tolerance_m = 0.005   # optional: how far the planned path may leave the drawn one (smooth joins)

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
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from agvctl.config import build, check_fields, did_you_mean, document_fields, load_toml, number
from agvctl.errors import ConfigError
from agvctl.feasibility import HeadroomWarning

__all__ = [
    "BODY_LIMIT_KEYS",
    "DRAWN_PATH_TOLERANCE_M",
    "ArcSegment",
    "BodyLimits",
    "HeadroomWarning",
    "LineSegment",
    "PathLimits",
    "PathSpec",
    "Segment",
    "StartPose",
    "TurnSegment",
    "Waypoint",
    "WheelLimits",
    "load_path",
]

SEGMENT_TYPES = ("line", "turn", "arc")

MAX_WAYPOINT_COORDINATE_M = 1e6
"""The largest ``|x_m|``, ``|y_m|`` of a waypoint: a thousand kilometres, beyond a day's drive (the planner's maximum
reference duration) and within the range where the spline fit stays well conditioned."""

MAX_SEGMENTS = 10_000
"""The most segments (or waypoints) of one path: a hundred times the longest hall route, and a bound on the
planning work (each segment is a motion or a join to solve)."""


@document_fields
@dataclass(frozen=True)
class StartPose:
    """The start pose as written in a path file (degrees at the user's edge)."""

    x_m: float = number(default=0.0, doc="x of the point midway between the wheels, m.")
    y_m: float = number(default=0.0, doc="y of that point, m.")
    theta_deg: float = number(default=0.0, doc="The heading, counter-clockwise from the x axis, °.")

    def __post_init__(self) -> None:
        check_fields(self)


BODY_PLAN_SHARE = 0.7
"""The default of ``limits.body_plan_share``: the plan uses 70 % of each limit on the body's motion and leaves the
rest to the feedback, whose corrections (a start off the path, a wheel breaking away from stiction, a plant unlike
the model) add to the plan's accelerations as the payload feels them (design record 0041)."""

MIN_LIMIT = 1e-3
"""The smallest wheel limit or speed cap a path file may set, 1 mm/s (mm/s², mm/s³): slower still, a metre takes
over a quarter of an hour, and the motion-profile solver's times grow past what it resolves."""


DRAWN_PATH_TOLERANCE_M = 0.005
"""The default of ``limits.drawn_path_tolerance_m``: the planned path leaves the drawn one by at most 5 mm, the
tightest tolerance at which no shipped path takes longer (joins within it are found by a scan that also makes them
quicker on random paths; design record 0038), half the default gate's 1 cm at the final pose."""

MIN_DRAWN_PATH_TOLERANCE_M = 1e-4
"""The smallest ``limits.drawn_path_tolerance_m`` a path file may set, 0.1 mm: ten times the chords that stand for
the drawn path's arcs (:data:`~agvctl.planning.drawn.CHORD_ERROR_M`), below what a wheel's odometry resolves over a
path."""


@document_fields
@dataclass(frozen=True)
class BodyLimits:
    """Limits on the body's motion, the axle midpoint's speed U along the path and the yaw rate ω (eqs 39-40), as a
    payload on it feels them: each ``None`` for none, each at least :data:`MIN_LIMIT`. The planner keeps the plan
    within them at every instant, as it keeps the wheels' (:mod:`agvctl.planning.speed`)."""

    linear_speed_m_s: float | None = number(ge=MIN_LIMIT, default=None, doc="The largest ``|U|``, m/s.")
    linear_accel_m_s2: float | None = number(
        ge=MIN_LIMIT, default=None, doc="The largest ``|dU/dt|``, the acceleration along the path, m/s²."
    )
    linear_jerk_m_s3: float | None = number(ge=MIN_LIMIT, default=None, doc="The largest ``|d²U/dt²|``, m/s³.")
    angular_speed_rad_s: float | None = number(ge=MIN_LIMIT, default=None, doc="The largest ``|ω|``, rad/s.")
    angular_accel_rad_s2: float | None = number(ge=MIN_LIMIT, default=None, doc="The largest ``|dω/dt|``, rad/s².")
    lateral_accel_m_s2: float | None = number(
        ge=MIN_LIMIT, default=None, doc="The largest centripetal acceleration ``|U ω|`` of a curve, m/s²."
    )

    def __post_init__(self) -> None:
        check_fields(self)


BODY_LIMIT_KEYS = tuple(f.name for f in dataclasses.fields(BodyLimits))
"""The keys of :class:`BodyLimits`, which a path file's ``[limits]`` takes beside the wheels'."""


@document_fields
@dataclass(frozen=True)
class PathLimits(BodyLimits):
    """Limits as written in a path file: per wheel (``None`` takes the vehicle's value,
    :func:`~agvctl.planning.resolve_limits`; each at least :data:`MIN_LIMIT`), on the body's motion
    (:class:`BodyLimits`, none by default) and how far the planned path may leave the drawn one."""

    wheel_speed_m_s: float | None = number(
        ge=MIN_LIMIT, default=None, doc="The largest ``|speed|`` of either wheel, m/s."
    )
    wheel_accel_m_s2: float | None = number(
        ge=MIN_LIMIT, default=None, doc="The largest ``|acceleration|`` of either wheel, m/s²."
    )
    wheel_jerk_m_s3: float | None = number(
        ge=MIN_LIMIT, default=None, doc="The largest ``|jerk|`` of either wheel, m/s³."
    )
    body_plan_share: float = number(
        gt=0.0,
        le=1.0,
        default=BODY_PLAN_SHARE,
        doc="The share of each limit on the body's motion that the plan uses; the rest is the feedback's, and the "
        "gate judges the whole limit.",
    )
    drawn_path_tolerance_m: float = number(
        ge=MIN_DRAWN_PATH_TOLERANCE_M,
        default=DRAWN_PATH_TOLERANCE_M,
        doc="The largest distance from a point of the planned path to the path the file draws (its lines and "
        "arcs, or the curve through its waypoints), m: the smooth joins are shortened, and driven slower, to keep "
        "within it.",
    )

    def __post_init__(self) -> None:
        check_fields(self)


@document_fields
@dataclass(frozen=True)
class WheelLimits:
    """Resolved per-wheel limits: ``|wheel speed|``, ``|wheel acceleration|`` and ``|wheel jerk|`` of either wheel.

    Raises
    ------
    ConfigError
        ``WheelLimits: <argument>: must be finite and >= 0.001`` (:data:`MIN_LIMIT`).
    """

    wheel_speed_m_s: float
    """The largest ``|speed|`` of either wheel, m/s."""
    wheel_accel_m_s2: float
    """The largest ``|acceleration|`` of either wheel, m/s²."""
    wheel_jerk_m_s3: float
    """The largest ``|jerk|`` of either wheel, m/s³."""
    body: BodyLimits = dataclasses.field(default_factory=BodyLimits)
    """The limits on the body's motion (none by default)."""
    body_plan_share: float = 1.0
    """The share of each of ``body`` that the plan uses (:attr:`planned_body`), in (0, 1]."""

    @property
    def planned_body(self) -> BodyLimits:
        """The limits on the body's motion that the plan keeps: each of ``body`` times ``body_plan_share``."""
        if self.body_plan_share == 1.0:
            return self.body
        share = self.body_plan_share
        return BodyLimits(**{k: None if v is None else v * share for k, v in dataclasses.asdict(self.body).items()})

    def __post_init__(self) -> None:
        if not isinstance(self.body, BodyLimits):
            raise ConfigError("WheelLimits", "body", f"expected BodyLimits (got {self.body!r:.60})")
        share = self.body_plan_share
        if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0.0 < share <= 1.0:
            raise ConfigError("WheelLimits", "body_plan_share", f"must be in (0, 1] (got {share!r})")
        for f in dataclasses.fields(self)[:3]:
            value = getattr(self, f.name)
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not (math.isfinite(value) and value >= MIN_LIMIT)
            ):
                raise ConfigError("WheelLimits", f.name, f"must be finite and >= {MIN_LIMIT:g} (got {value!r})")


def _nonzero(value: float, source: str, prefix: str, key: str) -> None:
    if value == 0:
        raise ConfigError(source, f"{prefix}.{key}" if prefix else key, "must not be zero")


_SPEED_CAP = "A cap on the path speed U over the segment (None: the wheel limits alone), m/s."


@document_fields
@dataclass(frozen=True, kw_only=True)
class LineSegment:
    """A straight line along the current heading."""

    length_m: float = number(doc="Its length, not zero; negative drives in reverse, m.")
    speed_m_s: float | None = number(ge=MIN_LIMIT, default=None, doc=_SPEED_CAP)
    type: Literal["line"] = "line"
    """The segment's kind, as the file's ``type`` key names it."""

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.length_m, source, prefix, "length_m")


@document_fields
@dataclass(frozen=True, kw_only=True)
class TurnSegment:
    """A spin in place about the point midway between the wheels."""

    angle_deg: float = number(doc="The angle turned, not zero; positive is counter-clockwise, °.")
    speed_m_s: float | None = number(
        ge=MIN_LIMIT, default=None, doc="A cap on the wheel speed ω b/2 (None: the wheel limits alone), m/s."
    )
    type: Literal["turn"] = "turn"
    """The segment's kind, as the file's ``type`` key names it."""

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.angle_deg, source, prefix, "angle_deg")


@document_fields
@dataclass(frozen=True, kw_only=True)
class ArcSegment:
    """A circular arc, driven forwards."""

    radius_m: float = number(
        ge=1e-3, doc='Its radius, at least 1 mm: a smaller one is a turn in place (``type = "turn"``), m.'
    )
    angle_deg: float = number(doc="The angle turned along it, not zero; positive is a left turn, °.")
    speed_m_s: float | None = number(ge=MIN_LIMIT, default=None, doc=_SPEED_CAP)
    type: Literal["arc"] = "arc"
    """The segment's kind, as the file's ``type`` key names it."""

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self, *, source: str, prefix: str) -> None:
        _nonzero(self.angle_deg, source, prefix, "angle_deg")


@document_fields
@dataclass(frozen=True, kw_only=True)
class Waypoint:
    """A point the path passes through."""

    x_m: float = number(ge=-MAX_WAYPOINT_COORDINATE_M, le=MAX_WAYPOINT_COORDINATE_M, doc="Its x, m.")
    y_m: float = number(ge=-MAX_WAYPOINT_COORDINATE_M, le=MAX_WAYPOINT_COORDINATE_M, doc="Its y, m.")
    theta_deg: float | None = number(
        default=None, doc="The heading there (None: chosen for a smooth path), counter-clockwise from x, °."
    )

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


@document_fields
@dataclass(frozen=True)
class PathSpec:
    """A path: its segments (or waypoints), start pose, the limits it sets, how segments join, and where it came
    from. :func:`load_path` reads one from a file; :func:`~agvctl.planning.plan` plans its reference.

    Raises
    ------
    ConfigError
        Naming ``source``: both segments and waypoints, neither, more than :data:`MAX_SEGMENTS`, or waypoints
        that are fewer than two or repeat a point.

    Examples
    --------
    >>> from agvctl.planning import plan
    >>> square = PathSpec(segments=[LineSegment(length_m=2.0), TurnSegment(angle_deg=90)] * 4, name="square")
    >>> reference = plan(square)  # on the default vehicle
    >>> print(f"{reference.duration_s:.1f} s")
    27.5 s
    """

    segments: tuple[Segment, ...] = ()
    """The segments, driven in order (none for a waypoint path)."""
    name: str = "path"
    """The path's name, for reports and output folders."""
    start: StartPose = dataclasses.field(default_factory=StartPose)
    """The pose the first segment starts from (a waypoint path starts at its first waypoint)."""
    limits: PathLimits = dataclasses.field(default_factory=PathLimits)
    """The wheel limits the path sets (those it leaves to None default to the vehicle's)."""
    source: str = "<path>"
    """Where it came from (its file), as errors name it."""
    waypoints: tuple[Waypoint, ...] = ()
    """The points it passes through, instead of segments."""
    join: Literal["smooth", "stop"] = "smooth"
    """How consecutive segments join: ``"smooth"`` drives through the curvature changes, ``"stop"`` stops at
    each."""

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
    path : str or Path
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
