"""Planning benchmark: the shipped paths with smooth joins against stopping at every curvature change and
against TOPP-RA's acceleration-limited optimum, and planning times (goal: a 20-waypoint path in ≤ 20 ms).

    PYTHONPATH=. python experiments/benchmarks/planning.py [--repeat 200]

TOPP-RA (``pip install toppra``, the ``bench`` extra) solves the same path with the same per-wheel speed and
acceleration limits, the wheel acceleration including the ṡ² dκ/ds b/2 term, but no jerk limit: its duration
is a lower bound on ours (the jerk limit, and the zero path acceleration at section joins, make ours longer).
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import math
import time
from pathlib import Path

import numpy as np

from agvctl.params import load_vehicle
from agvctl.planning import ArcSegment, LineSegment, PathSpec, Reference, TurnSegment, Waypoint, load_path, plan

ROOT = Path(__file__).resolve().parents[2]
TOPPRA_GRIDPOINTS = 1500


def twenty_segments() -> list:
    """A 20-segment path mixing lines, turns in place, arcs of both signs, a reverse line and a speed cap."""
    segs: list = []
    for i in range(5):
        segs += [
            LineSegment(length_m=0.5 + 0.3 * i),
            TurnSegment(angle_deg=45.0 if i % 2 else -60.0),
            ArcSegment(radius_m=0.6 + 0.2 * i, angle_deg=(-1) ** i * 75.0, speed_m_s=0.5 if i == 2 else None),
            LineSegment(length_m=-0.4) if i == 3 else ArcSegment(radius_m=1.5, angle_deg=30.0),
        ]
    assert len(segs) == 20
    return segs


def twenty_waypoints() -> list[Waypoint]:
    """20 waypoints, 1 m apart along x, weaving ±0.5 m; the first heading given, the others chosen."""
    return [Waypoint(x_m=float(i), y_m=0.5 * math.sin(1.3 * i), theta_deg=0.0 if i == 0 else None) for i in range(20)]


def timings(fn, repeat: int) -> np.ndarray:
    out = np.empty(repeat)
    for k in range(repeat):
        t0 = time.perf_counter()
        fn()
        out[k] = time.perf_counter() - t0
    return out * 1e3


def report(label: str, ms: np.ndarray) -> None:
    print(
        f"  {label:<44} median {np.median(ms):7.3f} ms   min {np.min(ms):7.3f} ms   p99 {np.percentile(ms, 99):7.3f} ms"
    )


def _caps(spec: PathSpec, motion) -> list[tuple[float, float]]:
    """(start q, speed cap) of each segment of a motion (inf where none)."""
    caps = []
    for i, q in zip(motion.segment_indices, motion.segment_starts, strict=True):
        cap = spec.segments[i].speed_m_s if spec.segments else None
        caps.append((q, math.inf if cap is None else cap))
    return caps


def toppra_duration(spec: PathSpec, ref: Reference) -> float:
    """TOPP-RA's shortest time along the planned path, wheel speed and acceleration limits only."""
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    toppra.setup_logging("WARNING")
    lim, h = ref.limits, 0.5 * ref.separation_m
    total = 0.0
    for m in ref.motions:
        caps = _caps(spec, m)
        cap_q, cap_v = np.array([c[0] for c in caps]), np.array([c[1] for c in caps])
        if m.curve is None:  # a spin: each wheel moves h·q, a trapezoid in the wheel limits
            d, v = m.distance * h, min(lim.wheel_speed_m_s, float(np.min(cap_v)))
            a = lim.wheel_accel_m_s2
            total += d / v + v / a if d >= v * v / a else 2.0 * math.sqrt(d / a)
            continue
        curve, sign = m.curve, m.direction
        length = curve.length_m

        def vlim(s, curve=curve, cap_q=cap_q, cap_v=cap_v):
            k = curve.evaluate(s).curvature_1_m
            v = lim.wheel_speed_m_s / (1.0 + np.abs(k) * h)
            v = np.minimum(v, cap_v[np.searchsorted(cap_q, s, side="right") - 1])
            return np.column_stack([-v, v])

        def inv_dyn(q, qd, qdd, curve=curve, sign=sign):
            c = curve.evaluate(q)
            k, dk = c.curvature_1_m[0], c.curvature_rate_1_m2[0]
            turn = h * (k * qdd[0] + dk * qd[0] ** 2)
            return np.array([sign * qdd[0] - turn, sign * qdd[0] + turn])

        a = lim.wheel_accel_m_s2
        cons = [
            constraint.JointVelocityConstraintVarying(vlim),
            constraint.SecondOrderConstraint(
                inv_dyn,
                lambda q: np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]),
                lambda q, a=a: np.full(4, a),
                dof=1,
                discretization_scheme=0,
            ),
        ]
        path = toppra.SplineInterpolator([0.0, length], [[0.0], [length]], bc_type="natural")
        grid = np.linspace(0.0, length, TOPPRA_GRIDPOINTS)
        inst = algo.TOPPRA(cons, path, gridpoints=grid, parametrizer="ParametrizeConstAccel")
        _, sd, _ = inst.compute_parameterization(0.0, 0.0)  # ṡ at the gridpoints
        total += float(np.sum(2.0 * np.diff(grid) / (sd[1:] + sd[:-1])))  # constant s̈: Δs / mean speed
    return total


