"""Errors against the reference *path*, separating lag from error: cross-track, along-track lag, path heading.

The time-indexed position error |p(t) − p_d(t)| of a run mixes two things: being off the path and being behind
(or ahead of) the clock. Here the path is the curve the reference's point of rotation traces, as a polyline of
its positions sampled at most ``spacing_m`` apart in arc length s; for a vehicle sample at time t:

- cross-track error: the distance from the vehicle's position to the nearest point of the polyline (exact
  projection onto its segments; the polyline's chords sit within spacing²/(8ρ) of an arc of radius ρ);
- along-track lag: s_d(t) − s*, the arc length of the time-indexed reference point minus that of the nearest
  path point (positive: the vehicle is behind the reference point);
- heading error: θ − θ_path(s*), wrapped to [−π, π), with θ_path the reference's heading along the path (so a
  path driven in reverse has the heading of the vehicle, not of the tangent). Where the path stops and turns in
  place, the nearest point is a vertex with a range of headings (every heading the reference takes there:
  consecutive turns one way and back overshoot both ends); the error is the distance to that range. Beside such a
  vertex the nearest point is ambiguous (a vehicle 1 mm past it is nearest to the next segment, whose heading may
  differ by the whole turn), so the error against the turn's range counts too, the smaller of the two, for every
  turn-in-place vertex within ``turn_zone_m`` (default 5 cm) or within 2·d + spacing of the vehicle (d: its
  cross-track error), and for the one where the time-indexed reference is turning now: a vehicle turning in
  place a few centimetres off the vertex is turning, not turned around (its offset shows in the cross-track error
  and the lag).

Where the path crosses, retraces or ends on itself, the nearest point is ambiguous, and the lag would jump by
a lap. Lag and heading therefore use the nearest point of the *branch* that minimises
distance + ``branch_weight``·|σ − σ_d(t)|, with σ the travel along the path: its arc length plus, for each turn
in place, what the wheels roll in it (b/2 per radian), so that the way back after a sharp turn, which may run
within millimetres of the way there, is as far from it as the wheels' travel between. Another part of the path
is taken only if it is nearer by more than ``branch_weight`` times its travel from the clock (with the default
0.1, 10 cm nearer per metre). Along one branch the nearest point itself is unbiased. The cross-track error is
always the true distance to the path.

The nearest points come from a k-d tree (``scipy.spatial.cKDTree``) on the polyline's vertices: each vehicle
sample is projected onto the segments next to its ``neighbours`` nearest vertices, and onto those around the
time-indexed reference point (so that the clock's branch is a candidate even where the path retraces
itself). The default 48 vertices reach about 12 cm from the vehicle, beyond the default gate's 10 cm corridor, so
another branch the vehicle could be on is always a candidate: driving back along a sharp turn's way back, nearer
the way there and behind the clock, the way back is still among the choices.
Pure numpy/scipy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from agvctl.config import document_fields
from agvctl.planning.geometry import segment_distances
from agvctl.planning.reference import Reference

__all__ = ["PATH_LOG_COLUMNS", "PathErrors", "ReferencePath", "path_error_columns", "path_errors"]

FloatArray = NDArray[np.float64]

PATH_LOG_COLUMNS = ("cross_track_error_m", "along_track_lag_m", "path_heading_error_rad", "drawn_cross_track_error_m")
"""The log columns of :func:`path_error_columns`: :class:`PathErrors`' cross-track error, along-track lag and
heading error, and the distance to the path the file draws (``Reference.drawn_path``: its lines and arcs, or the
curve through its waypoints, before the planner smooths its joins), per sample."""


_BRANCH_SPAN = 8.0
"""Candidates within this many vertex spacings of travel from the chosen one are on its branch."""
_ROWS = 64
"""Samples evaluated together: their (rows × 3·neighbours) work arrays fit the processor's cache."""


