"""Planning a waypoint path (:mod:`agvctl.planning.waypoints`): one motion, its speed planned on sections of a few
curve pieces."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from agvctl.errors import ConfigError, expect_instance
from agvctl.planning.arguments import check_extent, check_geometry, check_reference
from agvctl.planning.curve import Curve
from agvctl.planning.motion import PlanFailure, path_motion
from agvctl.planning.profile import _Solver
from agvctl.planning.reference import Reference
from agvctl.planning.spec import MAX_SEGMENTS, Waypoint, WheelLimits, check_waypoints
from agvctl.planning.speed import SectionLimits, section_limits
from agvctl.planning.waypoints import waypoint_curve

__all__ = ["WAYPOINT_SECTION_PIECES", "plan_waypoints"]

WAYPOINT_SECTION_PIECES = 8
"""Curve pieces per speed section of a waypoint path (half a waypoint interval): the speed limit of a section is
its pieces' tightest, and each section is one Ruckig profile (design record 0008)."""


def plan_waypoints(
    waypoints: Sequence[Waypoint],
    *,
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    name: str = "path",
    source: str = "<path>",
) -> Reference:
    """Plan a path through waypoints with explicit limits (no vehicle file): one motion, its speed planned on
    sections of :data:`WAYPOINT_SECTION_PIECES` curve pieces.

    Parameters
    ----------
    waypoints : sequence of Waypoint
        The points to pass through, at least two, the first the start.
    limits : WheelLimits
        The wheel limits.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The control sample period of the reference's grid, s.
    name : str
        The reference's name.
    source : str
        What errors name as the file.

    Returns
    -------
    Reference
        The planned reference.

    Raises
    ------
    ConfigError
        One line naming ``source``: bad waypoints, more than :data:`~agvctl.planning.spec.MAX_SEGMENTS` of them,
        ``separation_m`` or ``sample_period_s`` not finite and > 0, a reference too long or of too many samples.
    PlanningError
        One line naming the waypoint, if the path cannot be planned.
    """
    if len(waypoints) > MAX_SEGMENTS:
        raise ConfigError(source, "waypoints", f"at most {MAX_SEGMENTS} (got {len(waypoints)})")
    for i, point in enumerate(waypoints):
        if not isinstance(point, Waypoint):
            raise ConfigError(source, f"waypoints[{i}]", f"expected a Waypoint (got {point!r})")
    check_waypoints(waypoints, source)
    check_geometry(source, separation_m, sample_period_s)
    expect_instance(limits, WheelLimits, source, "limits")
    check_extent((), waypoints, limits, separation_m, sample_period_s, source)
    curve, s_i, deviation = waypoint_curve(waypoints, source=source)
    sections, owners = _sections(curve, s_i, limits, 0.5 * separation_m)
    try:
        motion = path_motion(
            curve,
            sections,
            owners,
            "waypoints",
            _Solver(),
            0.0,
            tuple(range(len(s_i) - 1)),
            tuple(float(s) for s in s_i[:-1]),
        )
    except (ValueError, ArithmeticError) as exc:
        raise PlanFailure("waypoints", f"cannot be planned: {exc}") from None
    reference = Reference(
        name=name,
        motions=[motion],
        limits=limits,
        separation_m=separation_m,
        sample_period_s=sample_period_s,
        start_pose=motion.start_pose,
        segment_count=len(s_i) - 1,
        geometry_deviation_m=deviation,
    )
    check_reference(reference, source, "waypoints")
    return reference


def _sections(
    curve: Curve, s_i: NDArray[np.float64], limits: WheelLimits, half_b: float
) -> tuple[list[SectionLimits], list[int]]:
    """The speed sections of a waypoint curve, :data:`WAYPOINT_SECTION_PIECES` pieces each, and the waypoint
    interval each starts in."""
    bounds = curve.piece_bounds()
    n = len(curve.lengths_m)
    sections, owners = [], []
    for lo in range(0, n, WAYPOINT_SECTION_PIECES):
        hi = min(n, lo + WAYPOINT_SECTION_PIECES)
        length = float(np.sum(curve.lengths_m[lo:hi]))
        sections.append(section_limits(length, tuple(np.max(bounds[lo:hi], axis=0)), None, limits, half_b))
        owners.append(int(np.searchsorted(s_i, curve.s0_m[lo], side="right")) - 1)
    return sections, owners
