"""A path motion from a curve and its speed sections: the speed planned along it (:mod:`agvctl.planning.speed`),
and a failure to plan named by the file key it belongs to."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from agvctl.errors import PlanningError
from agvctl.planning.curve import Curve
from agvctl.planning.geometry import Pose
from agvctl.planning.profile import _Solver
from agvctl.planning.reference import Motion
from agvctl.planning.speed import SectionLimits, plan_speed

__all__ = ["PlanFailure", "motion_starts", "path_motion"]


class PlanFailure(PlanningError):
    """A planning failure with the file key it belongs to.

    Parameters
    ----------
    key : str
        The key, ``segments[i]`` or ``waypoints[i]``.
    problem : str
        What could not be planned.
    """

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}")
        self.key, self.problem = key, problem


def motion_starts(lengths: Sequence[float]) -> tuple[float, ...]:
    """Where each of consecutive pieces starts.

    Parameters
    ----------
    lengths : sequence of float
        The pieces' lengths, m.

    Returns
    -------
    tuple of float
        Each piece's start, from the first's start, m.
    """
    return tuple(float(x) for x in np.concatenate(([0.0], np.cumsum(lengths)[:-1])))


def path_motion(
    curve: Curve,
    sections: list[SectionLimits],
    owners: list[int],
    key: str,
    solver: _Solver,
    t: float,
    segment_indices: tuple[int, ...],
    segment_starts: tuple[float, ...],
) -> Motion:
    """Plan the speed along a curve and wrap it as a path motion.

    Parameters
    ----------
    curve : Curve
        The motion's geometry.
    sections : list of SectionLimits
        The limits of the path coordinate on each section of the curve, in order.
    owners : list of int
        The index of the segment (or waypoint) each section belongs to, for errors.
    key : str
        ``"segments"`` or ``"waypoints"``, for errors.
    solver : _Solver
        The Ruckig instance, reused from call to call.
    t : float
        When the motion starts on the reference, s.
    segment_indices : tuple of int
        The path's segments the motion drives.
    segment_starts : tuple of float
        Where each of them starts along the curve, m.

    Returns
    -------
    Motion
        The path motion.

    Raises
    ------
    PlanFailure
        A section's speed cannot be planned, naming the key of the segment it belongs to.
    """
    try:
        profiles, _ = plan_speed(sections, solver=solver)
    except PlanningError as exc:
        k = exc.args[1] if len(exc.args) > 1 else 0
        raise PlanFailure(f"{key}[{owners[k]}]", f"cannot be planned: {exc.args[0]}") from None
    start = curve.evaluate([0.0])
    pose = Pose(float(start.x_m[0]), float(start.y_m[0]), float(start.theta_rad[0]))
    return Motion(
        kind="path",
        segment_indices=segment_indices,
        t_start_s=t,
        start_pose=pose,
        end_pose=curve.end_pose(),
        direction=curve.direction,
        profiles=tuple(profiles),
        section_starts=motion_starts([s.length_m for s in sections]),
        segment_starts=segment_starts,
        curve=curve,
    )
