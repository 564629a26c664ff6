"""Plane geometry of the path primitives: poses, constant-curvature motion, and where a path ends.

A pose is (x, y, θ) of the point of rotation (mid-way between the driving wheels), θ measured
counter-clockwise from the x axis, in radians and never wrapped (a full circle ends at θ0 + 2π).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.config import check_fields, document_fields
from agvctl.planning.spec import ArcSegment, LineSegment, PathSpec, Segment, StartPose, TurnSegment

__all__ = ["Pose", "advance", "path_end_pose", "segment_distances", "segment_end_pose", "segment_kinematics"]


@document_fields
@dataclass(frozen=True)
class Pose:
    """Position of the point of rotation and heading (continuous, not wrapped).

    Raises
    ------
    ConfigError
        ``Pose: <argument>: must be finite`` for a NaN or infinite coordinate.
    """

    x_m: float
    """x of the point of rotation, m."""
    y_m: float
    """y of the point of rotation, m."""
    theta_rad: float
    """The heading, counter-clockwise from the x axis, never wrapped, rad."""

    def __post_init__(self) -> None:
        check_fields(self)

    @classmethod
    def from_start(cls, start: StartPose) -> Pose:
        """The pose a path file's ``start`` table describes."""
        return cls(start.x_m, start.y_m, math.radians(start.theta_deg))


def _sinc(z: float) -> float:
    return 1.0 if z == 0 else math.sin(z) / z


def advance(pose: Pose, *, displacement_m: float, curvature_1_m: float) -> Pose:
    """The pose after moving along a path of constant curvature.

    The chord of a circular arc of length σ has length σ·sinc(κσ/2) and points along θ0 + κσ/2; with κ = 0
    this is the straight line.

    Parameters
    ----------
    pose : Pose
        The pose it starts from.
    displacement_m : float
        The signed distance moved along the path (negative: in reverse), m.
    curvature_1_m : float
        The path's curvature κ (positive: turning left going forwards), 1/m.

    Returns
    -------
    Pose
        The pose at the end.

    Examples
    --------
    >>> import math
    >>> end = advance(Pose(0.0, 0.0, 0.0), displacement_m=math.pi / 2, curvature_1_m=1.0)  # a quarter circle
    >>> round(end.x_m, 9), round(end.y_m, 9), round(end.theta_rad, 9)
    (1.0, 1.0, 1.570796327)
    """
    half = 0.5 * curvature_1_m * displacement_m
    chord = displacement_m * _sinc(half)
    return Pose(
        pose.x_m + chord * math.cos(pose.theta_rad + half),
        pose.y_m + chord * math.sin(pose.theta_rad + half),
        pose.theta_rad + 2.0 * half,
    )


def segment_kinematics(segment: Segment) -> tuple[str, float, float, int]:
    """How a segment moves the vehicle, in the terms the planner works with.

    Parameters
    ----------
    segment : LineSegment, TurnSegment or ArcSegment
        The segment.

    Returns
    -------
    kind : str
        ``"path"`` (the coordinate is the distance travelled, m) or ``"spin"`` (the coordinate is the heading
        change, rad).
    distance : float
        The coordinate's total change, > 0 (m or rad).
    curvature_1_m : float
        ±1/radius for an arc (positive: left), 0 otherwise, 1/m.
    direction : int
        ±1: −1 in reverse for a negative line, clockwise for a negative turn.
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
    """Where a segment ends.

    Parameters
    ----------
    pose : Pose
        Where it starts.
    segment : LineSegment, TurnSegment or ArcSegment
        The segment.

    Returns
    -------
    Pose
        Its end.
    """
    kind, distance, curvature, direction = segment_kinematics(segment)
    if kind == "spin":
        return Pose(pose.x_m, pose.y_m, pose.theta_rad + direction * distance)
    return advance(pose, displacement_m=direction * distance, curvature_1_m=curvature)


def path_end_pose(spec: PathSpec) -> Pose:
    """The geometric end of a path: its segments composed from the start pose.

    Parameters
    ----------
    spec : PathSpec
        The path (of segments).

    Returns
    -------
    Pose
        Where its last segment ends.
    """
    pose = Pose.from_start(spec.start)
    for segment in spec.segments:
        pose = segment_end_pose(pose, segment)
    return pose


def segment_distances(
    px: NDArray[np.float64],
    py: NDArray[np.float64],
    x_m: NDArray[np.float64],
    y_m: NDArray[np.float64],
    segment: NDArray[np.int64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The exact projection of points onto segments of a polyline: the distance, and where along the segment.

    Parameters
    ----------
    px, py : ndarray
        The points, shape (n,), m.
    x_m, y_m : ndarray
        The polyline's vertices, m.
    segment : ndarray of int
        For each point (row), the segments to project it onto, shape (n, m): segment i runs from vertex i to i + 1.

    Returns
    -------
    tuple of ndarray
        The distance to each segment's nearest point (m) and that point's parameter u ∈ [0, 1] from the segment's
        start, each of ``segment``'s shape. The distance is the square root of the sum of squares, not
        ``np.hypot``, whose guard against overflow costs eight times as much and no path needs.

    Examples
    --------
    >>> d, u = segment_distances(np.array([1.0]), np.array([1.0]), np.array([0.0, 2.0]), np.array([0.0, 0.0]),
    ...                          np.array([[0]]))
    >>> float(d[0, 0]), float(u[0, 0])
    (1.0, 0.5)
    """
    ax, ay = x_m[segment], y_m[segment]
    bx, by = x_m[segment + 1] - ax, y_m[segment + 1] - ay
    rx, ry = px[:, None] - ax, py[:, None] - ay
    u = np.clip((rx * bx + ry * by) / np.maximum(bx * bx + by * by, 1e-300), 0.0, 1.0)
    dx, dy = rx - u * bx, ry - u * by
    return np.sqrt(dx * dx + dy * dy), u
