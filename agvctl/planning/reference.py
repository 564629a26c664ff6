"""The planned reference: a time-parameterised pose and wheel motion, evaluable at any time.

A :class:`Reference` is a chain of :class:`Motion` s, each driven without stopping: a *path* motion follows a
:class:`~agvctl.planning.curve.Curve` (lines, arcs, smooth joins, waypoint splines), its coordinate q the
distance travelled; a *spin* turns in place, q the heading change. Each motion's q(t) is a chain of
jerk-limited :class:`~agvctl.planning.profile.JerkProfile` s, one per section (see
:mod:`agvctl.planning.speed`). With direction d = ±1 and the curve's κ(q):

    path:  U = d q̇,  ω = κ q̇,  ω̇ = κ q̈ + κ' q̇²,  ω̈ = κ q⃛ + 3 κ' q̇ q̈ + κ'' q̇³
    spin:  U = 0,    ω = d q̇
    v_l = U − ω b/2,  v_r = U + ω b/2   (the report's eqs 39-43: U = (v_r + v_l)/2, ω = (v_r − v_l)/b)

Evaluation is vectorised: :meth:`Reference.sample` takes an array of times.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.config import document_fields
from agvctl.planning.curve import Curve
from agvctl.planning.drawn import DrawnPath
from agvctl.planning.geometry import Pose
from agvctl.planning.profile import JerkProfile
from agvctl.planning.spec import WheelLimits

__all__ = ["CSV_COLUMNS", "Motion", "Reference", "ReferenceSamples"]

FloatArray = NDArray[np.float64]

CSV_COLUMNS = (
    "t_s",
    "x_m",
    "y_m",
    "theta_rad",
    "speed_m_s",
    "yaw_rate_rad_s",
    "wheel_speed_left_m_s",
    "wheel_speed_right_m_s",
    "wheel_accel_left_m_s2",
    "wheel_accel_right_m_s2",
)
"""The columns of ``agvctl plan --out``, in order."""

PEAK_CHUNK = 1 << 16
"""Samples evaluated at once by :meth:`Reference.peaks`: a few megabytes of arrays, whatever the duration."""


@document_fields
@dataclass(frozen=True, eq=False)
class Motion:
    """One piece of a reference driven without stopping, from rest to rest, its coordinate q a distance along a
    curve (m) or a heading change (rad)."""

    kind: Literal["path", "spin"]
    """``"path"`` (q in m along ``curve``) or ``"spin"`` (a turn in place; q in rad)."""
    segment_indices: tuple[int, ...]
    """The path file's segments it drives (waypoint intervals for a waypoint path)."""
    t_start_s: float
    """When it starts on the reference, s."""
    start_pose: Pose
    """Where it starts."""
    end_pose: Pose
    """Where it ends."""
    direction: int
    """±1: −1 in reverse (a path) or clockwise (a spin)."""
    profiles: tuple[JerkProfile, ...]
    """q(t) on each section, one after another in time."""
    section_starts: tuple[float, ...]
    """The q at which each section starts."""
    segment_starts: tuple[float, ...]
    """The q at which each of ``segment_indices`` starts."""
    curve: Curve | None = None
    """The geometry of a path motion (None for a spin)."""

    @property
    def duration_s(self) -> float:
        return float(sum(p.duration_s for p in self.profiles))

    @property
    def t_end_s(self) -> float:
        return self.t_start_s + self.duration_s

    @property
    def distance(self) -> float:
        """Total change of q (m for a path, rad for a spin)."""
        return float(self.section_starts[-1] + self.profiles[-1].distance)


