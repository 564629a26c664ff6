"""Planning: every shipped path within the wheel limits (checked by finite differences of the sampled pose),
pose continuity, final pose against an independent geometric construction, and time-optimality against the
closed form of a rest-to-rest jerk-limited motion."""

from __future__ import annotations

import cmath
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agvctl.config import load_toml
from agvctl.feasibility import feedback_accel_m_s2
from agvctl.planning import (
    ArcSegment,
    LineSegment,
    PathSpec,
    TurnSegment,
    WheelLimits,
    load_path,
    plan,
    plan_segments,
)
from agvctl.planning.spec import BODY_LIMIT_KEYS

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted((ROOT / "trajectories").glob("*.toml"))
B = 0.54  # wheel separation of the default vehicle (appendix A)
DT = 1e-3  # the acceptance criterion's sampling period


def test_required_paths_are_shipped():
    names = {p.stem for p in SHIPPED}
    assert {"line", "square", "circle", "figure8", "lane_change", "slalom"} <= names


@pytest.fixture(scope="module", params=SHIPPED, ids=[p.stem for p in SHIPPED])
def shipped(request, vehicle):
    path = request.param
    return path, plan(load_path(path), vehicle)


def _file_limits(path: Path, vehicle) -> tuple[float, float, float]:
    """The limits as the file sets them, else the defaults: 80 % of I_max for the acceleration (eq 5 with 0.8
    I_max) and the speed at which that acceleration needs 80 % of the full-scale voltage (eq 33), and the jerk
    convention."""
    lim = load_toml(path).get("limits", {})
    k_t, r_n, R = 0.027, 0.1 / 36, 0.38
    j_tot = 2.5e-5 + 0.5 * 85.0 * r_n**2  # eq 5
    a_default = (0.8 * 5.5 * k_t - 0.065) / j_tot * r_n
    u_fs = 2.0 * 2047 * 10.0 / 4096  # the amplifier at the DA's last code
    v_default = (0.8 * u_fs - R * 0.8 * 5.5) / k_t * r_n
    return (
        lim.get("wheel_speed_m_s", v_default),
        lim.get("wheel_accel_m_s2", a_default),
        lim.get("wheel_jerk_m_s3", vehicle.derived.accel_limit_m_s2 / (5 * vehicle.control.sample_period_s)),
    )


def _wheel_speeds_by_differences(x, y, theta, dt):
    """Wheel speeds on the mid-points of a pose sampled every dt, from the pose alone.

    The chord of a constant-curvature step points along the mid heading, so
    U = (Δx cos θ_mid + Δy sin θ_mid)/dt is the mean speed over the step and ω = Δθ/dt the mean yaw rate;
    v_l,r = U ∓ ω b/2 (eqs 39-43).
    """
    th_mid = 0.5 * (theta[1:] + theta[:-1])
    u = (np.diff(x) * np.cos(th_mid) + np.diff(y) * np.sin(th_mid)) / dt
    w = np.diff(theta) / dt
    return u - w * B / 2, u + w * B / 2


def test_wheel_limits_hold_by_finite_differences(shipped, vehicle):
    path, ref = shipped
    v_lim, a_lim, j_lim = _file_limits(path, vehicle)
    t = np.arange(0.0, ref.duration_s + 0.05, DT)
    s = ref.sample(t)
    peak_a = peak_v = 0.0
    for v in _wheel_speeds_by_differences(s.x_m, s.y_m, s.theta_rad, DT):
        peak_v = max(peak_v, np.max(np.abs(v)))
        a = np.diff(v) / DT
        j = np.diff(a) / DT
        assert np.max(np.abs(v)) <= v_lim * (1 + 1e-9)
        assert np.max(np.abs(a)) <= a_lim * 1.001
        assert np.max(np.abs(j)) <= j_lim * 1.01
        peak_a = max(peak_a, np.max(np.abs(a)))
    # the limits are used, not just respected: the outer wheel reaches the acceleration limit on every segment
    # path, or the speed limit binds first (the figure-8's outer wheel at its crossing) (a waypoint path's
    # curvature changes all along, and takes a share of the acceleration everywhere)
    # (a path that limits the body's motion plans within those limits instead: tests/test_planning_body.py)
    data = load_toml(path)
    if "segments" in data and not set(data.get("limits", {})) & set(BODY_LIMIT_KEYS):
        assert peak_a >= 0.98 * a_lim or peak_v >= 0.995 * v_lim
    # the planner's own numbers agree with the differences (mid-point speeds)
    mid = ref.sample(t[:-1] + DT / 2)
    v_l, v_r = _wheel_speeds_by_differences(s.x_m, s.y_m, s.theta_rad, DT)
    assert np.max(np.abs(v_l - mid.wheel_speed_left_m_s)) < 1e-5
    assert np.max(np.abs(v_r - mid.wheel_speed_right_m_s)) < 1e-5
    # and its exact peaks are within the limits too
    peaks = ref.peaks()
    assert peaks["peak_wheel_speed_m_s"] <= v_lim
    assert peaks["peak_wheel_accel_m_s2"] <= a_lim
    assert peaks["peak_wheel_jerk_m_s3"] <= j_lim


