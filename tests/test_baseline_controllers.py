"""The unicycle baselines (Ramsete, LTV LQR): their equations, their gains, and their closed loops."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig, LtvLqrController, unicycle_error_model, unicycle_lqr_gain
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController, ramsete_law
from agvctl.controllers.baselines.unicycle import UnicycleTracker, desaturated_wheel_speeds, robot_frame_error
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.controllers.registry import default_pi_gains
from agvctl.evaluation.path_metrics import path_errors
from agvctl.params import VehicleParams
from agvctl.planning import ArcSegment, LineSegment, WheelLimits, plan_segments
from agvctl.planning.reference import Reference
from agvctl.sim.loop import run_closed_loop


def _reference(vehicle: VehicleParams, segment: LineSegment | ArcSegment) -> Reference:
    limits = WheelLimits(wheel_speed_m_s=0.6, wheel_accel_m_s2=0.4, wheel_jerk_m_s3=2.0)
    return plan_segments(
        [segment],
        limits=limits,
        separation_m=vehicle.wheels.separation_m,
        sample_period_s=vehicle.control.sample_period_s,
    )


# --- the shared kinematics -------------------------------------------------------------------------------
def test_robot_frame_error_is_the_reference_seen_from_the_robot() -> None:
    # robot at (1, 1) facing +y: a point 1 m further along +y is straight ahead, one at x = 0 is to its left
    pose = np.array([1.0, 1.0, math.pi / 2])
    e_x, e_y, e_theta = robot_frame_error(pose, 1.0, 2.0, math.pi / 2)
    assert (e_x, e_y, e_theta) == pytest.approx((1.0, 0.0, 0.0), abs=1e-12)
    e_x, e_y, e_theta = robot_frame_error(pose, 0.0, 1.0, math.pi / 2 + 2 * math.pi + 0.1)
    assert (e_x, e_y, e_theta) == pytest.approx((0.0, 1.0, 0.1), abs=1e-12)  # heading wrapped


def test_desaturation_keeps_the_curvature() -> None:
    b = 0.5
    left, right = desaturated_wheel_speeds(1.0, 2.0, b, 0.8)  # v_l = 0.5, v_r = 1.5 before scaling
    assert max(abs(left), abs(right)) == pytest.approx(0.8)
    assert right / left == pytest.approx(3.0)
    assert desaturated_wheel_speeds(0.3, 0.4, b, 0.8) == pytest.approx((0.2, 0.4))  # within: unchanged


# --- Ramsete ---------------------------------------------------------------------------------------------
def test_ramsete_law_on_a_hand_computed_case() -> None:
    # e = (0.1 m, 0.2 m, 0.3 rad), v_d = 0.5 m/s, ω_d = 0.4 rad/s, b = 2, ζ = 0.7:
    # k = 1.4 √(0.16 + 0.5) = 1.137365; v = 0.5 cos 0.3 + 0.1 k = 0.477668 + 0.113737 = 0.591405
    # ω = 0.4 + 0.3 k + 2 · 0.5 · (sin 0.3 / 0.3) · 0.2 = 0.4 + 0.341210 + 0.197013 = 0.938223
    v, w = ramsete_law((0.1, 0.2, 0.3), 0.5, 0.4, 2.0, 0.7)
    assert v == pytest.approx(0.591405, abs=2e-6)
    assert w == pytest.approx(0.938223, abs=2e-6)


def test_ramsete_law_limits() -> None:
    assert ramsete_law((0.0, 0.0, 0.0), 0.5, -0.3, 2.0, 0.7) == pytest.approx((0.5, -0.3))  # on the reference
    # e_θ → 0: sinc → 1, so ω = ω_d + b v_d e_y; k = 2 ζ √(b) v_d
    v, w = ramsete_law((0.0, 0.05, 0.0), 0.5, 0.0, 2.0, 0.7)
    assert (v, w) == pytest.approx((0.5, 2.0 * 0.5 * 0.05))
    assert ramsete_law((0.1, 0.1, 0.1), 0.0, 0.0, 2.0, 0.7) == pytest.approx((0.0, 0.0))  # at rest: k = 0


def test_ramsete_defaults_are_wpilibs(vehicle: VehicleParams) -> None:
    c = RamseteController(vehicle)
    assert (c.config.b_rad2_m2, c.config.zeta) == (2.0, 0.7)
    assert c.max_wheel_speed_m_s == pytest.approx(vehicle.derived.max_speed_m_s)


# --- LTV LQR ---------------------------------------------------------------------------------------------
def test_error_model_is_the_exact_zero_order_hold() -> None:
    v, T = 0.4, 0.04
    a_d, b_d = unicycle_error_model(v, T)
    np.testing.assert_allclose(a_d, [[1, 0, 0], [0, 1, v * T], [0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(b_d, [[T, 0], [0, v * T**2 / 2], [0, T]], atol=1e-15)


@pytest.mark.parametrize("speed_m_s", [-0.5, 0.0, 0.05, 0.6])
def test_lqr_gain_solves_the_riccati_equation(speed_m_s: float) -> None:
    cfg = LtvLqrConfig()
    T = 0.04
    a, b = unicycle_error_model(speed_m_s, T)
    q = np.diag([1 / cfg.tolerance_x_m**2, 1 / cfg.tolerance_y_m**2, 1 / cfg.tolerance_heading_rad**2])
    r = np.diag([1 / cfg.effort_speed_m_s**2, 1 / cfg.effort_yaw_rate_rad_s**2])
    # value iteration of the Riccati difference equation, independent of the library's solver
    s = q.copy()
    for _ in range(200000):
        k = np.linalg.solve(b.T @ s @ b + r, b.T @ s @ a)
        s_next = q + a.T @ s @ (a - b @ k)
        if np.max(np.abs(s_next - s)) <= 1e-10 * np.max(np.abs(s_next)):
            break
        s = s_next
    k_expected = np.linalg.solve(b.T @ s @ b + r, b.T @ s @ a)
    k = unicycle_lqr_gain(speed_m_s, T, cfg)
    np.testing.assert_allclose(k, k_expected, rtol=1e-5, atol=1e-6 * np.max(np.abs(k_expected)))
    assert np.max(np.abs(np.linalg.eigvals(a - b @ k))) < 1.0  # the closed error loop is stable


def test_gain_schedule_interpolates_between_riccati_gains(vehicle: VehicleParams) -> None:
    c = LtvLqrController(vehicle)
    T = vehicle.control.sample_period_s
    v0, v1 = c.schedule_speeds_m_s[100], c.schedule_speeds_m_s[101]
    np.testing.assert_allclose(c.gain(float(v0)), unicycle_lqr_gain(float(v0), T, c.config), rtol=1e-12)
    mid = 0.5 * (unicycle_lqr_gain(float(v0), T, c.config) + unicycle_lqr_gain(float(v1), T, c.config))
    np.testing.assert_allclose(c.gain(float(0.5 * (v0 + v1))), mid, rtol=1e-12)
    assert np.all(np.diff(c.schedule_speeds_m_s) <= c.config.schedule_step_m_s + 1e-12)
    assert c.schedule_speeds_m_s[-1] == pytest.approx(vehicle.derived.max_speed_m_s)


# --- the PoseController contract -------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [RamseteController, LtvLqrController])
def test_setpoints_are_finite_and_within_the_wheel_limit(vehicle: VehicleParams, cls: type[UnicycleTracker]) -> None:
    ref = _reference(vehicle, LineSegment(length_m=2.0))
    c = cls(vehicle)  # type: ignore[call-arg]
    c.reset(ref)
    t_mid = 0.5 * ref.duration_s
    far = c.update(t_mid, np.array([-5.0, 3.0, 2.0]), np.zeros(2))  # far off: the law asks for far too much
    assert max(abs(far.wheel_speed_left_m_s), abs(far.wheel_speed_right_m_s)) <= c.max_wheel_speed_m_s * (1 + 1e-12)
    bad = c.update(t_mid, np.array([np.nan, 0.0, 0.0]), np.zeros(2))
    assert math.isfinite(bad.wheel_speed_left_m_s) and math.isfinite(bad.wheel_speed_right_m_s)
    assert bad.status == "fallback_feedforward" and c.failures == 1


def test_a_lower_configured_wheel_limit_is_respected(vehicle: VehicleParams) -> None:
    c = RamseteController(vehicle, RamseteConfig(max_wheel_speed_m_s=0.2))
    c.reset(_reference(vehicle, ArcSegment(radius_m=0.5, angle_deg=90)))
    cmd = c.update(2.0, np.array([0.0, -0.2, 0.0]), np.zeros(2))
    assert max(abs(cmd.wheel_speed_left_m_s), abs(cmd.wheel_speed_right_m_s)) <= 0.2 + 1e-12


def test_update_before_reset_raises(vehicle: VehicleParams) -> None:
    with pytest.raises(RuntimeError, match="before reset"):
        RamseteController(vehicle).update(0.0, np.zeros(3), np.zeros(2))


# --- closed loop -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [RamseteController, LtvLqrController])
@pytest.mark.parametrize(
    "segment", [LineSegment(length_m=3.0, speed_m_s=0.4), ArcSegment(radius_m=1.0, angle_deg=360, speed_m_s=0.4)]
)
def test_converges_from_an_offset_start(
    vehicle: VehicleParams, cls: type[UnicycleTracker], segment: LineSegment | ArcSegment
) -> None:
    """Starting 5 cm to the side and 5° turned, the vehicle is back on the path over the last third of the
    motion (cross-track error within 2 cm, the issue's end-of-path figure, and well below the offset; Ramsete's
    gain k vanishes as the reference slows to its stop, so what is left there stays), and the setpoints stay
    finite and within the wheel limit."""
    ref = _reference(vehicle, segment)
    gains, _ = default_pi_gains(vehicle)
    start = ref.start_pose
    result = run_closed_loop(
        plant_vehicle=vehicle,
        controller_vehicle=vehicle,
        reference=ref,
        pose_controller=cls(vehicle),  # type: ignore[call-arg]
        wheel_controller=PIWheelController(vehicle, gains),
        initial_pose=(start.x_m, start.y_m + 0.05, start.theta_rad + math.radians(5.0)),
        settle_s=1.0,
    )
    log = result.log
    pe = path_errors(log["t_s"], log["x_m"], log["y_m"], log["theta_rad"], ref)
    late = (log["t_s"] > 2.0 / 3.0 * ref.duration_s) & (log["t_s"] <= ref.duration_s)
    assert np.max(pe.cross_track_m[late]) < 0.02
    assert np.max(np.abs(pe.heading_error_rad)) < math.radians(30.0)
    for side in ("left", "right"):
        assert np.all(np.isfinite(log[f"setpoint_wheel_speed_{side}_m_s"]))
        assert np.max(np.abs(log[f"setpoint_wheel_speed_{side}_m_s"])) <= vehicle.derived.max_speed_m_s + 1e-12


# --- the reference feed-forward (pose = "none") ------------------------------------------------------------
def test_feedforward_gives_exactly_the_references_wheel_speeds(vehicle: VehicleParams) -> None:
    ref = _reference(vehicle, ArcSegment(radius_m=1.0, angle_deg=90.0, speed_m_s=0.5))
    ff = FeedForwardPoseController()
    ff.reset(ref)
    ts = ref.sample_period_s
    grid = list(ref.grid_times_s)
    times = [*grid, -0.01, 0.5 * ts, 1.234, ref.duration_s, grid[-1] + ts, grid[-1] + 3.7]  # on and off the grid
    for t in times:
        cmd = ff.update(t, np.zeros(3), np.zeros(2))
        s = ref.sample(np.array([t]))
        assert (cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s) == (
            float(s.wheel_speed_left_m_s[0]),
            float(s.wheel_speed_right_m_s[0]),
        ), t
