"""The arguments of the planner's entry points, checked as a path file's are, and the bounds of a reference."""

from __future__ import annotations

import math
from collections.abc import Sequence

from agvctl.errors import ConfigError
from agvctl.params.schema import check_sample_count
from agvctl.planning.geometry import segment_kinematics
from agvctl.planning.reference import Reference
from agvctl.planning.spec import (
    MAX_SEGMENTS,
    MIN_DRAWN_PATH_TOLERANCE_M,
    ArcSegment,
    LineSegment,
    Segment,
    Waypoint,
    WheelLimits,
)

__all__ = [
    "MAX_DURATION_S",
    "MAX_REFERENCE_SAMPLES",
    "check_arguments",
    "check_drawn_path",
    "check_extent",
    "check_geometry",
    "check_reference",
]

MAX_DURATION_S = 4 * 3600.0
"""The longest reference planned: four hours, half a shift, some hundred times the longest shipped route (about
100 s). Planning checks its wheel peaks every millisecond and samples it on the control grid, and a closed-loop
run keeps every sample, so this bounds the work after the path's geometry: a 4 h reference plans in about 15 s
and 0.6 GB (decision record 0021)."""

MAX_REFERENCE_SAMPLES = 1_000_000
"""The most control-grid samples of one reference: 4 h at the shipped 40 ms take 360 000; at a faster control
rate the bound is what binds (1000 s at 1 ms). Sampling a curved reference costs about 0.8 kB a sample at its
peak, so the grid stays within 1 GB (decision record 0021)."""


def check_reference(reference: Reference, source: str, key: str) -> None:
    """Refuse a reference longer than :data:`MAX_DURATION_S` or of more than :data:`MAX_REFERENCE_SAMPLES`
    samples (before its grid is made).

    Parameters
    ----------
    reference : Reference
        The planned reference.
    source : str
        What the error names as the file or function.
    key : str
        The key the error names.

    Raises
    ------
    ConfigError
        A reference too long or of too many samples.
    """
    if not reference.duration_s <= MAX_DURATION_S:
        raise ConfigError(
            source,
            key,
            f"the reference would last {reference.duration_s:.4g} s, above the maximum {MAX_DURATION_S:g} s",
        )
    ts = reference.sample_period_s
    what = f"the reference ({reference.duration_s:.4g} s at control.sample_period_s = {ts:g} s)"
    check_sample_count(reference.duration_s / ts, source, key, what)
    samples = reference.duration_s / ts
    if not samples <= MAX_REFERENCE_SAMPLES:
        raise ConfigError(
            source, key, f"{what} would take {samples:.4g} samples, above the maximum {MAX_REFERENCE_SAMPLES}"
        )


def check_tolerance(source: str, tolerance_m: float) -> None:
    """Check a drawn-path tolerance given to a planner's function as a path file's is checked.

    Parameters
    ----------
    source : str
        The function, as the error names it.
    tolerance_m : float
        The tolerance, finite and >= :data:`~agvctl.planning.spec.MIN_DRAWN_PATH_TOLERANCE_M`, m.

    Raises
    ------
    ConfigError
        ``<source>: drawn_path_tolerance_m: …``.
    """
    if (
        isinstance(tolerance_m, bool)
        or not isinstance(tolerance_m, (int, float))
        or not (math.isfinite(tolerance_m) and tolerance_m >= MIN_DRAWN_PATH_TOLERANCE_M)
    ):
        raise ConfigError(
            source,
            "drawn_path_tolerance_m",
            f"must be finite and >= {MIN_DRAWN_PATH_TOLERANCE_M:g} (got {tolerance_m!r})",
        )


def check_drawn_path(reference: Reference, source: str, key: str) -> None:
    """Refuse a reference whose path leaves the drawn one by more than its tolerance.

    Parameters
    ----------
    reference : Reference
        The planned reference.
    source : str
        What the error names as the file or function.
    key : str
        The tolerance's key (``limits.drawn_path_tolerance_m`` in a path file).

    Raises
    ------
    ConfigError
        ``<source>: <key>: the planned path leaves the drawn one by … mm, more than … mm; …``.
    """
    if not reference.drawn_path_deviation_m <= reference.drawn_path_tolerance_m:
        raise ConfigError(
            source,
            key,
            f"the planned path leaves the drawn one by {reference.drawn_path_deviation_m * 1e3:.3g} mm, more than "
            f"{reference.drawn_path_tolerance_m * 1e3:.3g} mm (raise the tolerance, or add waypoints where the "
            "path bends)",
        )


