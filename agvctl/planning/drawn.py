"""The drawn path: the geometry a path file writes, before the planner smooths it, and distances to it.

For a path of segments it is the chain of lines and arcs from the start pose (a turn in place is a point of it,
where the heading changes); for a waypoint path it is the quintic spline through the waypoints that the file
defines (:mod:`agvctl.planning.waypoints`), not the polyline between them: the file asks for a smooth path
through the points, with the headings chosen where none is given, and a polyline's corners can only be driven by
stopping and turning in place, which is what segments with turns are for (design record 0038).

The planner leaves the drawn path only inside its smooth joins (and, for a waypoint path, by the interpolation
of the spline's curvature, micrometres); ``Reference.drawn_path_deviation_m`` is the largest distance from a
point of the planned path to the drawn one, kept within the path's ``limits.drawn_path_tolerance_m``.

A :class:`DrawnPath` stands for the geometry as a polyline whose vertices are at most :data:`SPACING_M` apart
and within :data:`CHORD_ERROR_M` of every arc (a line's chords are exact); distances to it are exact projections
onto the segments next to the nearest vertices (a k-d tree).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from agvctl.planning.geometry import Pose, advance, segment_distances, segment_end_pose, segment_kinematics
from agvctl.planning.spec import Segment

__all__ = ["CHORD_ERROR_M", "SPACING_M", "DrawnPath", "arc_points", "piece_distance_m"]

FloatArray = NDArray[np.float64]

CHORD_ERROR_M = 1e-5
"""The largest distance between an arc of the drawn path and the chords that stand for it, m: a tenth of the
finest tolerance a path file may set."""

SPACING_M = 0.01
"""The largest distance between neighbouring vertices of the polyline (unless the path is so long that
:data:`MAX_VERTICES` binds), m: the nearest point of the path is on a segment next to one of the vertices nearest
a point."""

MAX_VERTICES = 2_000_000
"""The most vertices of one drawn path's polyline (tens of megabytes); a longer path's vertices are spread
further apart than :data:`SPACING_M`."""

_NEIGHBOURS = 8


def arc_points(pose: Pose, displacement_m: float, curvature_1_m: float, count: int) -> tuple[FloatArray, FloatArray]:
    """``count`` + 1 points evenly spaced along a line or an arc, its two ends included (exact: the chord rule).

    Parameters
    ----------
    pose : Pose
        Where it starts.
    displacement_m : float
        The signed distance along it (negative: driven in reverse), m.
    curvature_1_m : float
        Its curvature κ, 1/m.
    count : int
        The number of chords, ≥ 1.

    Returns
    -------
    tuple of ndarray
        x and y of the points, m.
    """
    sigma = np.linspace(0.0, displacement_m, count + 1)
    half = 0.5 * curvature_1_m * sigma
    chord = sigma * np.sinc(half / np.pi)
    return pose.x_m + chord * np.cos(pose.theta_rad + half), pose.y_m + chord * np.sin(pose.theta_rad + half)


def chords_for(length_m: float, curvature_1_m: float, spacing_m: float = SPACING_M) -> int:
    """How many chords stand for a line or an arc: at most ``spacing_m`` long, and within :data:`CHORD_ERROR_M` of
    an arc (a chord h of a circle of radius ρ is within h²/(8ρ) of it)."""
    step = spacing_m
    if curvature_1_m != 0.0:
        step = min(step, math.sqrt(8.0 * CHORD_ERROR_M / abs(curvature_1_m)))
    return max(1, math.ceil(abs(length_m) / step))


def piece_distance_m(px: FloatArray, py: FloatArray, pose: Pose, length_m: float, curvature_1_m: float) -> FloatArray:
    """The exact distance from each point to a line or an arc driven forwards.

    Parameters
    ----------
    px, py : ndarray
        The points, m.
    pose : Pose
        Where the line or arc starts, and its heading there.
    length_m : float
        Its length, > 0, m.
    curvature_1_m : float
        Its curvature κ (positive: turning left), 1/m.

    Returns
    -------
    ndarray
        The distance of each point, m.
    """
    c, s = math.cos(pose.theta_rad), math.sin(pose.theta_rad)
    rx, ry = px - pose.x_m, py - pose.y_m
    if curvature_1_m == 0.0:
        u = np.clip(rx * c + ry * s, 0.0, length_m)
        return np.asarray(np.hypot(rx - u * c, ry - u * s), dtype=np.float64)
    radius = 1.0 / abs(curvature_1_m)
    side = math.copysign(1.0, curvature_1_m)
    cx, cy = -side * s * radius, side * c * radius  # the centre, from the start
    # the angle swept from the start about the centre, in the direction of travel, in [0, 2π)
    swept = side * (np.arctan2(ry - cy, rx - cx) - math.atan2(-cy, -cx))
    swept = np.mod(swept, 2.0 * math.pi)
    on_arc = swept <= abs(curvature_1_m) * length_m
    to_circle = np.abs(np.hypot(rx - cx, ry - cy) - radius)
    end = advance(Pose(0.0, 0.0, pose.theta_rad), displacement_m=length_m, curvature_1_m=curvature_1_m)
    to_ends = np.minimum(np.hypot(rx, ry), np.hypot(rx - end.x_m, ry - end.y_m))
    return np.asarray(np.where(on_arc, to_circle, to_ends), dtype=np.float64)


class DrawnPath:
    """The path a file draws, as a polyline (see the module notes). Immutable; a path of segments builds it with
    :meth:`of_segments`, a waypoint path from its spline's points.

    Parameters
    ----------
    x_m, y_m : array_like
        The polyline's vertices, at least one, m.
    """

    def __init__(self, x_m: ArrayLike, y_m: ArrayLike) -> None:
        x = np.atleast_1d(np.asarray(x_m, dtype=np.float64)).ravel()
        y = np.atleast_1d(np.asarray(y_m, dtype=np.float64)).ravel()
        if len(x) == 0 or len(x) != len(y) or not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ValueError("DrawnPath: as many finite x as y, at least one, are required")
        x.flags.writeable = False
        y.flags.writeable = False
        self.x_m: FloatArray = x
        """x of each vertex, m."""
        self.y_m: FloatArray = y
        """y of each vertex, m."""

    @classmethod
    def of_segments(cls, segments: Sequence[Segment], start: Pose) -> DrawnPath:
        """The lines and arcs of a path of segments, from its start pose (a turn in place adds no vertex).

        Parameters
        ----------
        segments : sequence of LineSegment, TurnSegment or ArcSegment
            The segments, in order.
        start : Pose
            Where the first starts.

        Returns
        -------
        DrawnPath
            Their geometry.
        """
        total = sum(segment_kinematics(s)[1] for s in segments if segment_kinematics(s)[0] == "path")
        spacing = max(SPACING_M, total / MAX_VERTICES)
        xs, ys = [np.array([start.x_m])], [np.array([start.y_m])]
        pose = start
        for segment in segments:
            kind, distance, curvature, direction = segment_kinematics(segment)
            if kind == "path":
                x, y = arc_points(pose, direction * distance, curvature, chords_for(distance, curvature, spacing))
                xs.append(x[1:])
                ys.append(y[1:])
            pose = segment_end_pose(pose, segment)
        return cls(np.concatenate(xs), np.concatenate(ys))

    def __len__(self) -> int:
        return len(self.x_m)

    @functools.cached_property
    def _tree(self) -> cKDTree:
        return cKDTree(np.column_stack([self.x_m, self.y_m]), balanced_tree=False, compact_nodes=False)

    def distance_m(self, x_m: ArrayLike, y_m: ArrayLike) -> FloatArray:
        """The distance from each point to the drawn path: the exact projection onto the segments next to its
        nearest vertices.

        Parameters
        ----------
        x_m, y_m : array_like
            The points (any shape, flattened), m.

        Returns
        -------
        ndarray
            The distance of each point, m (NaN for a point that is not finite).
        """
        px = np.atleast_1d(np.asarray(x_m, dtype=np.float64)).ravel()
        py = np.atleast_1d(np.asarray(y_m, dtype=np.float64)).ravel()
        out = np.full(len(px), np.nan)
        ok = np.isfinite(px) & np.isfinite(py)
        if not np.any(ok) or len(px) != len(py):
            return out
        if len(self) == 1:
            out[ok] = np.hypot(px[ok] - self.x_m[0], py[ok] - self.y_m[0])
            return out
        k = min(_NEIGHBOURS, len(self))
        _, idx = self._tree.query(np.column_stack([px[ok], py[ok]]), k=k)
        idx = np.asarray(idx, dtype=np.int64).reshape(-1, k)
        seg = np.clip(np.concatenate([idx - 1, idx], axis=1), 0, len(self) - 2)
        out[ok] = np.min(segment_distances(px[ok], py[ok], self.x_m, self.y_m, seg)[0], axis=1)
        return out