def finite_difference_peaks(ref: Reference, dt: float = 1e-3) -> tuple[float, float, float]:
    """Peak wheel speed, acceleration and jerk from the planned pose alone, sampled every ``dt``."""
    t = np.arange(0.0, ref.duration_s + 0.05, dt)
    s = ref.sample(t)
    mid = 0.5 * (s.theta_rad[1:] + s.theta_rad[:-1])
    u = (np.diff(s.x_m) * np.cos(mid) + np.diff(s.y_m) * np.sin(mid)) / dt
    w = np.diff(s.theta_rad) / dt
    h = 0.5 * ref.separation_m
    peaks = []
    for v in (u - w * h, u + w * h):
        a = np.diff(v) / dt
        peaks.append((np.max(np.abs(v)), np.max(np.abs(a)), np.max(np.abs(np.diff(a) / dt))))
    return tuple(np.max(peaks, axis=0))


def shipped(vehicle, with_toppra: bool) -> None:
    print('shipped paths: smooth joins vs join = "stop"; TOPP-RA lower bound; limits by finite differences')
    print(
        f"  {'path':<13}{'stop s':>8}{'smooth s':>10}{'saved':>7}{'TOPP-RA s':>11}{'ratio':>7}"
        f"{'dev mm':>8}{'stops':>6}   v/v_lim  a/a_lim  j/j_lim"
    )
    for file in sorted(glob.glob(str(ROOT / "trajectories" / "*.toml"))):
        spec = load_path(file)
        ref = plan(spec, vehicle)
        old = plan(dataclasses.replace(spec, join="stop"), vehicle) if spec.segments else ref
        low = toppra_duration(spec, ref) if with_toppra else math.nan
        v, a, j = finite_difference_peaks(ref)
        lim = ref.limits
        print(
            f"  {Path(file).stem:<13}{old.duration_s:8.2f}{ref.duration_s:10.2f}"
            f"{1 - ref.duration_s / old.duration_s:7.1%}{low:11.2f}{ref.duration_s / low:7.3f}"
            f"{ref.drawn_path_deviation_m * 1e3:8.2f}{len(ref.motions) - 1:6d}"
            f"   {v / lim.wheel_speed_m_s:7.4f}  {a / lim.wheel_accel_m_s2:7.4f}  {j / lim.wheel_jerk_m_s3:7.4f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=200)
    parser.add_argument("--no-toppra", action="store_true", help="skip the TOPP-RA comparison")
    args = parser.parse_args()
    vehicle = load_vehicle()
    shipped(vehicle, not args.no_toppra)
    wp = PathSpec(waypoints=twenty_waypoints(), name="bench-20-waypoints")
    seg = PathSpec(segments=twenty_segments(), name="bench-20-segments")
    ref_wp, ref_seg = plan(wp, vehicle), plan(seg, vehicle)
    print(
        f"20-waypoint path: {ref_wp.path_length_m:.2f} m in {ref_wp.duration_s:.2f} s, within "
        f"{ref_wp.drawn_path_deviation_m * 1e6:.1f} µm of the spline through the waypoints"
    )
    print(
        f"20-segment path: {len(ref_seg.motions)} motions, {ref_seg.path_length_m:.2f} m in {ref_seg.duration_s:.2f} s"
    )
    print("planning time:")
    report("plan(): 20 waypoints → Reference (goal ≤ 20 ms)", timings(lambda: plan(wp, vehicle), args.repeat))
    report("plan(): 20 segments → Reference", timings(lambda: plan(seg, vehicle), args.repeat))
    report("plan() and the 40 ms grid, 20 waypoints", timings(lambda: plan(wp, vehicle).grid, args.repeat))
    dense = np.arange(0, ref_wp.duration_s, 1e-3)
    report("sample() at 1 ms over the 20-waypoint path", timings(lambda: ref_wp.sample(dense), 20))


if __name__ == "__main__":
    main()