def test_the_peak_wheel_speed_alone_is_the_one_of_all_peaks(shipped, vehicle):
    reference = plan(load_path(shipped[0]), vehicle)  # a new reference: no peaks worked out yet
    speed_alone = reference.peak_wheel_speed_m_s()
    assert speed_alone == reference.peaks()["peak_wheel_speed_m_s"]
    assert reference.peak_wheel_speed_m_s() == speed_alone  # and again once the peaks are known


def test_pose_is_continuous(shipped):
    _, ref = shipped
    t = np.arange(0.0, ref.duration_s + 0.05, DT)
    s = ref.sample(t)
    v_lim = ref.limits.wheel_speed_m_s
    step = np.hypot(np.diff(s.x_m), np.diff(s.y_m))
    assert np.max(step) <= v_lim * DT * (1 + 1e-6)
    assert np.max(np.abs(np.diff(s.theta_rad))) <= v_lim / (B / 2) * DT * (1 + 1e-6)
    # across every join between motions, approached from both sides
    for m in ref.motions[1:]:
        pair = ref.sample([m.t_start_s - 1e-9, m.t_start_s + 1e-9])
        assert abs(pair.x_m[1] - pair.x_m[0]) < 1e-8
        assert abs(pair.y_m[1] - pair.y_m[0]) < 1e-8
        assert abs(pair.theta_rad[1] - pair.theta_rad[0]) < 1e-8
        # both wheels are at rest where the curvature changes
        assert abs(pair.wheel_speed_left_m_s[0]) < 1e-8 and abs(pair.wheel_speed_right_m_s[0]) < 1e-8


def _geometric_end(path: Path) -> tuple[float, float, float]:
    """Compose the file's segments with complex numbers, rotating about each arc's centre (independent of the
    planner's chord formula)."""
    data = load_toml(path)
    if "waypoints" in data:  # the last waypoint, and its heading
        last = data["waypoints"][-1]
        return last["x_m"], last["y_m"], math.radians(last.get("theta_deg", math.nan))
    start = data.get("start", {})
    z = complex(start.get("x_m", 0.0), start.get("y_m", 0.0))
    th = math.radians(start.get("theta_deg", 0.0))
    for seg in data["segments"]:
        if seg["type"] == "line":
            z += seg["length_m"] * cmath.exp(1j * th)
        elif seg["type"] == "turn":
            th += math.radians(seg["angle_deg"])
        else:
            phi = math.radians(seg["angle_deg"])
            centre = z + 1j * math.copysign(seg["radius_m"], phi) * cmath.exp(1j * th)
            z = centre + (z - centre) * cmath.exp(1j * phi)
            th += phi
    return z.real, z.imag, th


def test_final_pose_is_the_geometric_end(shipped):
    path, ref = shipped
    x, y, th = _geometric_end(path)
    for t_end in (ref.duration_s, ref.duration_s + 1.0, ref.grid_times_s[-1]):
        s = ref.sample([t_end])
        assert math.hypot(s.x_m[0] - x, s.y_m[0] - y) <= 1e-3
        assert abs(math.remainder(s.theta_rad[0] - th, 2 * math.pi)) <= math.radians(0.1) or math.isnan(th)
        assert s.wheel_speed_left_m_s[0] == 0 and s.wheel_speed_right_m_s[0] == 0
    pose = ref.final_pose
    assert math.hypot(pose.x_m - x, pose.y_m - y) <= 1e-3
    assert abs(math.remainder(pose.theta_rad - th, 2 * math.pi)) <= math.radians(0.1) or math.isnan(th)


