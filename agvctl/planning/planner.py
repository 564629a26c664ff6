"""The offline planner: a path file's geometry → a time-optimal, wheel-limited :class:`Reference`.

Joining rule (``join = "smooth"``, the default): the reference stops only where the direction of travel
reverses, at a turn in place, and at the end. Where the curvature changes between consecutive lines and arcs,
a smooth join (:mod:`agvctl.planning.joins`) replaces the corner, so the wheel speeds, accelerations and jerks
stay continuous or bounded while driving through. A waypoint path (:mod:`agvctl.planning.waypoints`) is one
motion. The speed along each motion is planned by :mod:`agvctl.planning.speed`: a velocity limit per
section, forward and backward passes, and one Ruckig profile per section.

``join = "stop"`` keeps the earlier rule: the reference stops wherever the curvature or the direction of
travel changes; consecutive segments with the same curvature, direction and speed cap form one motion, one
rest-to-rest Ruckig profile whose limits are the wheel limits divided by 1 + |κ| b/2 (b/2 for a turn).

A failure to plan (Ruckig, or a pass) is one line naming the segment or waypoint: a
:class:`~agvctl.errors.PlanningError` from :func:`plan_segments`, a :class:`~agvctl.errors.ConfigError`
naming the file too from :func:`plan`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np

from agvctl.errors import ConfigError, PlanningError, expect_instance
from agvctl.params import VehicleParams, load_vehicle
from agvctl.planning.arguments import (
    MAX_DURATION_S,
    check_arguments,
    check_drawn_path,
    check_extent,
    check_reference,
    check_tolerance,
)
from agvctl.planning.curve import Curve
from agvctl.planning.drawn import DrawnPath
from agvctl.planning.geometry import Pose, segment_kinematics
from agvctl.planning.join_runs import _Designed, _Part, _runs
from agvctl.planning.joins import JoinWindow
from agvctl.planning.limits import resolve_limits
from agvctl.planning.motion import PlanFailure, motion_starts, path_motion
from agvctl.planning.profile import _Solver, rest_to_rest
from agvctl.planning.reference import Motion, Reference
from agvctl.planning.spec import DRAWN_PATH_TOLERANCE_M, PathSpec, Segment, WheelLimits, load_path
from agvctl.planning.speed import section_limits
from agvctl.planning.waypoint_plan import plan_waypoints, waypoints_reference

__all__ = ["MAX_DURATION_S", "plan", "plan_file", "plan_segments", "plan_waypoints"]

Join = Literal["smooth", "stop"]


def plan(spec: PathSpec, vehicle: VehicleParams | None = None, *, force: bool = False) -> Reference:
    """Plan the reference of a path for a vehicle.

    The path's limits are resolved against the vehicle (see :func:`~agvctl.planning.limits.resolve_limits`).

    Parameters
    ----------
    spec : PathSpec
        The path, from :func:`~agvctl.planning.load_path` or built in code.
    vehicle : VehicleParams or None
        Whose wheel separation, sample period and limits apply; None: the shipped IAU AGV.
    force : bool
        Turn a physically impossible limit from an error into a warning.

    Returns
    -------
    Reference
        The time-optimal, jerk-limited reference: sampled anywhere by ``.sample(t_s)``, on the control grid by
        ``.grid``.

    Raises
    ------
    ConfigError
        One line naming the file and the segment or waypoint: a failure to plan (numerical ones included), a
        limit above the physical one without ``force``, a reference longer than :data:`MAX_DURATION_S`; or naming
        ``limits.drawn_path_tolerance_m``, a planned path that would leave the drawn one by more.

    Examples
    --------
    >>> from agvctl.planning import load_path
    >>> reference = plan(load_path("trajectories/square.toml"))
    >>> print(f"{reference.duration_s:.1f} s, {reference.path_length_m:.1f} m")
    25.1 s, 8.0 m
    >>> print(f"{reference.peaks()['peak_wheel_speed_m_s']:.3f} m/s")  # the file's wheel speed limit binds
    0.800 m/s
    """
    expect_instance(spec, PathSpec, "plan", "spec")
    if vehicle is not None:
        expect_instance(vehicle, VehicleParams, "plan", "vehicle")
    vehicle = vehicle if vehicle is not None else load_vehicle()
    limits = resolve_limits(spec, vehicle, force=force)
    check_extent(
        spec.segments,
        spec.waypoints,
        limits,
        vehicle.wheels.separation_m,
        vehicle.control.sample_period_s,
        spec.source,
    )
    common = {
        "limits": limits,
        "separation_m": vehicle.wheels.separation_m,
        "sample_period_s": vehicle.control.sample_period_s,
        "name": spec.name,
        "drawn_path_tolerance_m": spec.limits.drawn_path_tolerance_m,
    }
    try:
        if spec.waypoints:
            reference = waypoints_reference(spec.waypoints, source=spec.source, **common)  # type: ignore[arg-type]
        else:
            start = Pose.from_start(spec.start)
            reference = _segments_reference(spec.segments, start_pose=start, join=spec.join, **common)  # type: ignore[arg-type]
    except PlanFailure as exc:
        raise ConfigError(spec.source, exc.key, exc.problem) from None
    except ConfigError:
        raise
    except (ValueError, ArithmeticError) as exc:  # a numerical failure no validation foresaw: still one line
        key = "waypoints" if spec.waypoints else "segments"
        raise ConfigError(spec.source, key, f"cannot be planned: {exc}") from None
    check_reference(reference, spec.source, "waypoints" if spec.waypoints else "segments")
    check_drawn_path(reference, spec.source, "limits.drawn_path_tolerance_m")
    return reference


def plan_file(path: str | Path, vehicle: VehicleParams | None = None, *, force: bool = False) -> Reference:
    """Plan the reference of a path file: :func:`~agvctl.planning.load_path` then :func:`plan`.

    Parameters
    ----------
    path : str or Path
        The path file (TOML).
    vehicle : VehicleParams or None
        Whose wheel separation, sample period and limits apply; None: the shipped IAU AGV.
    force : bool
        Turn a physically impossible limit from an error into a warning.

    Returns
    -------
    Reference
        The planned reference.

    Raises
    ------
    ConfigError
        The file's problem, or a failure to plan, in one line naming the file and key.
    """
    return plan(load_path(path), vehicle, force=force)


def _groups(segments: Sequence[Segment], join: Join) -> list[tuple[str, int, list[_Part]]]:
    """Consecutive segments driven without stopping: ``(kind, direction, parts)``."""
    groups: list[tuple[str, int, list[_Part]]] = []
    for i, seg in enumerate(segments):
        kind, distance, curvature, direction = segment_kinematics(seg)
        part = (i, distance, curvature, seg.speed_m_s)
        if groups:
            g_kind, g_dir, parts = groups[-1]
            last = parts[-1]
            same = (kind, direction) == (g_kind, g_dir)
            if kind == "spin" or join == "stop":
                same = same and (curvature, seg.speed_m_s) == (last[2], last[3])
            if same:
                parts.append(part)
                continue
        groups.append((kind, direction, [part]))
    return groups


def plan_segments(
    segments: Sequence[Segment],
    *,
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    start_pose: Pose | None = None,
    name: str = "path",
    join: Join = "smooth",
    drawn_path_tolerance_m: float = DRAWN_PATH_TOLERANCE_M,
) -> Reference:
    """Plan segments with explicit limits and geometry (no vehicle file): the core of :func:`plan`.

    Parameters
    ----------
    segments : sequence of LineSegment, TurnSegment or ArcSegment
        The segments, driven in order.
    limits : WheelLimits
        The wheel limits.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The control sample period of the reference's grid, s.
    start_pose : Pose or None
        Where the first segment starts; None: the origin, heading along x.
    name : str
        The reference's name.
    join : {'smooth', 'stop'}
        ``"smooth"`` drives through curvature changes, ``"stop"`` stops at each.
    drawn_path_tolerance_m : float
        The largest distance from a point of the planned path to the segments' lines and arcs, m (a path file's
        ``limits.drawn_path_tolerance_m``).

    Returns
    -------
    Reference
        The planned reference.

    Raises
    ------
    ConfigError
        ``plan_segments: <argument>: <problem>``: no segment or more than :data:`~agvctl.planning.spec.MAX_SEGMENTS`,
        a segment of zero length or angle, ``join`` not ``"smooth"`` or ``"stop"``, ``separation_m`` or
        ``sample_period_s`` not finite and > 0, or a reference longer than :data:`MAX_DURATION_S` or of more than
        :data:`~agvctl.params.schema.MAX_SAMPLES_PER_RUN` samples, ``drawn_path_tolerance_m`` not finite and at
        least :data:`~agvctl.planning.spec.MIN_DRAWN_PATH_TOLERANCE_M`.
    PlanningError
        One line naming the segment (``segments[i]: …``) if a motion cannot be planned.
    """
    check_arguments(segments, join, separation_m, sample_period_s)
    check_tolerance("plan_segments", drawn_path_tolerance_m)
    expect_instance(limits, WheelLimits, "plan_segments", "limits")
    check_extent(segments, (), limits, separation_m, sample_period_s, "plan_segments")
    reference = _segments_reference(
        segments,
        limits=limits,
        separation_m=separation_m,
        sample_period_s=sample_period_s,
        start_pose=start_pose,
        name=name,
        join=join,
        drawn_path_tolerance_m=drawn_path_tolerance_m,
    )
    check_reference(reference, "plan_segments", "segments")
    check_drawn_path(reference, "plan_segments", "drawn_path_tolerance_m")
    return reference


def _segments_reference(
    segments: Sequence[Segment],
    *,
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    start_pose: Pose | None = None,
    name: str = "path",
    join: Join = "smooth",
    drawn_path_tolerance_m: float = DRAWN_PATH_TOLERANCE_M,
) -> Reference:
    """:func:`plan_segments` of arguments checked already."""
    half_b = 0.5 * separation_m
    pose = start_pose if start_pose is not None else Pose(0.0, 0.0, 0.0)
    solver = _Solver()
    designed: _Designed = {}
    motions: list[Motion] = []
    t, deviation = 0.0, 0.0
    for kind, direction, parts in _groups(segments, join):
        try:
            if kind == "spin":
                new = [_spin(parts, direction, pose, t, limits, half_b, solver)]
            else:
                new, dev = _paths(parts, direction, pose, t, limits, half_b, solver, designed, drawn_path_tolerance_m)
                deviation = max(deviation, dev)
        except PlanFailure:
            raise
        except (PlanningError, ValueError, ArithmeticError) as exc:
            raise PlanFailure(f"segments[{parts[0][0]}]", f"cannot be planned: {exc}") from None
        motions += new
        t, pose = new[-1].t_end_s, new[-1].end_pose
    reference = Reference(
        name=name,
        motions=motions,
        limits=limits,
        separation_m=separation_m,
        sample_period_s=sample_period_s,
        start_pose=motions[0].start_pose,
        segment_count=len(segments),
        drawn_path_deviation_m=deviation,
        drawn_path_tolerance_m=drawn_path_tolerance_m,
        drawn_path=DrawnPath.of_segments(segments, motions[0].start_pose),
    )
    return reference


def _spin(
    parts: list[_Part], direction: int, pose: Pose, t: float, limits: WheelLimits, half_b: float, solver: _Solver
) -> Motion:
    distance = sum(p[1] for p in parts)
    cap = parts[0][3]
    v = limits.wheel_speed_m_s if cap is None else min(cap, limits.wheel_speed_m_s)
    body = limits.planned_body  # a turn in place moves the body only about its axle's midpoint: ω and dω/dt
    w_max, alpha_max = body.angular_speed_rad_s, body.angular_accel_rad_s2
    profile = rest_to_rest(
        distance,
        max_velocity=v / half_b if w_max is None else min(v / half_b, w_max),
        max_acceleration=limits.wheel_accel_m_s2 / half_b
        if alpha_max is None
        else min(limits.wheel_accel_m_s2 / half_b, alpha_max),
        max_jerk=limits.wheel_jerk_m_s3 / half_b,
        solver=solver,
    )
    end = Pose(pose.x_m, pose.y_m, pose.theta_rad + direction * distance)
    return Motion(
        kind="spin",
        segment_indices=tuple(p[0] for p in parts),
        t_start_s=t,
        start_pose=pose,
        end_pose=end,
        direction=direction,
        profiles=(profile,),
        section_starts=(0.0,),
        segment_starts=motion_starts([p[1] for p in parts]),
    )


def _paths(
    parts: list[_Part],
    direction: int,
    pose: Pose,
    t: float,
    limits: WheelLimits,
    half_b: float,
    solver: _Solver,
    designed: _Designed,
    max_deviation_m: float,
) -> tuple[list[Motion], float]:
    """The motions of a run of lines and arcs: one, or several where a join is not worth driving; and the largest
    distance of its joins from the corners they replace (at most ``max_deviation_m``)."""
    motions: list[Motion] = []
    deviation = 0.0
    for lo, hi, windows in _runs(parts, limits, half_b, designed, max_deviation_m):
        new, dev = _path(parts[lo:hi], windows, direction, pose, t, limits, half_b, solver)
        motions += new
        deviation = max(deviation, dev)
        pose, t = new[-1].end_pose, new[-1].t_end_s
    return motions, deviation


def _path(
    parts: list[_Part],
    windows: list[JoinWindow | None],
    direction: int,
    pose: Pose,
    t: float,
    limits: WheelLimits,
    half_b: float,
    solver: _Solver,
) -> tuple[list[Motion], float]:
    lengths: list[float] = []
    coeffs: list[list[float]] = []
    sections: list[tuple[float, tuple[float, float, float], float | None, int]] = []
    cut_left = 0.0
    for k, (index, distance, curvature, cap) in enumerate(parts):
        w = windows[k]
        cut_right = 0.5 * w.length_m if w is not None else 0.0
        straight = distance - cut_left - cut_right
        if straight > 1e-12 * distance:
            lengths.append(straight)
            coeffs.append([curvature])
            last = sections[-1] if sections else None
            if last is not None and last[1] == (abs(curvature), 0.0, 0.0) and last[2] == cap:
                sections[-1] = (last[0] + straight, last[1], cap, last[3])
            else:
                sections.append((straight, (abs(curvature), 0.0, 0.0), cap, index))
        if w is not None:
            lengths.append(w.length_m)
            coeffs.append(list(w.coeffs))
            caps = [c for c in (cap, parts[k + 1][3]) if c is not None]
            sections.append((w.length_m, w.bounds, min(caps) if caps else None, parts[k + 1][0]))
        cut_left = cut_right
    curve = Curve(pose, lengths, _pad(coeffs), direction=direction)
    limits_s = [section_limits(d, b, c, limits, half_b) for d, b, c, _ in sections]
    motion = path_motion(
        curve,
        limits_s,
        [s[3] for s in sections],
        "segments",
        solver,
        t,
        tuple(p[0] for p in parts),
        motion_starts([p[1] for p in parts]),
    )
    deviation = max((w.deviation_m for w in windows if w is not None), default=0.0)
    return [motion], deviation


def _pad(rows: list[list[float]]) -> np.ndarray:
    width = max(len(r) for r in rows)
    return np.array([r + [0.0] * (width - len(r)) for r in rows])