def _wrap(angle_rad: FloatArray) -> FloatArray:
    return np.asarray((angle_rad + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


@document_fields
@dataclass(frozen=True)
class PathErrors:
    """Errors of vehicle samples against the reference path; arrays of the samples' length."""

    cross_track_m: FloatArray
    """Distance from the vehicle's position to the path (≥ 0), m."""
    along_track_lag_m: FloatArray
    """s_d(t) − s*: how far (arc length) the nearest path point is behind the time-indexed reference point, m."""
    heading_error_rad: FloatArray
    """θ − θ_path at the nearest point, wrapped to [−π, π), rad."""
    path_length_m: FloatArray
    """s*, the arc length of the nearest path point, m."""


class ReferencePath:
    """The reference's path as a polyline with arc length and heading per vertex, and a k-d tree on it.

    Parameters
    ----------
    reference
        The planned reference; the path is its positions over [0, duration].
    spacing_m
        Largest arc length between vertices (on a line or arc; a stop adds a vertex), m.
    """

    def __init__(self, reference: Reference, spacing_m: float = 0.01) -> None:
        if not spacing_m > 0:
            raise ValueError(f"spacing_m must be > 0 (got {spacing_m})")
        speed = max(reference.peak_wheel_speed_m_s(), 1e-9)  # bounds |U| (eqs 39-43)
        # samples at most spacing/2 apart, one vertex per spacing/2 of arc length: vertices at most spacing apart
        half = 0.5 * spacing_m
        n = max(2, min(4_000_000, math.ceil(reference.duration_s * speed / half) + 1))
        # every motion's end is sampled exactly and kept as a vertex (a stop, where the heading may turn back)
        stops = np.array([m.t_end_s for m in reference.motions])
        times = np.union1d(np.linspace(0.0, reference.duration_s, n), stops)
        n = len(times)
        d = reference.sample(times)
        x, y, s, th = d.x_m, d.y_m, d.path_length_m, d.theta_rad
        # runs of samples at one position (stops, turns in place) become one vertex with a heading range
        moved = np.hypot(np.diff(x), np.diff(y)) > 1e-12
        first = np.concatenate(([0], np.nonzero(moved)[0] + 1))
        last = np.concatenate((first[1:] - 1, [n - 1]))
        # thin to about spacing_m / 2, keeping every stop and the end
        cell = np.floor(s[first] / half)
        keep = np.concatenate(([True], cell[1:] != cell[:-1]))
        keep |= last > first
        keep[np.searchsorted(first, np.searchsorted(times, stops), side="right") - 1] = True
        keep[-1] = True
        # the headings a vertex takes: all those of its run (turns in place one way, then back, go beyond the ends)
        low, high = np.minimum.reduceat(th, first)[keep], np.maximum.reduceat(th, first)[keep]
        first, last = first[keep], last[keep]
        self.x_m: FloatArray = x[first]
        self.y_m: FloatArray = y[first]
        self.s_m: FloatArray = s[first]
        self.theta_arrive_rad: FloatArray = th[first]
        """The reference heading on arriving at each vertex."""
        self.theta_leave_rad: FloatArray = th[last]
        """The heading on leaving it (differs from the arrival after a turn in place)."""
        self.theta_low_rad: FloatArray = low
        self.theta_high_rad: FloatArray = high
        """The range of headings the reference takes at each vertex (arrival and leaving included)."""
        self.spacing_m = spacing_m
        # travel along the path counting turns in place as the wheels do (b/2 per radian): the branch measure
        rotated = np.concatenate(([0.0], np.where(moved, 0.0, np.abs(np.diff(th)))))
        travel = s + 0.5 * reference.separation_m * np.cumsum(rotated)
        self._clock_t_s, self._clock_travel_m = times, travel
        self.travel_leave_m: FloatArray = travel[last]
        """The travel (arc length plus b/2 per radian turned in place) on leaving each vertex."""
        self.tree = cKDTree(np.column_stack([self.x_m, self.y_m]), balanced_tree=False, compact_nodes=False)
        self.reference = reference

    def __len__(self) -> int:
        return len(self.x_m)

    def errors(
        self,
        t_s: ArrayLike,
        x_m: ArrayLike,
        y_m: ArrayLike,
        theta_rad: ArrayLike,
        *,
        neighbours: int = 48,
        branch_weight: float = 0.1,
        turn_zone_m: float = 0.05,
    ) -> PathErrors:
        """Cross-track error, along-track lag and heading error of vehicle samples (times in s, poses in m, rad)."""
        t, px, py, th = (np.atleast_1d(np.asarray(a, dtype=np.float64)).ravel() for a in (t_s, x_m, y_m, theta_rad))
        if not len(t) == len(px) == len(py) == len(th):
            raise ValueError("t_s, x_m, y_m and theta_rad must have the same length")
        s_ref = self.reference.sample(t).path_length_m
        if len(self) == 1:  # a path that never moves: the distance to its point
            zero = np.zeros_like(px)
            d = np.hypot(px - self.x_m[0], py - self.y_m[0])
            heading = self._vertex_heading_error(th, np.zeros(len(th), dtype=np.int64))
            return PathErrors(d, s_ref - self.s_m[0], heading, zero + self.s_m[0])
        k = min(max(1, neighbours), len(self))
        _, idx = self.tree.query(np.column_stack([px, py]), k=k)
        idx = np.asarray(idx, dtype=np.int64).reshape(len(px), k)
        travel_ref = np.interp(t, self._clock_t_s, self._clock_travel_m)
        d_min, s_star, heading = (np.empty(len(px)) for _ in range(3))
        for start in range(0, len(px), _ROWS):  # rows are independent; a block's work arrays stay in the cache
            at = slice(start, start + _ROWS)
            d_min[at], s_star[at], heading[at] = self._nearest(
                px[at], py[at], th[at], s_ref[at], travel_ref[at], idx[at], branch_weight, turn_zone_m
            )
        return PathErrors(d_min, s_ref - s_star, heading, s_star)

    def _nearest(
        self,
        px: FloatArray,
        py: FloatArray,
        th: FloatArray,
        s_ref: FloatArray,
        travel_ref: FloatArray,
        idx: NDArray[np.int64],
        branch_weight: float,
        turn_zone_m: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The distance to the path, the arc length s* of the nearest point of the branch and the heading error
        there, of samples whose nearest vertices are ``idx``."""
        dist, seg, u = self._candidates(px, py, s_ref, idx)
        rows = np.arange(len(px))
        s_c = self.s_m[seg] + u * (self.s_m[seg + 1] - self.s_m[seg])
        travel_c = s_c + (self.travel_leave_m[seg] - self.s_m[seg])
        d_min = np.min(dist, axis=1)
        # the branch (a stretch of travel) nearest with a preference for the clock's, then its nearest point
        seed = np.argmin(dist + branch_weight * np.abs(travel_c - travel_ref[:, None]), axis=1)
        # the branch: within 2·d of travel of the seed, where the clock's pull can move the seed off the nearest point
        span = _BRANCH_SPAN * self.spacing_m + 2.0 * d_min
        branch = np.abs(travel_c - travel_c[rows, seed][:, None]) <= span[:, None]
        pick = np.argmin(np.where(branch, dist, np.inf), axis=1)
        j, uj = seg[rows, pick], u[rows, pick]
        reach = np.maximum(2.0 * dist[rows, pick] + self.spacing_m, turn_zone_m)
        heading = self._near_turns(px, py, th, s_ref, reach, self._heading_error(th, j, uj))
        return d_min, s_c[rows, pick], heading

    def _near_turns(
        self,
        px: FloatArray,
        py: FloatArray,
        theta: FloatArray,
        s_ref: FloatArray,
        reach: FloatArray,
        heading: FloatArray,
    ) -> FloatArray:
        """Where the path turns in place near the vehicle, any heading in the turn's range is on the path: a
        vertex with a range of headings within ``reach`` of the vehicle, or the one the time-indexed reference
        point is at, gives the error instead if its range is nearer in angle. (Off a turn by a few cm, the nearest
        point is on the next line, whose heading the vehicle only takes once the turn is done.)"""
        turns = np.nonzero(self.theta_high_rad - self.theta_low_rad > 1e-9)[0]
        if turns.size == 0:
            return heading
        near = np.hypot(px[:, None] - self.x_m[turns], py[:, None] - self.y_m[turns]) <= reach[:, None]
        near |= np.abs(s_ref[:, None] - self.s_m[turns]) <= 0.5 * self.spacing_m
        errors = np.column_stack([self._vertex_heading_error(theta, np.full(len(theta), v)) for v in turns])
        errors = np.where(near, errors, np.inf)
        best = errors[np.arange(len(theta)), np.argmin(np.abs(errors), axis=1)]
        return np.asarray(np.where(np.abs(best) < np.abs(heading), best, heading), dtype=np.float64)

    def _candidates(
        self, px: FloatArray, py: FloatArray, s_ref: FloatArray, idx: NDArray[np.int64]
    ) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
        """(distance, segment index, projection parameter u ∈ [0, 1]) onto the candidate segments of each
        sample, shape (samples, 3·k): those next to its k nearest vertices ``idx`` (the global nearest point) and
        the k around the time-indexed reference point (its branch, where the path overlaps itself)."""
        k = idx.shape[1]
        at_clock = np.searchsorted(self.s_m, s_ref)[:, None] + np.arange(-(k // 2), k - k // 2)
        seg = np.clip(np.concatenate([idx - 1, idx, at_clock], axis=1), 0, len(self) - 2)
        dist, u = segment_distances(px, py, self.x_m, self.y_m, seg)
        return dist, seg, u

    def _heading_error(self, theta: FloatArray, seg: NDArray[np.int64], u: FloatArray) -> FloatArray:
        """θ against the path heading at parameter u of segment seg; at a vertex, against its heading range."""
        interior = self.theta_leave_rad[seg] + u * (self.theta_arrive_rad[seg + 1] - self.theta_leave_rad[seg])
        error = _wrap(theta - interior)
        at_start, at_end = u <= 0.0, u >= 1.0
        if np.any(at_start):
            error[at_start] = self._vertex_heading_error(theta[at_start], seg[at_start])
        if np.any(at_end):
            error[at_end] = self._vertex_heading_error(theta[at_end], seg[at_end] + 1)
        return error

    def _vertex_heading_error(self, theta: FloatArray, vertex: NDArray[np.int64]) -> FloatArray:
        """Signed distance (wrapped) of θ to the range of headings the path takes at ``vertex``."""
        lo, hi = self.theta_low_rad[vertex], self.theta_high_rad[vertex]
        half = 0.5 * np.abs(hi - lo)
        d = _wrap(theta - 0.5 * (lo + hi))
        return np.asarray(np.sign(d) * np.maximum(np.abs(d) - half, 0.0), dtype=np.float64)


def path_errors(
    t_s: ArrayLike,
    x_m: ArrayLike,
    y_m: ArrayLike,
    theta_rad: ArrayLike,
    reference: Reference,
    *,
    spacing_m: float = 0.01,
) -> PathErrors:
    """Cross-track error, along-track lag and heading error of vehicle samples against a reference's path (see the
    module notes). Build a :class:`ReferencePath` once to evaluate several runs of one reference.

    Parameters
    ----------
    t_s : array_like
        The samples' times, s.
    x_m, y_m : array_like
        The vehicle's positions, m.
    theta_rad : array_like
        Its headings, rad.
    reference : Reference
        The reference whose path (and time-indexed point) the samples are judged against.
    spacing_m : float
        The spacing of the polyline that stands for the path, m.

    Returns
    -------
    PathErrors
        The errors of each sample.
    """
    return ReferencePath(reference, spacing_m).errors(t_s, x_m, y_m, theta_rad)


def path_error_columns(
    t_s: ArrayLike, x_m: ArrayLike, y_m: ArrayLike, theta_rad: ArrayLike, reference: Reference
) -> dict[str, FloatArray]:
    """The :data:`PATH_LOG_COLUMNS` of a run's samples against a reference's path (one k-d tree per call).

    Parameters
    ----------
    t_s : array_like
        The samples' times, s.
    x_m, y_m : array_like
        The vehicle's positions, m.
    theta_rad : array_like
        Its headings, rad.
    reference : Reference
        The reference.

    Returns
    -------
    dict of str to ndarray
        Each column by name; samples whose pose is not finite (a run that diverged) get NaN. Without a drawn path
        (``reference.drawn_path`` None) the planned path is the drawn one.
    """
    t, x, y, th = (np.atleast_1d(np.asarray(a, dtype=np.float64)).ravel() for a in (t_s, x_m, y_m, theta_rad))
    out = {name: np.full(len(t), np.nan) for name in PATH_LOG_COLUMNS}
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(y) & np.isfinite(th)
    if np.any(ok):
        e = ReferencePath(reference).errors(t[ok], x[ok], y[ok], th[ok])
        for name, values in zip(
            PATH_LOG_COLUMNS[:3], (e.cross_track_m, e.along_track_lag_m, e.heading_error_rad), strict=True
        ):
            out[name][ok] = values
        drawn = reference.drawn_path
        out["drawn_cross_track_error_m"][ok] = e.cross_track_m if drawn is None else drawn.distance_m(x[ok], y[ok])
    return out