def test_known_ends():
    # hand-computed ends of three shipped paths
    ends = {
        "square": (0.0, 0.0, 2 * math.pi),
        "lane_change": (2 + 2 * 2 * math.sin(math.pi / 6), 4 * (1 - math.cos(math.pi / 6)), 0.0),
        "figure8": (0.0, 0.0, 0.0),
    }
    for name, (x, y, th) in ends.items():
        assert _geometric_end(ROOT / "trajectories" / f"{name}.toml") == pytest.approx((x, y, th), abs=1e-12)
        pose = plan(load_path(ROOT / "trajectories" / f"{name}.toml")).final_pose
        assert (pose.x_m, pose.y_m, pose.theta_rad) == pytest.approx((x, y, th), abs=1e-9)


# ----------------------------------------------------------------------------------------------------
# time-optimality


def closed_form_rest_to_rest(d: float, v: float, a: float, j: float) -> float:
    """Shortest time to move d at rest at both ends with |velocity| ≤ v, |accel| ≤ a, |jerk| ≤ j.

    Accelerating from rest to speed w takes 2√(w/j) if w ≤ a²/j (the acceleration limit is not reached) and
    w/a + a/j otherwise, covering w·t/2 (the profile is symmetric). Accelerating and braking to and from w
    therefore covers w·t_acc. Cruise at v if that fits, else find the peak w that covers exactly d.
    """

    def t_acc(w: float) -> float:
        return 2 * math.sqrt(w / j) if w <= a * a / j else w / a + a / j

    if v * t_acc(v) <= d:
        return t_acc(v) + d / v
    w_no_a = (d * math.sqrt(j) / 2) ** (2 / 3)  # d = 2 w^1.5 / √j
    if w_no_a <= a * a / j:
        return 2 * t_acc(w_no_a)
    w = (-a * a / j + math.sqrt((a * a / j) ** 2 + 4 * a * d)) / 2  # d = w²/a + w a/j
    return 2 * t_acc(w)


LIMITS = WheelLimits(wheel_speed_m_s=0.8, wheel_accel_m_s2=0.657, wheel_jerk_m_s3=3.0)


def _single(segment, limits=LIMITS):
    return plan_segments([segment], limits=limits, separation_m=B, sample_period_s=0.04)


@pytest.mark.parametrize("length_m", [0.01, 0.1, 0.3, 0.8, 1.2, 2.0, 10.0, -2.0])
def test_line_duration_is_time_optimal(length_m):
    ref = _single(LineSegment(length_m=length_m))
    best = closed_form_rest_to_rest(abs(length_m), 0.8, 0.657, 3.0)
    assert ref.duration_s == pytest.approx(best, rel=1e-6)  # the criterion is 1 %; Ruckig is exact


@pytest.mark.parametrize("angle_deg", [1.0, 10.0, 45.0, 90.0, -90.0, 180.0, 720.0])
def test_turn_duration_is_time_optimal(angle_deg):
    ref = _single(TurnSegment(angle_deg=angle_deg))
    # spin in place: each wheel travels |angle|·b/2 with the wheel limits
    best = closed_form_rest_to_rest(abs(math.radians(angle_deg)) * B / 2, 0.8, 0.657, 3.0)
    assert ref.duration_s == pytest.approx(best, rel=1e-6)


def test_arc_duration_is_time_optimal_for_the_outer_wheel():
    radius, angle = 0.8, math.pi / 2
    ref = _single(ArcSegment(radius_m=radius, angle_deg=90.0))
    # the outer wheel covers (R + b/2)·φ within the wheel limits; the inner one follows in proportion
    best = closed_form_rest_to_rest((radius + B / 2) * angle, 0.8, 0.657, 3.0)
    assert ref.duration_s == pytest.approx(best, rel=1e-6)


def test_each_motion_of_the_square_is_time_optimal(vehicle):
    spec = load_path(ROOT / "trajectories" / "square.toml")
    lim = spec.limits  # the file's own wheel limits (0.8 m/s, 0.5 m/s², 3 m/s³)
    ref = plan(spec, vehicle)
    assert len(ref.motions) == 8
    for m in ref.motions:
        d = 2.0 if m.kind == "path" else math.pi / 2 * B / 2
        best = closed_form_rest_to_rest(d, lim.wheel_speed_m_s, lim.wheel_accel_m_s2, lim.wheel_jerk_m_s3)
        assert m.duration_s == pytest.approx(best, rel=1e-6)


