"""The planned reference: a time-parameterised pose and wheel motion, evaluable at any time.

A :class:`Reference` is a chain of :class:`Motion` s, each a rest-to-rest
:class:`~agvctl.planning.profile.JerkProfile` of one coordinate q along one constant-curvature primitive (a
line or an arc: q is the distance travelled; a spin in place: q is the heading change). Every signal is linear
in q's derivatives with constants per motion:

    U = λ q̇,  ω = η q̇,  v_l = U − ω b/2,  v_r = U + ω b/2
    (the report's eqs 39-43: U = (v_r + v_l)/2, ω = (v_r − v_l)/b)

with λ = ±1, η = ±κ for a line or arc, and λ = 0, η = ±1 for a spin; the pose follows from the exact chord of
a circular arc. Evaluation is vectorised: :meth:`Reference.sample` takes an array of times.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.planning.geometry import Pose
from agvctl.planning.profile import JerkProfile
from agvctl.planning.spec import WheelLimits

__all__ = ["CSV_COLUMNS", "Motion", "Reference", "ReferenceSamples"]

FloatArray = NDArray[np.float64]

CSV_COLUMNS = (
    "t_s", "x_m", "y_m", "theta_rad", "speed_m_s", "yaw_rate_rad_s",
    "wheel_speed_left_m_s", "wheel_speed_right_m_s", "wheel_accel_left_m_s2", "wheel_accel_right_m_s2",
)
"""The columns of ``agvctl plan --out``, in order."""


@dataclass(frozen=True, eq=False)
class Motion:
    """One rest-to-rest piece of a reference: a run of segments driven without stopping.

    ``kind`` is ``"path"`` (a line or an arc; q in m) or ``"spin"`` (a turn in place; q in rad).
    ``curvature_1_m`` is κ of a path (0 for a line, + = left); ``direction`` is ±1 (reverse, clockwise).
    ``wheel_factor`` is max(|v_l|, |v_r|)/|q̇| = |λ| + |η| b/2: the coordinate's limits are the wheel limits
    divided by it.
    """

    kind: Literal["path", "spin"]
    segment_indices: tuple[int, ...]
    t_start_s: float
    start_pose: Pose
    end_pose: Pose
    curvature_1_m: float
    direction: int
    wheel_factor: float
    profile: JerkProfile

    @property
    def duration_s(self) -> float:
        return self.profile.duration_s

    @property
    def t_end_s(self) -> float:
        return self.t_start_s + self.profile.duration_s

    @property
    def linear_gain(self) -> float:
        """λ in U = λ q̇."""
        return float(self.direction) if self.kind == "path" else 0.0

    @property
    def angular_gain(self) -> float:
        """η in ω = η q̇ (1/m for a path, 1 for a spin)."""
        return self.direction * (self.curvature_1_m if self.kind == "path" else 1.0)


@dataclass(frozen=True, eq=False)
class ReferenceSamples:
    """The reference at an array of times; every field is an array of the same length (SI units).

    ``theta_rad`` is continuous (not wrapped). ``path_length_m`` is the distance travelled by the point of
    rotation since the start (never decreasing; a spin adds nothing). ``segment_index`` is the index of the
    path file's segment in progress (the last one once the reference has ended).
    """

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    theta_rad: FloatArray
    speed_m_s: FloatArray
    accel_m_s2: FloatArray
    yaw_rate_rad_s: FloatArray
    yaw_accel_rad_s2: FloatArray
    wheel_speed_left_m_s: FloatArray
    wheel_speed_right_m_s: FloatArray
    wheel_accel_left_m_s2: FloatArray
    wheel_accel_right_m_s2: FloatArray
    wheel_jerk_left_m_s3: FloatArray
    wheel_jerk_right_m_s3: FloatArray
    path_length_m: FloatArray
    motion_index: NDArray[np.int64]

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
        self.duration_s = self.motions[-1].t_end_s
        b2 = 0.5 * self.separation_m

        # per motion
        self._lin = np.array([m.linear_gain for m in self.motions])
        self._ang = np.array([m.angular_gain for m in self.motions])
        self._x0 = np.array([m.start_pose.x_m for m in self.motions])
        self._y0 = np.array([m.start_pose.y_m for m in self.motions])
        self._th0 = np.array([m.start_pose.theta_rad for m in self.motions])
        travelled = [m.profile.distance if m.kind == "path" else 0.0 for m in self.motions]
        self._s0 = np.concatenate(([0.0], np.cumsum(travelled)[:-1]))
        self.path_length_m = float(sum(travelled))
        self._left = self._lin - self._ang * b2
        self._right = self._lin + self._ang * b2

        # every phase of every motion, then a final hold phase at rest
        starts, durations, jerk, q0, v0, a0, owner = [], [], [], [], [], [], []
        for i, m in enumerate(self.motions):
            p = m.profile
            starts.append(m.t_start_s + np.concatenate(([0.0], np.cumsum(p.phase_durations_s)[:-1])))
            durations.append(p.phase_durations_s)
            jerk.append(p.jerk)
            q0.append(p.q0)
            v0.append(p.v0)
            a0.append(p.a0)
            owner.append(np.full(len(p.jerk), i))
        last = self.motions[-1].profile
        tau = last.phase_durations_s[-1]
        q_end = last.q0[-1] + last.v0[-1] * tau + 0.5 * last.a0[-1] * tau**2 + last.jerk[-1] * tau**3 / 6.0
        starts.append(np.array([self.duration_s]))
        durations.append(np.array([np.inf]))
        jerk.append(np.zeros(1))
        q0.append(np.array([q_end]))
        v0.append(np.zeros(1))
        a0.append(np.zeros(1))
        owner.append(np.array([len(self.motions) - 1]))
        self._ph_t0 = np.concatenate(starts)
        self._ph_j = np.concatenate(jerk)
        self._ph_q0 = np.concatenate(q0)
        self._ph_v0 = np.concatenate(v0)
        self._ph_a0 = np.concatenate(a0)
        self._ph_motion = np.concatenate(owner).astype(np.int64)
        self._ph_t0[-1] = self.duration_s

    # ------------------------------------------------------------------------------------------------------
    def sample(self, t_s: ArrayLike) -> ReferenceSamples:
        """The reference at the times ``t_s`` (any shape is flattened to 1-D)."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float)).ravel()
        tc = np.clip(t, 0.0, self.duration_s)
        k = np.searchsorted(self._ph_t0, tc, side="right") - 1
        k = np.clip(k, 0, len(self._ph_t0) - 1)
        dt = tc - self._ph_t0[k]
        j = np.where(t < 0.0, 0.0, self._ph_j[k])
        a0, v0 = self._ph_a0[k], self._ph_v0[k]
        q = self._ph_q0[k] + dt * (v0 + dt * (0.5 * a0 + dt * j / 6.0))
        qd = v0 + dt * (a0 + 0.5 * dt * j)
        qdd = a0 + dt * j
        m = self._ph_motion[k]
        lin, ang, left, right = self._lin[m], self._ang[m], self._left[m], self._right[m]
        sigma = lin * q
        half = 0.5 * ang * q
        chord = sigma * np.sinc(half / np.pi)
        heading_mid = self._th0[m] + half
        return ReferenceSamples(
            t_s=t,
            x_m=self._x0[m] + chord * np.cos(heading_mid),
            y_m=self._y0[m] + chord * np.sin(heading_mid),
            theta_rad=self._th0[m] + 2.0 * half,
            speed_m_s=lin * qd,
            accel_m_s2=lin * qdd,
            yaw_rate_rad_s=ang * qd,
            yaw_accel_rad_s2=ang * qdd,
            wheel_speed_left_m_s=left * qd,
            wheel_speed_right_m_s=right * qd,
            wheel_accel_left_m_s2=left * qdd,
            wheel_accel_right_m_s2=right * qdd,
            wheel_jerk_left_m_s3=left * j,
            wheel_jerk_right_m_s3=right * j,
            path_length_m=self._s0[m] + np.abs(lin) * q,
            motion_index=m,
        )

    def segment_index(self, t_s: ArrayLike) -> NDArray[np.int64]:
        """Index of the path file's segment in progress at each time (per motion: the first of its run)."""
        firsts = np.array([m.segment_indices[0] for m in self.motions], dtype=np.int64)
        return firsts[self.sample(t_s).motion_index]

    @functools.cached_property
    def grid_times_s(self) -> FloatArray:
        """t_k = k·T_s for k = 0 … ⌈duration/T_s⌉ (computed as k·T_s, never by accumulation)."""
        n = math.ceil(self.duration_s / self.sample_period_s - 1e-9)
        return np.arange(n + 1, dtype=np.float64) * self.sample_period_s

    @functools.cached_property
    def grid(self) -> ReferenceSamples:
        """The reference sampled on the control grid :attr:`grid_times_s`."""
        return self.sample(self.grid_times_s)

    @property
    def final_pose(self) -> Pose:
        """The pose where the reference comes to rest (evaluated from the profiles)."""
        s = self.sample([self.duration_s])
        return Pose(float(s.x_m[0]), float(s.y_m[0]), float(s.theta_rad[0]))

    def peaks(self) -> dict[str, float]:
        """Exact peaks of |wheel speed|, |wheel accel| and |wheel jerk| (either wheel) over the reference."""
        v = a = j = 0.0
        for m in self.motions:
            pv, pa, pj = m.profile.peaks()
            v, a, j = max(v, pv * m.wheel_factor), max(a, pa * m.wheel_factor), max(j, pj * m.wheel_factor)
        return {"peak_wheel_speed_m_s": v, "peak_wheel_accel_m_s2": a, "peak_wheel_jerk_m_s3": j}

    def summary(self) -> dict[str, object]:
        """The ``agvctl plan --json`` object."""
        pose = self.final_pose
        return {
            "name": self.name,
            "duration_s": self.duration_s,
            "path_length_m": self.path_length_m,
            **self.peaks(),
            "final_pose": {"x_m": pose.x_m, "y_m": pose.y_m, "theta_rad": pose.theta_rad},
        }

    def __repr__(self) -> str:
        return (f"Reference(name={self.name!r}, duration_s={self.duration_s:.3f}, "
                f"path_length_m={self.path_length_m:.3f}, motions={len(self.motions)})")
