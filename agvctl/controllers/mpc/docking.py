"""Docking: the final approach when a tracking controller stops beside the end of its path.

At the end the reference is at rest, and a vehicle beside it cannot move sideways (eqs 41-43: ẏ = U sin θ in the path's
frame needs U ≠ 0); a controller linearised about the reference at rest sees no way to remove a lateral error there, so
it stays. A driver backs up and comes in again. :class:`Docking` decides when and plans that manoeuvre as an ordinary
reference: once the vehicle has (nearly) stopped at the end with an error across the path's last drive above
``tolerance_m`` (where the path ends with turns in place, a distance from the end point above it, across the drive and
along it together), a straight line back along that drive's final heading and the same line forwards again, slowly
(``speed_m_s``, ``accel_m_s2``), ending at the path's end pose (where the path ends with turns in place, the heading
they leave is undone first, the short way round, and turned again after); the controller tracks it like any reference
and removes the error while moving. The distance grows with the error (a heading change of about 2·e/L suffices), in
steps of 5 cm (:func:`backing_steps`: a finite set of manoeuvres per path, which the generated C plans ahead), and
shrinks where the path ends on a curve, so that backing straight up stays within ``max_deviation_m`` of the path's arc
(``L ≤ √(2δ/|κ|)``), and never reaches back beyond the path's last motion. It is tried at most ``attempts`` times, and
never on a path that only turns in place.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.config import check_fields, document_fields, number
from agvctl.controllers.ranges import (
    MAX_ACCEL_M_S2,
    MAX_DISTANCE_M,
    MAX_WHEEL_SPEED_M_S,
    MIN_ACCEL_M_S2,
    MIN_WHEEL_SPEED_M_S,
)
from agvctl.params import VehicleParams
from agvctl.planning import BodyLimits, PathLimits, PathSpec, StartPose, plan
from agvctl.planning.reference import Reference
from agvctl.planning.spec import LineSegment, Segment, TurnSegment

__all__ = ["BACKING_STEP_M", "BACKING_STEPS", "Docking", "DockingConfig", "EndOfPath", "backing_steps"]

BACKING_STEP_M = 0.05
"""The backing distance comes in steps of 5 cm, so that each path has a finite set of manoeuvres, which a controller
without an online planner (the generated C) plans ahead (``docs/decisions/0043-the-mpc-qp-in-c.md``)."""
BACKING_STEPS = (3, 10)
"""The fewest and the most steps: 0.15 m and 0.5 m."""


def backing_steps(lateral_m: float) -> int:
    """How many :data:`BACKING_STEP_M` to back up for an error ``lateral_m`` across the last drive: twenty times the
    error (a heading change of about 2·e/L suffices), rounded up to a step, within :data:`BACKING_STEPS`.

    Parameters
    ----------
    lateral_m : float
        The error's size, m (finite, at least 0).

    Returns
    -------
    int
        The steps.
    """
    fewest, most = BACKING_STEPS
    steps = math.ceil(20.0 * lateral_m / BACKING_STEP_M - 1e-9)
    return most if most < steps else (fewest if fewest > steps else steps)


@document_fields
@dataclass(frozen=True)
class DockingConfig:
    """When and how to dock (SI units): an experiment file's ``[controller.docking]`` table."""

    enabled: bool = True
    """Stopped beside the end of the path, back up and come in again."""
    tolerance_m: float = number(
        gt=0,
        le=MAX_DISTANCE_M,
        default=0.008,
        doc="The error at rest across the path's last drive (where the path ends with turns in place, the distance "
        "from its end point) beyond which to dock, m.",
    )
    speed_m_s: float = number(
        ge=MIN_WHEEL_SPEED_M_S,
        le=MAX_WHEEL_SPEED_M_S,
        default=0.15,
        doc="The wheel-speed limit the manoeuvre is planned at, m/s.",
    )
    accel_m_s2: float = number(
        ge=MIN_ACCEL_M_S2,
        le=MAX_ACCEL_M_S2,
        default=0.3,
        doc="The wheel-acceleration limit the manoeuvre is planned at (at most the path's own), m/s².",
    )
    max_deviation_m: float = number(
        gt=0,
        le=MAX_DISTANCE_M,
        default=0.01,
        doc="δ, the largest distance from the arc of a curved final segment that backing up straight may reach, m.",
    )
    attempts: int = number(ge=0, le=100, default=2, doc="The most manoeuvres in one run (0: never dock; at most 100).")
    uncertainty_sigmas: float = number(ge=0, le=10.0, default=2.0)
    """The standard deviations of the pose estimate counted against the tolerance. On an estimated pose, the error
    that decides is the estimated one plus this many standard deviations of the estimate along the same direction: a
    vehicle docks when it may be beyond ``tolerance_m``, not only when its estimate says so (an estimate 2σ off is
    one run in 40). With a perfect estimate (σ = 0) it changes nothing."""

    def __post_init__(self) -> None:
        check_fields(self)