@settings(max_examples=60, derandomize=True, deadline=None)
@given(
    d=st.floats(1e-3, 20.0),
    v=st.floats(0.05, 1.0),
    a=st.floats(0.05, 1.0),
    j=st.floats(0.1, 20.0),
    spin=st.booleans(),
)
def test_time_optimal_for_random_limits(d, v, a, j, spin):
    limits = WheelLimits(v, a, j)
    seg = TurnSegment(angle_deg=math.degrees(d / (B / 2))) if spin else LineSegment(length_m=d)
    ref = _single(seg, limits)
    assert ref.duration_s == pytest.approx(closed_form_rest_to_rest(d, v, a, j), rel=1e-4)


# ----------------------------------------------------------------------------------------------------
# joining rule, speed caps, the Reference API


def test_join_stop_merges_equal_curvatures_and_stops_at_curvature_jumps():
    segs = [
        LineSegment(length_m=1.0),
        LineSegment(length_m=1.0),
        ArcSegment(radius_m=1.0, angle_deg=90),
        ArcSegment(radius_m=1.0, angle_deg=90),
        ArcSegment(radius_m=1.0, angle_deg=-90),
        TurnSegment(angle_deg=30),
    ]
    ref = plan_segments(segs, limits=LIMITS, separation_m=B, sample_period_s=0.04, join="stop")
    assert [m.segment_indices for m in ref.motions] == [(0, 1), (2, 3), (4,), (5,)]
    # the default drives through the curvature changes and stops only for the turn in place
    smooth = plan_segments(segs, limits=LIMITS, separation_m=B, sample_period_s=0.04)
    assert [m.segment_indices for m in smooth.motions] == [(0, 1, 2, 3, 4), (5,)]
    # the merged line is one rest-to-rest motion over 2 m
    assert ref.motions[0].duration_s == pytest.approx(closed_form_rest_to_rest(2.0, 0.8, 0.657, 3.0), rel=1e-6)


def test_segment_speed_cap_is_the_path_speed():
    ref = _single(ArcSegment(radius_m=1.0, angle_deg=360, speed_m_s=0.5))
    s = ref.sample(np.linspace(0, ref.duration_s, 20001))
    assert np.max(s.speed_m_s) == pytest.approx(0.5, rel=1e-6)
    assert np.max(s.wheel_speed_right_m_s) == pytest.approx(0.5 * (1 + B / 2), rel=1e-6)
    assert np.max(s.yaw_rate_rad_s) == pytest.approx(0.5, rel=1e-6)  # ω = U/R


def test_figure8_cruises_at_half_a_metre_per_second(vehicle):
    ref = plan(load_path(ROOT / "trajectories" / "figure8.toml"), vehicle)
    s = ref.grid
    assert np.max(np.abs(s.speed_m_s)) == pytest.approx(0.5, rel=1e-6)
    # most of the time is spent at the cruise speed
    assert np.mean(np.abs(s.speed_m_s) > 0.499) > 0.7


def test_spin_keeps_position_and_wheels_opposite():
    ref = _single(TurnSegment(angle_deg=-120))
    s = ref.sample(np.linspace(0, ref.duration_s, 501))
    assert np.all(s.x_m == 0) and np.all(s.y_m == 0) and np.all(s.speed_m_s == 0)
    assert np.allclose(s.wheel_speed_left_m_s, -s.wheel_speed_right_m_s)
    assert np.all(s.wheel_speed_right_m_s <= 0)  # clockwise: right wheel backwards
    assert s.theta_rad[-1] == pytest.approx(math.radians(-120), abs=1e-12)


def test_reverse_line_drives_backwards_and_counts_path_length():
    ref = _single(LineSegment(length_m=-1.5))
    s = ref.sample(np.linspace(0, ref.duration_s, 101))
    assert np.all(s.speed_m_s <= 0)
    assert s.x_m[-1] == pytest.approx(-1.5, abs=1e-9)
    assert np.all(np.diff(s.path_length_m) >= 0) and s.path_length_m[-1] == pytest.approx(1.5)


def test_grid_is_on_the_control_period(vehicle):
    ref = plan(load_path(ROOT / "trajectories" / "line.toml"), vehicle)
    t = ref.grid.t_s
    k = np.arange(len(t))
    assert np.array_equal(t, k * 0.04)
    assert t[-1] >= ref.duration_s > t[-2]
    assert len(ref.grid) == len(t)


