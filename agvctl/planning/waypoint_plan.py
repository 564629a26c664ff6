"""Planning a waypoint path (:mod:`agvctl.planning.waypoints`): one motion, its speed planned on sections of a few
curve pieces."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from agvctl.errors import ConfigError, expect_instance
from agvctl.planning.arguments import check_drawn_path, check_extent, check_geometry, check_reference, check_tolerance
from agvctl.planning.curve import Curve
from agvctl.planning.motion import PlanFailure, path_motion
from agvctl.planning.profile import _Solver
from agvctl.planning.reference import Reference
from agvctl.planning.spec import DRAWN_PATH_TOLERANCE_M, MAX_SEGMENTS, Waypoint, WheelLimits, check_waypoints
from agvctl.planning.speed import SectionLimits, section_limits
from agvctl.planning.waypoints import NODES_PER_SPAN, waypoint_curve

__all__ = ["WAYPOINT_SECTION_PIECES", "plan_waypoints"]

WAYPOINT_SECTION_PIECES = NODES_PER_SPAN
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
    drawn_path_tolerance_m: float = DRAWN_PATH_TOLERANCE_M,
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
    drawn_path_tolerance_m : float
        The largest distance allowed from a point of the planned path to the spline through the waypoints, m (a
        path file's ``limits.drawn_path_tolerance_m``).

    Returns
    -------
    Reference
        The planned reference.

    Raises
    ------
    ConfigError
        One line naming ``source``: bad waypoints, more than :data:`~agvctl.planning.spec.MAX_SEGMENTS` of them,
        ``separation_m`` or ``sample_period_s`` not finite and > 0, a reference too long or of too many samples,
        ``drawn_path_tolerance_m`` out of range or a planned path that leaves the spline by more.
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
    check_tolerance(source, drawn_path_tolerance_m)
    expect_instance(limits, WheelLimits, source, "limits")
    check_extent((), waypoints, limits, separation_m, sample_period_s, source)
    reference = waypoints_reference(
        waypoints,
        limits=limits,
        separation_m=separation_m,
        sample_period_s=sample_period_s,
        name=name,
        source=source,
        drawn_path_tolerance_m=drawn_path_tolerance_m,
    )
    check_reference(reference, source, "waypoints")
    check_drawn_path(reference, source, "drawn_path_tolerance_m")
    return reference


def waypoints_reference(
    waypoints: Sequence[Waypoint],
    *,
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    name: str,
    source: str,
    drawn_path_tolerance_m: float,
) -> Reference:
    """:func:`plan_waypoints` of arguments checked already, its reference not yet checked against its bounds."""
    shape = waypoint_curve(waypoints, source=source, max_deviation_m=drawn_path_tolerance_m)
    curve, s_i = shape.curve, shape.s_i
    sections, owners = _sections(curve, s_i, limits, 0.5 * separation_m, shape.pieces_per_span)
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
        drawn_path_deviation_m=shape.deviation_m,
        drawn_path_tolerance_m=drawn_path_tolerance_m,
        drawn_path=shape.drawn,
    )
    return reference


def _sections(
    curve: Curve, s_i: NDArray[np.float64], limits: WheelLimits, half_b: float, pieces_per_span: int
) -> tuple[list[SectionLimits], list[int]]:
    """The speed sections of a waypoint curve, one per knot span (half a waypoint interval: its
    :data:`WAYPOINT_SECTION_PIECES` pieces, more where the curve was refined), and the waypoint interval each
    starts in."""
    bounds = curve.piece_bounds()
    n = len(curve.lengths_m)
    sections, owners = [], []
    for lo in range(0, n, pieces_per_span):
        hi = min(n, lo + pieces_per_span)
        length = float(np.sum(curve.lengths_m[lo:hi]))
        sections.append(section_limits(length, tuple(np.max(bounds[lo:hi], axis=0)), None, limits, half_b))
        owners.append(int(np.searchsorted(s_i, curve.s0_m[lo], side="right")) - 1)
    return sections, owners
