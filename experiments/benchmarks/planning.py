"""Planning benchmark: plan a 20-segment path (goal: ≤ 5 ms), and the measurement behind the planner's
choice of Ruckig formulation (one path coordinate with curvature-mapped limits vs. the two wheels as
phase-synchronised degrees of freedom).

    PYTHONPATH=. python experiments/benchmarks/planning.py [--repeat 2000]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import ruckig

from agvctl.params import load_vehicle
from agvctl.planning import ArcSegment, LineSegment, PathSpec, TurnSegment, plan
from agvctl.planning.geometry import segment_kinematics


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


def timings(fn, repeat: int) -> np.ndarray:
    out = np.empty(repeat)
    for k in range(repeat):
        t0 = time.perf_counter()
        fn()
        out[k] = time.perf_counter() - t0
    return out * 1e3


def report(label: str, ms: np.ndarray) -> None:
    print(f"  {label:<44} median {np.median(ms):7.3f} ms   p99 {np.percentile(ms, 99):7.3f} ms")


def compare_formulations(segments, vehicle, repeat: int) -> None:
    """Each segment as (a) one coordinate with limits / (1 + |κ| b/2) and (b) two wheel positions, Ruckig
    phase synchronisation, per-wheel limits. Compares durations and the time per calculation."""
    v, a, j = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2, 3.0
    half_b = vehicle.wheels.separation_m / 2
    one, two = ruckig.Ruckig(1), ruckig.Ruckig(2)
    i1, i2 = ruckig.InputParameter(1), ruckig.InputParameter(2)
    t1, t2 = ruckig.Trajectory(1), ruckig.Trajectory(2)
    i2.synchronization = ruckig.Synchronization.Phase
    i2.max_velocity, i2.max_acceleration, i2.max_jerk = [v, v], [a, a], [j, j]
    worst, cost1, cost2 = 0.0, [], []
    for seg in segments:
        kind, dist, kappa, _ = segment_kinematics(seg)
        gl, gr = (1 - kappa * half_b, 1 + kappa * half_b) if kind == "path" else (-half_b, half_b)
        f = max(abs(gl), abs(gr))
        i1.target_position = [dist]
        i1.max_velocity, i1.max_acceleration, i1.max_jerk = [v / f], [a / f], [j / f]
        i2.target_position = [gl * dist, gr * dist]
        one.calculate(i1, t1)
        two.calculate(i2, t2)
        worst = max(worst, abs(t1.duration - t2.duration) / t1.duration)
        cost1.append(np.median(timings(lambda: one.calculate(i1, t1), repeat // 10)))
        cost2.append(np.median(timings(lambda: two.calculate(i2, t2), repeat // 10)))
        # phase synchronisation keeps the wheel ratio (the path) only if the profiles are scaled copies
        ts = np.linspace(0, t2.duration, 50)
        pos = np.array([t2.at_time(t)[0] for t in ts])
        ratio_err = np.max(np.abs(pos[:, 0] * gr - pos[:, 1] * gl)) if kind == "path" else 0.0
        assert ratio_err < 1e-9, ratio_err
    print("formulation (per segment, rest to rest):")
    print(f"  largest duration difference, 1 coordinate vs 2 wheels (phase sync): {worst:.2e} (relative)")
    print(f"  Ruckig calculate: 1 coordinate {np.mean(cost1) * 1e3:.1f} µs, "
          f"2 wheels {np.mean(cost2) * 1e3:.1f} µs")


def closed_form(d: float, v: float, a: float, j: float) -> float:
    def t_acc(w: float) -> float:
        return 2 * math.sqrt(w / j) if w <= a * a / j else w / a + a / j

    if v * t_acc(v) <= d:
        return t_acc(v) + d / v
    w = (d * math.sqrt(j) / 2) ** (2 / 3)
    if w > a * a / j:
        w = (-a * a / j + math.sqrt((a * a / j) ** 2 + 4 * a * d)) / 2
    return 2 * t_acc(w)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=2000)
    args = parser.parse_args()
    vehicle = load_vehicle()
    segments = twenty_segments()
    spec = PathSpec(segments=segments, name="bench-20")
    ref = plan(spec, vehicle)
    print(f"20-segment path: {len(ref.motions)} motions, {ref.path_length_m:.2f} m "
          f"in {ref.duration_s:.2f} s, {len(ref.grid)} grid samples")
    print("planning time:")
    report("plan() → Reference", timings(lambda: plan(spec, vehicle), args.repeat))
    report("plan() and the 40 ms grid", timings(lambda: plan(spec, vehicle).grid, args.repeat))
    dense = np.arange(0, ref.duration_s, 1e-3)
    report("sample() at 1 ms over the whole path", timings(lambda: ref.sample(dense), 100))
    compare_formulations(segments, vehicle, args.repeat)
    v, a, j = 0.8, 0.657, 3.0
    spec_lim = dict(wheel_speed_m_s=v, wheel_accel_m_s2=a, wheel_jerk_m_s3=j)
    from agvctl.planning import PathLimits

    errs = []
    half_b = vehicle.wheels.separation_m / 2
    cases = [(LineSegment(length_m=x), x) for x in (0.01, 0.1, 0.5, 1.0, 2.0, 10.0)]
    cases += [(TurnSegment(angle_deg=x), math.radians(x) * half_b) for x in (5, 45, 90, 180, 720)]
    for seg, d in cases:
        r = plan(PathSpec(segments=[seg], limits=PathLimits(**spec_lim)), vehicle)
        errs.append(abs(r.duration_s - closed_form(d, v, a, j)) / closed_form(d, v, a, j))
    print(f"time-optimality: largest relative excess over the closed form (lines and turns): {max(errs):.2e}")


if __name__ == "__main__":
    main()
