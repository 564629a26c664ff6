"""The offline planner: a path file's geometry → a time-optimal, wheel-limited :class:`Reference`.

Joining rule: the reference **stops wherever the curvature or the direction of travel changes** (line → arc,
arc → turn, left arc → right arc, forward → reverse), because the wheel speeds v = U(1 ± κ b/2) cannot jump
while U ≠ 0. Consecutive segments with the same curvature, direction and speed cap form one *motion* driven
without stopping. Each motion is one rest-to-rest Ruckig profile of a single coordinate q (distance for a
line or an arc, heading for a turn) whose limits are the wheel limits mapped through the curvature:

    path:  |v_l|, |v_r| = |U| (1 ± κ b/2)  ⇒  q̇_max = v_wheel / (1 + |κ| b/2)  (same for q̈, q⃛)
    spin:  |v_l| = |v_r| = |ω| b/2         ⇒  q̇_max = v_wheel / (b/2)

so each motion is time-optimal for itself and every wheel limit holds everywhere, joins included (both wheels
are at rest there). Why one coordinate rather than the two wheels as phase-synchronised Ruckig degrees of
freedom: both give the same durations (the wheel profiles are scaled copies of one another), and the single
coordinate is about twice as fast to compute and keeps the path exactly on its geometry by construction; see
``experiments/benchmarks/planning.py`` for the measurement.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import NoReturn

from agvctl.errors import ConfigError, PlanningError
from agvctl.params import VehicleParams, load_vehicle
from agvctl.planning.geometry import Pose, advance, segment_kinematics
from agvctl.planning.profile import _Solver, rest_to_rest
from agvctl.planning.reference import Motion, Reference
from agvctl.planning.spec import LineSegment, PathSpec, Segment, WheelLimits, load_path, resolve_limits

__all__ = ["MAX_DURATION_S", "plan", "plan_file", "plan_segments"]

MAX_DURATION_S = 24 * 3600.0
"""The longest reference planned (one day): a longer one is a typing error, not a drive, and its samples would
not fit in memory."""


def plan(spec: PathSpec, vehicle: VehicleParams | None = None, *, force: bool = False) -> Reference:
    """Plan the reference of a path for a vehicle (default: the shipped IAU AGV).

    The path's limits are resolved against the vehicle (see :func:`~agvctl.planning.spec.resolve_limits`;
    ``force`` turns a physically impossible limit from an error into a warning).
    """
    vehicle = vehicle if vehicle is not None else load_vehicle()
    limits = resolve_limits(spec, vehicle, force=force)
    return plan_segments(
        spec.segments,
        limits=limits,
        separation_m=vehicle.wheels.separation_m,
        sample_period_s=vehicle.control.sample_period_s,
        start_pose=Pose.from_start(spec.start),
        name=spec.name,
        source=spec.source,
    )


def plan_file(path: str | Path, vehicle: VehicleParams | None = None, *, force: bool = False) -> Reference:
    """:func:`~agvctl.planning.spec.load_path` then :func:`plan`."""
    return plan(load_path(path), vehicle, force=force)


def plan_segments(
    segments: Sequence[Segment],
    *,
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    start_pose: Pose | None = None,
    name: str = "path",
    source: str = "<segments>",
) -> Reference:
    """Plan segments with explicit limits and geometry (no vehicle file): the core of :func:`plan`.

    ``start_pose`` defaults to the origin, heading along x. A segment that cannot be planned (a reference
    longer than :data:`MAX_DURATION_S`, or a geometry the solver cannot resolve numerically) raises a one-line
    :class:`ConfigError` naming ``source`` and the segment's key.
    """
    if not segments:
        raise ValueError("plan_segments: at least one segment is required")
    half_b = 0.5 * separation_m
    start_pose = start_pose if start_pose is not None else Pose(0.0, 0.0, 0.0)
    solver = _Solver()

    # group consecutive segments that can be driven without stopping
    runs: list[tuple[str, float, int, float | None, float, list[int]]] = []
    for i, seg in enumerate(segments):
        kind, distance, curvature, direction = segment_kinematics(seg)
        cap = seg.speed_m_s
        if runs:
            r_kind, r_curv, r_dir, r_cap, r_dist, r_idx = runs[-1]
            if (kind, curvature, direction, cap) == (r_kind, r_curv, r_dir, r_cap):
                runs[-1] = (r_kind, r_curv, r_dir, r_cap, r_dist + distance, [*r_idx, i])
                continue
        runs.append((kind, curvature, direction, cap, distance, [i]))

    motions: list[Motion] = []
    t, pose = 0.0, start_pose
    for kind, curvature, direction, cap, distance, indices in runs:
        if kind == "path":
            factor = 1.0 + abs(curvature) * half_b
            v_max = limits.wheel_speed_m_s / factor
            if cap is not None:
                v_max = min(v_max, cap)  # the cap is on the path speed U
        else:
            factor = half_b
            v_max = (limits.wheel_speed_m_s if cap is None else min(cap, limits.wheel_speed_m_s)) / factor
        where = _motion_key(segments, indices)
        if not distance <= v_max * (MAX_DURATION_S - t):  # at least distance / v_max: too long for the solver too
            _too_long(f"at least {t + distance / v_max if v_max > 0 else math.inf:.4g}", source, where)
        try:
            if kind == "path":
                end = advance(pose, displacement_m=direction * distance, curvature_1_m=curvature)
            else:
                end = Pose(pose.x_m, pose.y_m, pose.theta_rad + direction * distance)
            profile = rest_to_rest(
                distance,
                max_velocity=v_max,
                max_acceleration=limits.wheel_accel_m_s2 / factor,
                max_jerk=limits.wheel_jerk_m_s3 / factor,
                solver=solver,
            )
        except (PlanningError, ArithmeticError, ValueError) as exc:  # numerically out of reach
            raise ConfigError(source, where, f"cannot be planned within the wheel limits: {exc}") from None
        if not t + profile.duration_s <= MAX_DURATION_S:
            _too_long(f"{t + profile.duration_s:.4g}", source, where)
        motions.append(Motion(
            kind="path" if kind == "path" else "spin",
            segment_indices=tuple(indices),
            t_start_s=t,
            start_pose=pose,
            end_pose=end,
            curvature_1_m=curvature,
            direction=direction,
            wheel_factor=factor,
            profile=profile,
        ))
        t += profile.duration_s
        pose = end
    return Reference(
        name=name,
        motions=motions,
        limits=limits,
        separation_m=separation_m,
        sample_period_s=sample_period_s,
        start_pose=start_pose,
        segment_count=len(segments),
    )


def _motion_key(segments: Sequence[Segment], indices: list[int]) -> str:
    """The key an error about one motion names: ``segments[3].length_m``, or ``segments[3-5].angle_deg`` for
    segments driven as one motion."""
    first, last = indices[0], indices[-1]
    field = "length_m" if isinstance(segments[first], LineSegment) else "angle_deg"
    return f"segments[{first}].{field}" if first == last else f"segments[{first}-{last}].{field}"


def _too_long(duration: str, source: str, where: str) -> NoReturn:
    raise ConfigError(source, where, f"the reference would last {duration} s, above the maximum {MAX_DURATION_S:g} s")
