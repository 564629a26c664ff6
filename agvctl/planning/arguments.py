"""The arguments of the planner's entry points, checked as a path file's are, and the bounds of a reference."""

from __future__ import annotations

import math
from collections.abc import Sequence

from agvctl.errors import ConfigError
from agvctl.params.schema import check_sample_count
from agvctl.planning.reference import Reference
from agvctl.planning.spec import MAX_SEGMENTS, Segment

__all__ = ["MAX_DURATION_S", "check_arguments", "check_geometry", "check_reference"]

MAX_DURATION_S = 24 * 3600.0
"""The longest reference planned (one day): a longer one is a typing error, not a drive, and its samples would
not fit in memory."""


def check_reference(reference: Reference, source: str, key: str) -> None:
    """Refuse a reference longer than :data:`MAX_DURATION_S` or of more than
    :data:`~agvctl.params.schema.MAX_SAMPLES_PER_RUN` samples (before its grid is made).

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
