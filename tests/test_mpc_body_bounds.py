"""The MPC keeps a path's limits on the body's motion: its commands change the body's speed and yaw rate by at most
a share of the limits per sample (a smaller share while a wheel rests on its stiction), their centripetal
acceleration stays within a share of the lateral limit, the QP bounds its setpoints alike, and a path without such
limits is tracked exactly as before."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import tomli_w

from agvctl.controllers.mpc.body_bounds import NEAR_REST_SPEED_M_S, BodyBounds
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.options import Braking
from agvctl.evaluation.limits import judge_run
from agvctl.params import VehicleParams
from agvctl.planning import BodyLimits, PathLimits, PathSpec, plan
from agvctl.planning.spec import ArcSegment, LineSegment
from agvctl.scenario.experiment import load_experiment, run_experiment

T, B = 0.04, 0.54
SHARE, BREAKAWAY = 0.8, 0.5
GENTLE = BodyLimits(linear_accel_m_s2=0.3, angular_accel_rad_s2=1.0, lateral_accel_m_s2=0.3)
MOVING = (0.3, 0.3)
PAYLOAD = Path(__file__).resolve().parent.parent / "experiments" / "payload"


def bounds(body: BodyLimits = GENTLE) -> BodyBounds:
    b = BodyBounds(T, B, SHARE, BREAKAWAY)
    b.reset(body)
    return b


def mean_and_difference(left: float, right: float) -> tuple[float, float]:
    return 0.5 * (left + right), right - left


def test_without_body_limits_every_command_passes_unchanged():
    b = bounds(BodyLimits())
    assert not b.active
    assert b.command(1.0, -1.0, (0.0, 0.0), (0.0, 0.0)) == (1.0, -1.0)


def test_a_command_changes_the_bodys_speed_and_yaw_rate_by_at_most_the_share_per_sample():
    b = bounds()
    left, right = b.command(0.9, 0.1, (0.2, 0.2), MOVING)
    mean, difference = mean_and_difference(left, right)
    assert mean - 0.2 == pytest.approx(SHARE * 0.3 * T)  # the linear limit binds the speed-up
    assert abs(difference) / B == pytest.approx(SHARE * 1.0 * T)  # the angular one the turn
    assert b.command(0.205, 0.21, (0.2, 0.2), MOVING) == (0.205, 0.21)  # within both: unchanged


def test_a_step_with_a_wheel_at_or_near_rest_uses_the_break_away_share():
    b = bounds()
    resting = (0.0, NEAR_REST_SPEED_M_S / 2)
    assert b.first_steps(*resting) == pytest.approx((BREAKAWAY * SHARE * 0.3 * T, BREAKAWAY * SHARE * 1.0 * T * B))
    assert b.first_steps(*MOVING) == pytest.approx((SHARE * 0.3 * T, SHARE * 1.0 * T * B))
    left, right = b.command(0.5, 0.5, (0.0, 0.0), resting)
    assert mean_and_difference(left, right)[0] == pytest.approx(BREAKAWAY * SHARE * 0.3 * T)


def test_a_commands_centripetal_acceleration_stays_within_the_share_of_the_lateral_limit():
    b = bounds(BodyLimits(lateral_accel_m_s2=0.3))
    left, right = b.command(0.3, 0.9, (0.3, 0.9), MOVING)  # U = 0.6 m/s, ω = 1.1 rad/s: 0.67 m/s² asked
    mean, difference = mean_and_difference(left, right)
    assert mean == pytest.approx(0.6)
    assert abs(mean * difference / B) == pytest.approx(SHARE * 0.3)


def test_random_requests_keep_every_bound():
    rng = np.random.default_rng(20261206)
    b = bounds()
    for _ in range(2000):
        previous = tuple(rng.uniform(-0.5, 0.5, 2))
        speeds = tuple(rng.choice([0.0, 0.3]) * rng.uniform(-1, 1, 2))
        left, right = b.command(*rng.uniform(-1, 1, 2), previous, speeds)
        step_mean, step_difference = b.first_steps(*speeds)
        mean, difference = mean_and_difference(left, right)
        mean0, difference0 = mean_and_difference(*previous)
        assert abs(mean - mean0) <= step_mean * (1 + 1e-12)
        assert abs(difference - difference0) <= step_difference * (1 + 1e-12) + 1e-15
        if abs(difference0) * abs(mean) <= b.lateral_m2_s2:  # from within the cap, a command stays within it
            assert abs(mean * difference) <= b.lateral_m2_s2 * (1 + 1e-12)


def gentle_bend(vehicle: VehicleParams, body: BodyLimits):
    segments = (LineSegment(length_m=1.0), ArcSegment(radius_m=0.6, angle_deg=90.0), LineSegment(length_m=0.5))
    limits = PathLimits(**{k: getattr(body, k) for k in ("linear_accel_m_s2", "angular_accel_rad_s2")})
    return plan(PathSpec(segments=segments, name="bend", limits=limits), vehicle)


def test_the_qp_has_the_body_rate_block_only_where_the_path_limits_the_body(vehicle: VehicleParams):
    controller = LtvMpcController(vehicle, MpcConfig())
    assert "body rate" not in controller._qp.rows
    controller.reset(gentle_bend(vehicle, GENTLE))
    assert (
        controller._qp.rows["body rate"].stop - controller._qp.rows["body rate"].start == 2 * controller.config.horizon
    )
    controller.reset(gentle_bend(vehicle, BodyLimits()))
    assert "body rate" not in controller._qp.rows
    segments = (LineSegment(length_m=1.0), ArcSegment(radius_m=0.6, angle_deg=90.0))
    lateral_only = PathSpec(segments=segments, name="bend", limits=PathLimits(lateral_accel_m_s2=0.3))
    controller.reset(plan(lateral_only, vehicle))  # a lateral bound acts on the commands, no rate rows needed
    assert controller._body.active and "body rate" not in controller._qp.rows


def test_from_an_offset_start_the_commands_keep_the_body_bounds_the_qp_solves(vehicle: VehicleParams):
    reference = gentle_bend(vehicle, GENTLE)
    controller = LtvMpcController(vehicle, MpcConfig())
    controller.reset(reference)
    b = controller._body
    pose, speeds, previous = np.array([0.0, -0.04, math.radians(-4.0)]), np.zeros(2), (0.0, 0.0)
    for i in range(40):  # open loop: the wheels follow each command within a sample
        cmd = controller.update(i * T, pose, speeds)
        assert cmd.status == "solved"
        step_mean, step_difference = b.first_steps(*speeds)
        mean, difference = mean_and_difference(cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s)
        mean0, difference0 = mean_and_difference(*previous)
        assert abs(mean - mean0) <= step_mean * (1 + 1e-9)
        assert abs(difference - difference0) <= step_difference * (1 + 1e-9)
        previous, speeds = (
            (cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s),
            np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s]),
        )
        u, w = mean, difference / B
        pose = pose + T * np.array([u * math.cos(pose[2]), u * math.sin(pose[2]), w])


@pytest.mark.parametrize("name", ["bend_nominal", "bend_heavy", "s_curve_nominal", "s_curve_heavy"])
def test_a_gentle_path_from_an_offset_start_keeps_its_payloads_limits_and_passes_the_default_gate(name):
    experiment = load_experiment(PAYLOAD / f"{name}.toml")
    verdict = judge_run(run_experiment(experiment), experiment.spec.limits, experiment.controller_vehicle)
    judged = {r.limit for r in verdict.limits if r.default}
    assert {f"peak_body_{key}" for key in ("linear_accel_m_s2", "lateral_accel_m_s2", "angular_accel_rad_s2")} <= judged
    assert verdict.passed, [r.limit for r in verdict.limits if not r.passed]


def test_a_solver_that_plans_without_the_body_bounds_gets_commands_unbounded_by_them_and_tracks(tmp_path):
    """The NMPC plans without the body's bounds: bounding its commands behind its back would leave its predictions
    wrong (on this bend it drifted 20 cm off the path); its commands stay its own and the gate judges the limits."""
    text = (PAYLOAD / "bend_nominal.toml").read_text(encoding="utf-8")
    text = text.replace('pose = "mpc"', 'pose = "nmpc"').replace(
        "../../trajectories", str(PAYLOAD.parents[1] / "trajectories")
    )
    (tmp_path / "nmpc.toml").write_text(text, encoding="utf-8")
    experiment = load_experiment(tmp_path / "nmpc.toml")
    verdict = judge_run(run_experiment(experiment), experiment.spec.limits, experiment.controller_vehicle)
    others = [r.limit for r in verdict.limits if not r.passed and not r.limit.startswith("peak_body")]
    assert others == []  # on the path, at its end, on time
    assert any(r.limit.startswith("peak_body") for r in verdict.limits)  # the path's limits judged


@pytest.mark.parametrize(
    ("limits", "named", "braking"),
    [
        ({"linear_accel_m_s2": 0.3}, None, Braking.GENTLE_STOP),
        ({"angular_accel_rad_s2": 1.0}, None, Braking.GENTLE_STOP),
        ({"lateral_accel_m_s2": 0.3}, None, Braking.FULL),
        ({}, None, Braking.FULL),
        ({"linear_accel_m_s2": 0.3}, "full", Braking.FULL),
    ],
)
def test_the_wheel_loops_brake_gently_to_a_stop_where_the_path_limits_the_bodys_acceleration(
    limits, named, braking, tmp_path
):
    """A wheel braked at the full current decelerates at up to 2.7 a_lim into its stop: unless the experiment names
    a braking, a path with a payload's acceleration limits gets gentle stops (its loops and the resolved file)."""
    path = {"name": "l", "segments": [{"type": "line", "length_m": 1.0}], "limits": limits}
    (tmp_path / "l.path.toml").write_text(tomli_w.dumps(path), encoding="utf-8")
    controller = {"pose": "mpc", **({"braking": named} if named else {})}
    experiment = {"name": "e", "trajectory": "l.path.toml", "controller": controller}
    (tmp_path / "e.toml").write_text(tomli_w.dumps(experiment), encoding="utf-8")
    loaded = load_experiment(tmp_path / "e.toml")
    assert loaded.wheel_loops.options.braking is braking
    assert loaded.spec.controller.braking == braking.value