class Docking:
    """Decides on and plans the docking manoeuvre for one reference (see the module notes).

    The controller tells it the reference (:meth:`reset`) and, on an estimated pose, the estimate's covariance each
    sample (:meth:`observe`); :meth:`needed` and :meth:`plan` then decide for a vehicle at rest.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's vehicle, which the manoeuvre is planned for.
    config : DockingConfig or None
        When and how to dock (None: the defaults).
    """

    def __init__(self, vehicle: VehicleParams, config: DockingConfig | None = None) -> None:
        self.vehicle = vehicle
        self.config = config if config is not None else DockingConfig()
        self._end = np.zeros(3)
        self._drive_heading_rad = 0.0
        self._direction = 1.0
        self._curvature_1_m = 0.0
        self._last_length_m = 0.0
        self._left = 0
        self._covariance = np.zeros((3, 3))
        self._accel_m_s2 = self.config.accel_m_s2
        self._body = BodyLimits()
        self._body_plan_share = 1.0

    def observe(self, covariance: NDArray[np.float64]) -> None:
        """The pose estimate's 3×3 covariance (m², m rad, rad²) at this sample; zero (the default) for a known pose."""
        self._covariance = np.asarray(covariance, dtype=np.float64)

    def _sigma_m(self, direction_rad: float) -> float:
        """The estimate's standard deviation (m) along the unit vector at ``direction_rad``."""
        n = np.array([math.cos(direction_rad), math.sin(direction_rad)])
        return math.sqrt(max(float(n @ self._covariance[:2, :2] @ n), 0.0))

    def reset(self, reference: Reference) -> None:
        """Start a run on ``reference``: where its last drive ends, its heading there and the turns after it."""
        self._covariance = np.zeros((3, 3))
        self._accel_m_s2 = min(self.config.accel_m_s2, reference.limits.wheel_accel_m_s2)
        self._body = reference.limits.body  # the manoeuvre keeps the path's limits on the body's motion too
        self._body_plan_share = reference.limits.body_plan_share
        path_motions = [m for m in reference.motions if m.kind == "path"]
        self._left = self.config.attempts if path_motions else 0
        if not path_motions:
            return
        last = path_motions[-1]
        end = reference.final_pose
        self._end = np.array([end.x_m, end.y_m, end.theta_rad])
        self._drive_heading_rad = last.end_pose.theta_rad
        self._direction = 1.0 if last.direction >= 0 else -1.0
        s = reference.sample([last.t_start_s, last.t_end_s, max(last.t_start_s, last.t_end_s - 0.2)])
        self._last_length_m = float(s.path_length_m[1] - s.path_length_m[0])
        self._curvature_1_m = float(s.curvature_1_m[2])

    @property
    def constants(self) -> dict[str, float]:
        """What deciding on a manoeuvre takes for the present path (what a generated controller takes): whether it
        is enabled, the attempts, the tolerance and the sigmas counted, the path's end pose, its last drive's
        heading, and the heading the turns after it leave (rad)."""
        c = self.config
        return {
            "docking_enabled": float(c.enabled),
            "docking_attempts": float(self._left),
            "docking_tolerance_m": c.tolerance_m,
            "docking_sigmas": c.uncertainty_sigmas,
            "docking_end_x": float(self._end[0]),
            "docking_end_y": float(self._end[1]),
            "docking_heading": self._drive_heading_rad,
            "docking_turned": self._turned_rad(),
        }

    def lateral_error_m(self, pose: NDArray[np.float64]) -> float:
        """The pose's offset across the heading of the path's last drive at its end (m, positive to the left)."""
        x, y, theta = self._end[0], self._end[1], self._drive_heading_rad
        return float(-math.sin(theta) * (pose[0] - x) + math.cos(theta) * (pose[1] - y))

    def along_error_m(self, pose: NDArray[np.float64]) -> float:
        """The pose's offset along the heading of the path's last drive from its end (m, positive beyond it)."""
        x, y, theta = self._end[0], self._end[1], self._drive_heading_rad
        return float(math.cos(theta) * (pose[0] - x) + math.sin(theta) * (pose[1] - y))

    def _turned_rad(self) -> float:
        """The heading the turns in place after the last drive leave, relative to the drive's, the short way round
        (rad): a full turn in place leaves the vehicle facing along the drive again."""
        return wrap_angle(float(self._end[2]) - self._drive_heading_rad)

    def needed(self, pose: NDArray[np.float64]) -> bool:
        """Whether a vehicle at rest at ``pose`` should dock: attempts left, and an error that may be beyond tolerance
        (the estimated error plus ``uncertainty_sigmas`` of the estimate in the same direction, :meth:`observe`)
        across the last drive, or, where the path ends with turns in place, in the distance from the end point
        (then the vehicle no longer faces along the drive and can remove neither the error across it nor the one
        along it by moving along its heading)."""
        if self._left <= 0:
            return False
        c, theta = self.config, self._drive_heading_rad
        lateral = self.lateral_error_m(pose)
        if abs(self._turned_rad()) <= 1e-6:
            return abs(lateral) + c.uncertainty_sigmas * self._sigma_m(theta + 0.5 * math.pi) > c.tolerance_m
        along = self.along_error_m(pose)
        direction = theta + math.atan2(lateral, along)  # of the error, in the world frame
        return math.hypot(lateral, along) + c.uncertainty_sigmas * self._sigma_m(direction) > c.tolerance_m

    def plan(self, pose: NDArray[np.float64]) -> Reference | None:
        """The manoeuvre for a vehicle at ``pose`` (and count the attempt), or None when it cannot help."""
        if not self.needed(pose):
            return None
        self._left -= 1
        return self.manoeuvre(backing_steps(abs(self.lateral_error_m(pose))))

    def distance_m(self, steps: int) -> float:
        """The distance to back up along the last drive for ``steps`` of :data:`BACKING_STEP_M`, within 0.8 of the
        drive's length and, where the path ends on a curve, within ``max_deviation_m`` of its arc, m."""
        distance = min(steps * BACKING_STEP_M, 0.8 * self._last_length_m)
        if abs(self._curvature_1_m) > 1e-9:
            distance = min(distance, math.sqrt(2.0 * self.config.max_deviation_m / abs(self._curvature_1_m)))
        return distance

    def manoeuvre(self, steps: int) -> Reference | None:
        """The manoeuvre that backs up ``steps`` of :data:`BACKING_STEP_M` (:meth:`distance_m`), or None where that
        is under 5 cm (it cannot help)."""
        c, distance = self.config, self.distance_m(steps)
        if distance < 0.05:
            return None
        x, y, theta = self._end
        turned_deg = math.degrees(self._turned_rad())  # undone and turned again the short way round
        back = -self._direction * distance
        segments: list[Segment] = [LineSegment(length_m=back), LineSegment(length_m=-back)]
        if abs(turned_deg) > 1e-6:
            segments = [TurnSegment(angle_deg=-turned_deg), *segments, TurnSegment(angle_deg=turned_deg)]
        spec = PathSpec(
            segments=tuple(segments),
            name="docking",
            start=StartPose(x_m=float(x), y_m=float(y), theta_deg=math.degrees(float(theta))),
            limits=PathLimits(
                wheel_speed_m_s=c.speed_m_s,
                wheel_accel_m_s2=self._accel_m_s2,
                body_plan_share=self._body_plan_share,
                **dataclasses.asdict(self._body),
            ),
            join="stop",
        )
        return plan(spec, self.vehicle)


