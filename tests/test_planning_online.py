"""The online velocity-command API: streamed (U, ω) targets give wheel references within the limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agvctl.planning import VelocityCommandPlanner, WheelLimits

LIMITS = WheelLimits(wheel_speed_m_s=0.8, wheel_accel_m_s2=0.657, wheel_jerk_m_s3=3.0)
B, TS = 0.54, 0.04


def _run(targets):
    cmd = VelocityCommandPlanner(LIMITS, separation_m=B, sample_period_s=TS)
    return [cmd.step(u, w) for u, w in targets]


@settings(max_examples=40, derandomize=True, deadline=None)
@given(st.lists(st.tuples(st.floats(-1.5, 1.5), st.floats(-6.0, 6.0), st.integers(1, 40)), min_size=1, max_size=12))
def test_streamed_targets_respect_the_wheel_limits(schedule):
    targets = [(u, w) for u, w, n in schedule for _ in range(n)]
    out = _run(targets)
    v = np.array([[c.wheel_speed_left_m_s, c.wheel_speed_right_m_s] for c in out])
    a = np.array([[c.wheel_accel_left_m_s2, c.wheel_accel_right_m_s2] for c in out])
    assert np.max(np.abs(v)) <= 0.8 * (1 + 1e-9)
    assert np.max(np.abs(a)) <= 0.657 * (1 + 1e-9)
    # by differences of the streamed states, not only Ruckig's own numbers
    v_all = np.vstack([[0.0, 0.0], v])
    a_all = np.vstack([[0.0, 0.0], a])
    assert np.max(np.abs(np.diff(v_all, axis=0) / TS)) <= 0.657 * 1.001
    assert np.max(np.abs(np.diff(a_all, axis=0) / TS)) <= 3.0 * 1.01
    # U and ω are the wheel speeds' mean and difference (eqs 39-43)
    for c in out[:5]:
        assert c.speed_m_s == pytest.approx((c.wheel_speed_left_m_s + c.wheel_speed_right_m_s) / 2)
        assert c.yaw_rate_rad_s == pytest.approx((c.wheel_speed_right_m_s - c.wheel_speed_left_m_s) / B)


def test_reaches_the_target_in_the_shortest_time():
    out = _run([(0.5, 0.0)] * 100)
    assert out[-1].speed_m_s == pytest.approx(0.5, abs=1e-9) and out[-1].yaw_rate_rad_s == pytest.approx(0, abs=1e-12)
    # 0 → 0.5 m/s with a = 0.657, j = 3: 0.5 ≥ a²/j so t = v/a + a/j = 0.980 s
    t_reach = next(c.t_s for c in out if abs(c.speed_m_s - 0.5) < 1e-9)
    assert t_reach == pytest.approx(0.5 / 0.657 + 0.657 / 3.0, abs=TS)


def test_times_are_on_the_grid():
    out = _run([(0.1, 0.1)] * 30)
    assert [c.t_s for c in out] == [k * TS for k in range(1, 31)]


def test_saturation_keeps_the_curvature():
    cmd = VelocityCommandPlanner(LIMITS, separation_m=B, sample_period_s=TS)
    v_l, v_r, sat = cmd.target_wheel_speeds(1.0, 2.0)  # wants 0.46 and 1.54 m/s
    assert sat and max(abs(v_l), abs(v_r)) == pytest.approx(0.8)
    assert (v_r - v_l) / B / ((v_r + v_l) / 2) == pytest.approx(2.0 / 1.0)  # κ = ω/U kept
    out = [cmd.step(1.0, 2.0) for _ in range(200)]
    assert out[-1].saturated
    assert out[-1].yaw_rate_rad_s / out[-1].speed_m_s == pytest.approx(2.0)


def test_reset_and_bad_input():
    cmd = VelocityCommandPlanner(LIMITS, separation_m=B, sample_period_s=TS)
    cmd.reset(wheel_speed_left_m_s=0.3, wheel_speed_right_m_s=0.3)
    assert cmd.step(0.3, 0.0).speed_m_s == pytest.approx(0.3)
    with pytest.raises(ValueError, match="wheel_speed_left_m_s"):
        cmd.reset(wheel_speed_left_m_s=0.9)
    with pytest.raises(ValueError, match="finite"):
        cmd.step(math.nan, 0.0)
    with pytest.raises(ValueError):
        VelocityCommandPlanner(LIMITS, separation_m=0.0, sample_period_s=TS)
    with pytest.raises(ValueError):
        WheelLimits(0.8, -1.0, 3.0)


def test_for_vehicle_defaults(vehicle):
    cmd = VelocityCommandPlanner.for_vehicle(vehicle)
    assert cmd.limits.wheel_speed_m_s == vehicle.derived.max_speed_m_s
    assert cmd.limits.wheel_accel_m_s2 == vehicle.derived.accel_limit_m_s2
    assert cmd.sample_period_s == vehicle.control.sample_period_s and cmd.separation_m == vehicle.wheels.separation_m


def test_streaming_a_smooth_path_follows_it_within_the_limits(vehicle):
    # the online mode fed the smooth figure-8's (U, ω) on the control grid, one period at a time
    from pathlib import Path

    from agvctl.planning import load_path, plan

    path = Path(__file__).resolve().parents[1] / "trajectories" / "figure8.toml"
    ref = plan(load_path(path), vehicle)
    lim = ref.limits
    cmd = VelocityCommandPlanner.for_vehicle(vehicle, lim)
    g = ref.grid
    out = [cmd.step(u, w) for u, w in zip(g.speed_m_s[1:], g.yaw_rate_rad_s[1:], strict=True)]
    v = np.array([[c.wheel_speed_left_m_s, c.wheel_speed_right_m_s] for c in out])
    a = np.array([[c.wheel_accel_left_m_s2, c.wheel_accel_right_m_s2] for c in out])
    assert not any(c.saturated for c in out)  # the smooth reference is within the wheel speed limit
    assert np.max(np.abs(v)) <= lim.wheel_speed_m_s and np.max(np.abs(a)) <= lim.wheel_accel_m_s2 * (1 + 1e-9)
    # a jerk-limited follower of a target accelerating at up to a lags by at most a·(T_s + a/j)
    ref_v = np.column_stack([g.wheel_speed_left_m_s[1:], g.wheel_speed_right_m_s[1:]])
    lag = lim.wheel_accel_m_s2 * (TS + lim.wheel_accel_m_s2 / lim.wheel_jerk_m_s3)
    assert np.max(np.abs(v - ref_v)) <= lag
    # and comes to rest within a lag of the reference's end
    settle = round((lim.wheel_accel_m_s2 / lim.wheel_jerk_m_s3 + lag / lim.wheel_accel_m_s2) / TS) + 2
    last = [cmd.step(0.0, 0.0) for _ in range(settle)][-1]
    assert abs(last.wheel_speed_left_m_s) < 1e-9 and abs(last.wheel_speed_right_m_s) < 1e-9