@document_fields
@dataclass(frozen=True, eq=False)
class ReferenceSamples:
    """The reference at an array of times; every field is an array of the same length."""

    t_s: FloatArray
    """The times, s."""
    x_m: FloatArray
    """x of the point of rotation, m."""
    y_m: FloatArray
    """y of the point of rotation, m."""
    theta_rad: FloatArray
    """The heading, continuous (not wrapped), rad."""
    speed_m_s: FloatArray
    """The vehicle's speed U, m/s."""
    accel_m_s2: FloatArray
    """Its acceleration U̇, m/s²."""
    yaw_rate_rad_s: FloatArray
    """The yaw rate ω, rad/s."""
    yaw_accel_rad_s2: FloatArray
    """The yaw acceleration ω̇, rad/s²."""
    wheel_speed_left_m_s: FloatArray
    """The left wheel's speed, m/s."""
    wheel_speed_right_m_s: FloatArray
    """The right wheel's speed, m/s."""
    wheel_accel_left_m_s2: FloatArray
    """The left wheel's acceleration, m/s²."""
    wheel_accel_right_m_s2: FloatArray
    """The right wheel's acceleration, m/s²."""
    wheel_jerk_left_m_s3: FloatArray
    """The left wheel's jerk, m/s³."""
    wheel_jerk_right_m_s3: FloatArray
    """The right wheel's jerk, m/s³."""
    path_length_m: FloatArray
    """The distance the point of rotation has travelled since the start (never decreasing; a spin adds
    nothing), m."""
    curvature_1_m: FloatArray
    """κ of the path at the current point (positive: left; 0 during a spin), 1/m."""
    motion_index: NDArray[np.int64]
    """The index of the motion in progress (the last one once the reference has ended)."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):  # frozen, arrays included: a cached grid is shared by every reader
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                value.flags.writeable = False

    def __len__(self) -> int:
        return len(self.t_s)

    def columns(self, names: Sequence[str] = CSV_COLUMNS) -> dict[str, FloatArray]:
        """The named fields as an ordered mapping, e.g. for :func:`agvctl.fileio.write_csv`."""
        return {name: getattr(self, name) for name in names}


class Reference:
    """A planned reference trajectory. Built by :func:`agvctl.planning.plan`; immutable.

    Evaluate it anywhere with :meth:`sample` (times before 0 give the start at rest, times after
    :attr:`duration_s` the final pose at rest), or use :attr:`grid`, the samples at t_k = k·T_s from 0 to the
    first grid time at or after the end.

    Parameters
    ----------
    name : str
        The path's name.
    motions : sequence of Motion
        Its motions, at least one, one after another in time.
    limits : WheelLimits
        The wheel limits it was planned within.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The control sample period T_s of :attr:`grid`, s.
    start_pose : Pose
        Where it starts.
    segment_count : int
        The path's segments (or waypoint intervals).
    drawn_path_deviation_m : float
        The largest distance from a point of the planned path to the drawn one (where its smooth joins, or the
        interpolation of a waypoint spline, leave it), m.
    drawn_path_tolerance_m : float
        The tolerance it was planned within (the path file's ``limits.drawn_path_tolerance_m``), m.
    drawn_path : DrawnPath or None
        The path as the file draws it; None: the planned path is the drawn one.

    Raises
    ------
    ValueError
        No motion.
    """

    def __init__(
        self,
        *,
        name: str,
        motions: Sequence[Motion],
        limits: WheelLimits,
        separation_m: float,
        sample_period_s: float,
        start_pose: Pose,
        segment_count: int,
        drawn_path_deviation_m: float = 0.0,
        drawn_path_tolerance_m: float = math.inf,
        drawn_path: DrawnPath | None = None,
    ) -> None:
        if not motions:
            raise ValueError("a reference needs at least one motion")
        self.name = name
        self.motions: tuple[Motion, ...] = tuple(motions)
        self.limits = limits
        self.separation_m = float(separation_m)
        self.sample_period_s = float(sample_period_s)
        self.start_pose = start_pose
        self.segment_count = segment_count
        self.drawn_path_deviation_m = float(drawn_path_deviation_m)
        """The largest distance from a point of the planned path to the path the file draws, m
        (:mod:`agvctl.planning.drawn`)."""
        self.drawn_path_tolerance_m = float(drawn_path_tolerance_m)
        """The largest :attr:`drawn_path_deviation_m` the planner was asked to keep, m."""
        self.drawn_path = drawn_path
        """The path as the file draws it (None: the planned path is the drawn one)."""
        self.duration_s = self.motions[-1].t_end_s
        travelled = [m.distance if m.kind == "path" else 0.0 for m in self.motions]
        self._s0 = np.concatenate(([0.0], np.cumsum(travelled)[:-1]))
        self.path_length_m = float(sum(travelled))

        # every phase of every section of every motion, then a final hold phase at rest
        starts, jerk, q0, v0, a0, owner = [], [], [], [], [], []
        for i, m in enumerate(self.motions):
            t = m.t_start_s
            for offset, p in zip(m.section_starts, m.profiles, strict=True):
                starts.append(t + np.concatenate(([0.0], np.cumsum(p.phase_durations_s)[:-1])))
                jerk.append(p.jerk)
                q0.append(p.q0 + offset)
                v0.append(p.v0)
                a0.append(p.a0)
                owner.append(np.full(len(p.jerk), i))
                t += p.duration_s
        starts.append(np.array([self.duration_s]))
        jerk.append(np.zeros(1))
        q0.append(np.array([self.motions[-1].distance]))
        v0.append(np.zeros(1))
        a0.append(np.zeros(1))
        owner.append(np.array([len(self.motions) - 1]))
        self._ph_t0 = np.concatenate(starts)
        self._ph_j = np.concatenate(jerk)
        self._ph_q0 = np.concatenate(q0)
        self._ph_v0 = np.concatenate(v0)
        self._ph_a0 = np.concatenate(a0)
        self._ph_motion = np.concatenate(owner).astype(np.int64)
        for array in (self._s0, self._ph_t0, self._ph_j, self._ph_q0, self._ph_v0, self._ph_a0, self._ph_motion):
            array.flags.writeable = False

    # ------------------------------------------------------------------------------------------------------
    def _coordinate(
        self, t_s: ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.int64]]:
        """``(t, q, q̇, q̈, q⃛, motion index)`` at the times (flattened)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float)).ravel()
        tc = np.clip(t, 0.0, self.duration_s)
        k = np.clip(np.searchsorted(self._ph_t0, tc, side="right") - 1, 0, len(self._ph_t0) - 1)
        dt = tc - self._ph_t0[k]
        j = np.where(t < 0.0, 0.0, self._ph_j[k])
        a0, v0 = self._ph_a0[k], self._ph_v0[k]
        q = self._ph_q0[k] + dt * (v0 + dt * (0.5 * a0 + dt * j / 6.0))
        qd = v0 + dt * (a0 + 0.5 * dt * j)
        qdd = a0 + dt * j
        return t, q, qd, qdd, j, self._ph_motion[k]

    def sample(self, t_s: ArrayLike) -> ReferenceSamples:
        """The reference at the times ``t_s`` (any shape is flattened to 1-D)."""
        t, q, qd, qdd, j, m = self._coordinate(t_s)
        n = len(t)
        x, y, th, kap = np.empty(n), np.empty(n), np.empty(n), np.zeros(n)
        u, ud, uj = np.zeros(n), np.zeros(n), np.zeros(n)
        w, wd, wj = np.empty(n), np.empty(n), np.empty(n)
        for i in np.unique(m):
            sel = m == i
            mo = self.motions[i]
            d = mo.direction
            if mo.curve is None:  # spin in place
                x[sel], y[sel] = mo.start_pose.x_m, mo.start_pose.y_m
                th[sel] = mo.start_pose.theta_rad + d * q[sel]
                w[sel], wd[sel], wj[sel] = d * qd[sel], d * qdd[sel], d * j[sel]
                continue
            c = mo.curve.evaluate(q[sel])
            v, acc, jk = qd[sel], qdd[sel], j[sel]
            x[sel], y[sel], th[sel], kap[sel] = c.x_m, c.y_m, c.theta_rad, c.curvature_1_m
            u[sel], ud[sel], uj[sel] = d * v, d * acc, d * jk
            w[sel] = c.curvature_1_m * v
            wd[sel] = c.curvature_1_m * acc + c.curvature_rate_1_m2 * v**2
            wj[sel] = c.curvature_1_m * jk + 3.0 * c.curvature_rate_1_m2 * v * acc + c.curvature_accel_1_m3 * v**3
        h = 0.5 * self.separation_m
        is_path = np.array([mo.kind == "path" for mo in self.motions])[m]
        return ReferenceSamples(
            t_s=t,
            x_m=x,
            y_m=y,
            theta_rad=th,
            speed_m_s=u,
            accel_m_s2=ud,
            yaw_rate_rad_s=w,
            yaw_accel_rad_s2=wd,
            wheel_speed_left_m_s=u - w * h,
            wheel_speed_right_m_s=u + w * h,
            wheel_accel_left_m_s2=ud - wd * h,
            wheel_accel_right_m_s2=ud + wd * h,
            wheel_jerk_left_m_s3=uj - wj * h,
            wheel_jerk_right_m_s3=uj + wj * h,
            path_length_m=self._s0[m] + np.where(is_path, q, 0.0),
            curvature_1_m=kap,
            motion_index=m,
        )

    def segment_index(self, t_s: ArrayLike) -> NDArray[np.int64]:
        """Index of the path file's segment (or waypoint interval) in progress at each time."""
        _, q, _, _, _, m = self._coordinate(t_s)
        out = np.empty(len(q), dtype=np.int64)
        for i in np.unique(m):
            sel = m == i
            mo = self.motions[i]
            k = np.searchsorted(np.asarray(mo.segment_starts), q[sel] + 1e-12, side="right") - 1
            out[sel] = np.asarray(mo.segment_indices)[np.clip(k, 0, len(mo.segment_indices) - 1)]
        return out

    @functools.cached_property
    def grid_times_s(self) -> FloatArray:
        """t_k = k·T_s for k = 0 … ⌈duration/T_s⌉ (computed as k·T_s, never by accumulation)."""
        n = math.ceil(self.duration_s / self.sample_period_s - 1e-9)
        times = np.arange(n + 1, dtype=np.float64) * self.sample_period_s
        times.flags.writeable = False
        return times

    @functools.cached_property
    def grid(self) -> ReferenceSamples:
        """The reference sampled on the control grid :attr:`grid_times_s`."""
        return self.sample(self.grid_times_s)

    @property
    def final_pose(self) -> Pose:
        """The pose where the reference comes to rest (evaluated from the profiles)."""
        s = self.sample([self.duration_s])
        return Pose(float(s.x_m[0]), float(s.y_m[0]), float(s.theta_rad[0]))

    def peaks(self, dense_period_s: float = 1e-3) -> dict[str, float]:
        """Peaks of ``|wheel speed|``, ``|wheel accel|`` and ``|wheel jerk|`` (either wheel) over the reference, sampled
        every ``dense_period_s`` and at every phase switch (where the accelerations peak).

        The samples are taken :data:`PEAK_CHUNK` at a time and only the curvature is evaluated (not the pose), so the
        memory stays bounded whatever the duration and the work grows linearly with it. The reference is immutable:
        the peaks are worked out once per ``dense_period_s``.
        """
        known: dict[float, dict[str, float]] = self.__dict__.setdefault("_peaks_by_period", {})
        if dense_period_s not in known:
            out = self._dense_peaks(dense_period_s, 3)
            known[dense_period_s] = {
                "peak_wheel_speed_m_s": float(out[0]),
                "peak_wheel_accel_m_s2": float(out[1]),
                "peak_wheel_jerk_m_s3": float(out[2]),
            }
        return dict(known[dense_period_s])

    def peak_wheel_speed_m_s(self, dense_period_s: float = 1e-3) -> float:
        """The ``peak_wheel_speed_m_s`` of :meth:`peaks`, the same number, without the accelerations' work (the
        curvature alone is evaluated): the largest rate of travel, ``|U| + |ω| b/2``. Worked out once per
        ``dense_period_s``, like the peaks."""
        known: dict[float, dict[str, float]] = self.__dict__.setdefault("_peaks_by_period", {})
        if dense_period_s in known:
            return known[dense_period_s]["peak_wheel_speed_m_s"]
        speeds: dict[float, float] = self.__dict__.setdefault("_peak_speed_by_period", {})
        if dense_period_s not in speeds:
            speeds[dense_period_s] = float(self._dense_peaks(dense_period_s, 1)[0])
        return speeds[dense_period_s]

    def _dense_peaks(self, dense_period_s: float, orders: int) -> FloatArray:
        """The first ``orders`` of the peaks (speed, acceleration, jerk) of :meth:`peaks`."""
        n_dense = math.ceil(self.duration_s / dense_period_s)
        out = np.zeros(orders)
        for lo in range(0, n_dense, PEAK_CHUNK):
            t = np.arange(lo, min(n_dense, lo + PEAK_CHUNK), dtype=np.float64) * dense_period_s
            out = np.maximum(out, self._wheel_peaks(t[t < self.duration_s], orders))
        for lo in range(0, len(self._ph_t0), PEAK_CHUNK):
            out = np.maximum(out, self._wheel_peaks(self._ph_t0[lo : lo + PEAK_CHUNK], orders))
        return np.maximum(out, self._wheel_peaks(np.array([self.duration_s]), orders))

    def _wheel_peaks(self, t_s: FloatArray, orders: int) -> FloatArray:
        """The largest ``|wheel speed|``, ``|wheel accel|``, ``|wheel jerk|`` (either wheel) at the times: the first
        ``orders`` of them (1: the speed alone, 3: all)."""
        if len(t_s) == 0:
            return np.zeros(orders)
        _, q, qd, qdd, j, m = self._coordinate(t_s)
        u, ud, uj = np.zeros(len(q)), np.zeros(len(q)), np.zeros(len(q))
        w, wd, wj = np.empty(len(q)), np.empty(len(q)), np.empty(len(q))
        for i in np.unique(m):
            sel = m == i
            mo = self.motions[i]
            d = mo.direction
            if mo.curve is None:  # spin in place
                w[sel], wd[sel], wj[sel] = d * qd[sel], d * qdd[sel], d * j[sel]
                continue
            v = qd[sel]
            if orders == 1:
                u[sel], w[sel] = d * v, mo.curve.curvatures(q[sel], 1)[0] * v
                continue
            k, k1, k2 = mo.curve.curvatures(q[sel])
            acc, jk = qdd[sel], j[sel]
            u[sel], ud[sel], uj[sel] = d * v, d * acc, d * jk
            w[sel] = k * v
            wd[sel] = k * acc + k1 * v**2
            wj[sel] = k * jk + 3.0 * k1 * v * acc + k2 * v**3
        h = 0.5 * self.separation_m
        pairs = ((u, w), (ud, wd), (uj, wj))[:orders]
        return np.array([np.max(np.abs(a) + np.abs(b) * h) for a, b in pairs])

    def summary(self) -> dict[str, object]:
        """The ``agvctl plan --json`` object."""
        pose, tolerance = self.final_pose, self.drawn_path_tolerance_m
        return {
            "name": self.name,
            "duration_s": self.duration_s,
            "path_length_m": self.path_length_m,
            **self.peaks(),
            "drawn_path_deviation_m": self.drawn_path_deviation_m,
            "drawn_path_tolerance_m": tolerance if math.isfinite(tolerance) else None,
            "final_pose": {"x_m": pose.x_m, "y_m": pose.y_m, "theta_rad": pose.theta_rad},
        }

    def __repr__(self) -> str:
        return (
            f"Reference(name={self.name!r}, duration_s={self.duration_s:.3f}, "
            f"path_length_m={self.path_length_m:.3f}, motions={len(self.motions)})"
        )
