"""Where a run of lines and arcs drives through its curvature changes on smooth joins, and where it stops instead:
the joins of a run designed once each, and the run split into motions at the joins not worth driving."""

from __future__ import annotations

import bisect

from agvctl.planning.joins import JoinWindow, design_join
from agvctl.planning.spec import WheelLimits
from agvctl.planning.speed import section_limits

__all__ = ["MIN_JOIN_WINDOW_M"]

_Part = tuple[int, float, float, float | None]  # segment index, distance, curvature, speed cap
_Designed = dict[tuple[float, float, float, float | None, float], JoinWindow | None]  # joins designed in one plan


def _worth_driving(
    w: JoinWindow, speed: float, cap: float | None, kappa_max: float, limits: WheelLimits, half_b: float
) -> bool:
    """Whether crossing a window at its speed limit is quicker than driving the corner with a stop instead:
    the window's length at ``speed`` plus what braking to rest and starting again add (speed/a + a/j with the
    wheel limits divided by F = 1 + |κ| b/2 of the sharper neighbour)."""
    lim = section_limits(w.length_m, w.bounds, cap, limits, half_b)
    f = 1.0 + kappa_max * half_b
    a, j = limits.wheel_accel_m_s2 / f, limits.wheel_jerk_m_s3 / f
    return w.length_m / lim.speed_m_s <= w.length_m / speed + speed / a + a / j


MIN_JOIN_WINDOW_M = 1e-6
"""A join window has room for at least a micrometre, else the reference stops at the corner: a shorter window's
curvature polynomial (coefficients over powers of its length) overflows, and no vehicle drives it."""


def _window(
    parts: list[_Part],
    k: int,
    left: bool,
    right: bool,
    limits: WheelLimits,
    half_b: float,
    designed: _Designed,
    max_deviation_m: float,
) -> JoinWindow | bool:
    """The smooth join between parts k and k + 1 (their curvatures differ), or ``False`` where the segments are too
    short for a join worth driving (the reference stops there). ``left``/``right``: whether part k has a join on
    its left and part k + 1 one on its right, in the run being planned (then it shares its length between them
    in proportion to their jumps). The window leaves the corner by at most ``max_deviation_m``."""
    a, b = parts[k], parts[k + 1]
    jump = abs(b[2] - a[2])
    room_a = a[1] * (jump / (jump + abs(a[2] - parts[k - 1][2])) if left else 1.0)
    room_b = b[1] * (jump / (jump + abs(parts[k + 2][2] - b[2])) if right else 1.0)
    speeds = [limits.wheel_speed_m_s / (1.0 + abs(p[2]) * half_b) for p in (a, b)]
    caps = [p[3] for p in (a, b) if p[3] is not None]
    cap = min(caps) if caps else None
    speed = min(speeds + caps)
    if 2.0 * min(room_a, room_b) < MIN_JOIN_WINDOW_M:
        return False
    key = (a[2], b[2], speed, cap, 2.0 * min(room_a, room_b))
    if key not in designed:  # a path that repeats a corner designs it once
        try:
            designed[key] = design_join(
                a[2],
                b[2],
                speed_m_s=speed,
                cap_m_s=cap,
                limits=limits,
                half_b_m=half_b,
                max_length_m=key[4],
                max_deviation_m=max_deviation_m,
            )
        except ValueError:
            designed[key] = None
    w = designed[key]
    if w is None:
        return False
    kappa_max = max(abs(a[2]), abs(b[2]))
    return w if _worth_driving(w, speed, cap, kappa_max, limits, half_b) else False


def _runs(
    parts: list[_Part], limits: WheelLimits, half_b: float, designed: _Designed, max_deviation_m: float
) -> list[tuple[int, int, list[JoinWindow | None]]]:
    """The motions of a run of lines and arcs as ``(first part, end part, join after each part)``: one motion, or
    several where a join is not worth driving (the reference stops after the part before it).

    A run is split at its first join not worth driving; the joins next to the cut are designed again (a part
    at the cut no longer shares its length with a join there), then each side is split the same way. A join
    depends only on its two parts and whether each neighbour has another join, so each is designed at most
    four times and the work grows linearly with the parts. No window leaves its corner by more than
    ``max_deviation_m``.
    """
    n = len(parts)
    joins = [parts[k][2] != parts[k + 1][2] for k in range(n - 1)]
    cache: dict[tuple[int, bool, bool], JoinWindow | bool] = {}

    def at(k: int, lo: int, hi: int) -> JoinWindow | bool | None:
        """The join after part k in the motion of parts lo … hi - 1 (None: no join)."""
        if k >= hi - 1 or not joins[k]:
            return None
        key = (k, k > lo and joins[k - 1], k + 2 < hi and joins[k + 1])
        if key not in cache:
            cache[key] = _window(parts, k, key[1], key[2], limits, half_b, designed, max_deviation_m)
        return cache[key]

    refused = [k for k in range(n - 1) if at(k, 0, n) is False]  # away from a cut, a join is the same
    out: list[tuple[int, int, list[JoinWindow | None]]] = []
    stack = [(0, n)]
    while stack:
        lo, hi = stack.pop()
        first = [k for k in (lo, hi - 2) if lo <= k and at(k, lo, hi) is False]
        i = bisect.bisect_right(refused, lo)
        if i < len(refused) and refused[i] < hi - 2:
            first.append(refused[i])
        if first:
            cut = min(first) + 1
            stack += [(cut, hi), (lo, cut)]  # the earlier side first
            continue
        windows = [at(k, lo, hi) for k in range(lo, hi)]
        out.append((lo, hi, [w if isinstance(w, JoinWindow) else None for w in windows]))
    return out