def test_sample_outside_the_reference_is_at_rest():
    ref = _single(ArcSegment(radius_m=1.0, angle_deg=90))
    s = ref.sample([-1.0, 0.0, ref.duration_s, ref.duration_s + 5.0])
    for name in (
        "speed_m_s",
        "yaw_rate_rad_s",
        "wheel_accel_left_m_s2",
        "wheel_jerk_left_m_s3",
        "wheel_jerk_right_m_s3",
    ):
        values = getattr(s, name)
        assert values[0] == 0 and values[3] == 0, name
    assert (s.x_m[0], s.y_m[0], s.theta_rad[0]) == (0.0, 0.0, 0.0)
    assert (
        s.x_m[3] == pytest.approx(1.0)
        and s.y_m[3] == pytest.approx(1.0)
        and s.theta_rad[3] == pytest.approx(math.pi / 2)
    )


def test_derivatives_are_consistent():
    # U and ω are the time derivatives of the path length and the heading; accel of speed; jerk of accel
    ref = _single(ArcSegment(radius_m=0.5, angle_deg=-200))
    t = np.linspace(0.0, ref.duration_s, 40001)
    s = ref.sample(t)
    h = t[1] - t[0]
    assert np.allclose(np.gradient(s.theta_rad, h), s.yaw_rate_rad_s, atol=1e-5)
    assert np.allclose(np.gradient(s.path_length_m, h), np.abs(s.speed_m_s), atol=1e-5)
    assert np.allclose(np.gradient(s.speed_m_s, h), s.accel_m_s2, atol=2e-3)
    assert np.allclose(np.gradient(s.yaw_rate_rad_s, h), s.yaw_accel_rad_s2, atol=4e-3)
    # jerk is piecewise constant: the central difference matches it except at the few phase switches
    agree = np.isclose(np.gradient(s.wheel_accel_left_m_s2, h), s.wheel_jerk_left_m_s3, atol=1e-6)
    assert np.mean(agree) > 0.99


def test_programmatic_path_spec_and_start_pose(vehicle):
    from agvctl.planning import StartPose

    spec = PathSpec(segments=[LineSegment(length_m=1.0)], start=StartPose(1.0, 2.0, 90.0))
    pose = plan(spec, vehicle).final_pose
    assert (pose.x_m, pose.y_m, pose.theta_rad) == pytest.approx((1.0, 3.0, math.pi / 2), abs=1e-12)


def test_the_feedbacks_share_is_the_current_the_default_limits_leave(vehicle):
    # 20 % of I_max accelerates a wheel by k_t 0.2 I_max r/(J_tot N) (eq 5, friction already paid by the plan): the
    # default limits' acceleration and this share add up to a_lim of eq 5
    k_t, n, r = 0.027, 36.0, 0.1
    j_tot = 2.5e-5 + 0.5 * 85.0 * r**2 / n**2  # eq 5
    assert feedback_accel_m_s2(vehicle) == pytest.approx(k_t * 0.2 * 5.5 / j_tot * r / n, rel=1e-12)
    default = plan(PathSpec(segments=[LineSegment(length_m=1.0)]), vehicle).limits.wheel_accel_m_s2
    assert default + feedback_accel_m_s2(vehicle) == pytest.approx(vehicle.derived.accel_limit_m_s2, rel=1e-12)


def test_default_limits_come_from_the_vehicle(vehicle):
    # the defaults leave 20 % of the current limit and of the full-scale voltage to the feedback: the planned
    # acceleration needs k_t i = J_tot a N/r + τ_c (eq 5's balance) with i = 0.8 I_max, and at the planned top speed
    # that current plus the back-EMF needs u = R i + k_e ω = 0.8 u_fs (eq 33), u_fs = k_pow · 2047 · 10 V/4096
    ref = plan(PathSpec(segments=[LineSegment(length_m=20.0)]), vehicle)
    k_t, k_e, R, n, r, tau_c = 0.027, 0.027, 0.38, 36.0, 0.1, 0.065
    j_tot = 2.5e-5 + 0.5 * 85.0 * r**2 / n**2  # eq 5
    a = ref.limits.wheel_accel_m_s2
    current = (j_tot * a * n / r + tau_c) / k_t
    assert current == pytest.approx(0.8 * 5.5, rel=1e-9)
    assert a < 0.657  # below a_lim of eq 5
    u_fs = 2.0 * 2047 * 10.0 / 4096
    omega = ref.limits.wheel_speed_m_s * n / r
    assert R * current + k_e * omega == pytest.approx(0.8 * u_fs, rel=1e-9)
    assert ref.limits.wheel_speed_m_s < vehicle.derived.max_speed_m_s
    assert ref.peaks()["peak_wheel_speed_m_s"] == pytest.approx(ref.limits.wheel_speed_m_s, rel=1e-6)
