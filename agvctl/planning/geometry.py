"""Plane geometry of the path primitives: poses, constant-curvature motion, and where a path ends.

A pose is (x, y, θ) of the point of rotation (mid-way between the driving wheels), θ measured
counter-clockwise from the x axis, in radians and never wrapped (a full circle ends at θ0 + 2π).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agvctl.config import check_fields
from agvctl.planning.spec import ArcSegment, LineSegment, PathSpec, Segment, StartPose, TurnSegment

__all__ = ["Pose", "advance", "path_end_pose", "segment_end_pose", "segment_kinematics"]


@dataclass(frozen=True)
class Pose:
    """Position of the point of rotation and heading (continuous, not wrapped).

    Raises
    ------
    ConfigError
        ``Pose: <argument>: must be finite`` for a NaN or infinite coordinate.
    """

    x_m: float
    y_m: float
    theta_rad: float

    def __post_init__(self) -> None:
        check_fields(self)

    @classmethod
    def from_start(cls, start: StartPose) -> Pose:
        """The pose a path file's ``start`` table describes."""
        return cls(start.x_m, start.y_m, math.radians(start.theta_deg))


def _sinc(z: float) -> float:
    return 1.0 if z == 0 else math.sin(z) / z


def advance(pose: Pose, *, displacement_m: float, curvature_1_m: float) -> Pose:
    """The pose after moving ``displacement_m`` (signed) along a path of constant curvature (1/m, + = left).

    The chord of a circular arc of length σ has length σ·sinc(κσ/2) and points along θ0 + κσ/2; with κ = 0
    this is the straight line.
    """
    half = 0.5 * curvature_1_m * displacement_m
    chord = displacement_m * _sinc(half)
    return Pose(
        pose.x_m + chord * math.cos(pose.theta_rad + half),
        pose.y_m + chord * math.sin(pose.theta_rad + half),
        pose.theta_rad + 2.0 * half,
    )


def segment_kinematics(segment: Segment) -> tuple[str, float, float, int]:
    """``(kind, distance, curvature_1_m, direction)`` of a segment.

    ``kind`` is ``"path"`` (the coordinate is the distance travelled, m) or ``"spin"`` (the coordinate is the
    heading change, rad); ``distance`` > 0 is the coordinate's total change; ``direction`` is ±1
    (reverse for a negative line, clockwise for a negative turn). For an arc, the curvature is ±1/radius
    (+ = left).
    """
    if isinstance(segment, LineSegment):
        return "path", abs(segment.length_m), 0.0, 1 if segment.length_m > 0 else -1
    if isinstance(segment, ArcSegment):
        angle = math.radians(segment.angle_deg)
        return "path", abs(angle) * segment.radius_m, math.copysign(1.0 / segment.radius_m, angle), 1
    if isinstance(segment, TurnSegment):
        angle = math.radians(segment.angle_deg)
        return "spin", abs(angle), 0.0, 1 if angle > 0 else -1
    raise TypeError(f"not a segment: {segment!r}")


def segment_end_pose(pose: Pose, segment: Segment) -> Pose:
    """Where ``segment`` ends when it starts at ``pose``."""
    kind, distance, curvature, direction = segment_kinematics(segment)
    if kind == "spin":
        return Pose(pose.x_m, pose.y_m, pose.theta_rad + direction * distance)
    return advance(pose, displacement_m=direction * distance, curvature_1_m=curvature)


def path_end_pose(spec: PathSpec) -> Pose:
    """The geometric end of a path: its segments composed from the start pose."""
    pose = Pose.from_start(spec.start)
    for segment in spec.segments:
        pose = segment_end_pose(pose, segment)
    return pose