class EndOfPath:
    """Where a tracking controller stands on its references: the path, then any docking manoeuvres, and whether it
    is done with them.

    The path's clock runs from 0; a manoeuvre's clock from the sample after it was planned. At the end of the
    current reference, a vehicle at rest beside the path's end starts a manoeuvre (while attempts last; also after
    being done, if it is pushed off), one still moving is decided on once it rests, and one within tolerance is done.

    Parameters
    ----------
    docking : Docking
        Decides on and plans the manoeuvres.
    sample_period_s : float
        The control sample period T_s, s: a manoeuvre starts one sample after the step that plans it.
    """

    def __init__(self, docking: Docking, sample_period_s: float) -> None:
        self.docking = docking
        self.sample_period_s = sample_period_s
        self.path_duration_s = 0.0
        self.current_duration_s = 0.0
        self.time_offset_s = 0.0
        """The loop time at which the current reference's t = 0 lies (0 on the path itself)."""
        self.done = False

    @property
    def on_path(self) -> bool:
        """Whether the current reference is the path itself (no manoeuvre has started)."""
        return self.time_offset_s == 0.0

    def reset(self, reference: Reference) -> None:
        """Start on the path ``reference``."""
        self.path_duration_s = self.current_duration_s = reference.duration_s
        self.time_offset_s = 0.0
        self.done = False
        self.docking.reset(reference)

    def local_time_s(self, t_s: float) -> float:
        """The loop time ``t_s`` on the current reference."""
        return max(t_s - self.time_offset_s, 0.0)

    def after_step(
        self, t_s: float, reference_time_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]
    ) -> Reference | None:
        """After the step at ``t_s`` with the clock at ``reference_time_s`` on the current reference: the manoeuvre
        to track from the next sample on, or None (go on, or done)."""
        if reference_time_s < self.current_duration_s - 1e-9:
            return None
        if not (self.docking.config.enabled and self.docking.needed(pose)):
            self.done = True
            return None
        if max(abs(float(wheel_speed_m_s[0])), abs(float(wheel_speed_m_s[1]))) > 0.01:
            return None  # still moving: decide at rest
        manoeuvre = self.docking.plan(pose)
        if manoeuvre is None:
            self.done = True
            return None
        self.done = False
        self.current_duration_s = manoeuvre.duration_s
        self.time_offset_s = t_s + self.sample_period_s  # the manoeuvre's t = 0 is the next sample
        return manoeuvre