def check_extent(
    segments: Sequence[Segment],
    waypoints: Sequence[Waypoint],
    limits: WheelLimits,
    separation_m: float,
    sample_period_s: float,
    source: str,
) -> None:
    """Refuse a path that cannot be driven within :data:`MAX_DURATION_S` and :data:`MAX_REFERENCE_SAMPLES`,
    naming the segment (and key) or waypoint where it passes the bound, before anything is planned.

    The time of a segment is at least its length over the speed it may keep (no path speed exceeds the wheel
    speed limit, nor the segment's cap; a turn's wheels travel ``|angle| b/2``), and a waypoint path is at
    least as long as the polyline through its points.

    Parameters
    ----------
    segments : sequence of LineSegment, TurnSegment or ArcSegment
        The segments (empty for a waypoint path).
    waypoints : sequence of Waypoint
        The waypoints (empty for a segment path).
    limits : WheelLimits
        The resolved wheel limits.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The control sample period, s.
    source : str
        What the error names as the file or function.

    Raises
    ------
    ConfigError
        ``<source>: segments[i].length_m: the path up to here takes at least … s …``.
    """
    longest = min(MAX_DURATION_S, MAX_REFERENCE_SAMPLES * sample_period_s)
    bound = (
        f"above the maximum {MAX_DURATION_S:g} s"
        if longest == MAX_DURATION_S
        else f"above the {MAX_REFERENCE_SAMPLES} samples at control.sample_period_s = {sample_period_s:g} s"
    )
    least = 0.0
    for i, seg in enumerate(segments):
        kind, distance, _, _ = segment_kinematics(seg)
        speed = limits.wheel_speed_m_s if seg.speed_m_s is None else min(seg.speed_m_s, limits.wheel_speed_m_s)
        least += distance * (0.5 * separation_m if kind == "spin" else 1.0) / speed
        if not least <= longest:
            if isinstance(seg, LineSegment):
                key = "length_m"
            elif isinstance(seg, ArcSegment) and seg.radius_m * 2.0 * math.pi / speed > longest:
                key = "radius_m"
            else:
                key = "angle_deg"
            raise ConfigError(
                source,
                f"segments[{i}].{key}",
                f"the path up to here takes at least {least:.4g} s at {speed:g} m/s, {bound}",
            )
    for i in range(1, len(waypoints)):
        a, b = waypoints[i - 1], waypoints[i]
        least += math.hypot(b.x_m - a.x_m, b.y_m - a.y_m) / limits.wheel_speed_m_s
        if not least <= longest:
            raise ConfigError(
                source,
                f"waypoints[{i}]",
                f"the path up to here takes at least {least:.4g} s at {limits.wheel_speed_m_s:g} m/s, {bound}",
            )


def check_arguments(segments: Sequence[Segment], join: str, separation_m: float, sample_period_s: float) -> None:
    """Check the arguments of :func:`~agvctl.planning.plan_segments` as a path file's are checked.

    Parameters
    ----------
    segments : sequence of LineSegment, TurnSegment or ArcSegment
        The segments: 1 to :data:`~agvctl.planning.spec.MAX_SEGMENTS` of them, each valid.
    join : str
        ``"smooth"`` or ``"stop"``.
    separation_m : float
        The wheel separation b, finite and > 0, m.
    sample_period_s : float
        The control sample period, finite and > 0, s.

    Raises
    ------
    ConfigError
        Naming ``plan_segments`` and the argument.
    """
    if not 1 <= len(segments) <= MAX_SEGMENTS:
        raise ConfigError("plan_segments", "segments", f"give 1 … {MAX_SEGMENTS} segments (got {len(segments)})")
    for i, seg in enumerate(segments):
        if not isinstance(seg, Segment):
            raise ConfigError("plan_segments", f"segments[{i}]", f"expected a segment (got {seg!r})")
        seg.validate(source="plan_segments", prefix=f"segments[{i}]")
    if join not in ("smooth", "stop"):
        raise ConfigError("plan_segments", "join", f"must be one of 'smooth', 'stop' (got {join!r})")
    check_geometry("plan_segments", separation_m, sample_period_s)


def check_geometry(source: str, separation_m: float, sample_period_s: float) -> None:
    """Check that the wheel separation and the sample period are finite numbers > 0.

    Parameters
    ----------
    source : str
        The function the arguments were given to, as the error names it.
    separation_m : float
        The wheel separation b, m.
    sample_period_s : float
        The control sample period, s.

    Raises
    ------
    ConfigError
        Naming ``source`` and the argument.
    """
    for name, value in (("separation_m", separation_m), ("sample_period_s", sample_period_s)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
            raise ConfigError(source, name, f"must be finite and > 0 (got {value!r})")
