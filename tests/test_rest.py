"""Rest when done: at the end of the figure-8 on the EKF the vehicle holds still instead of chasing each fix's
correction of the estimate, and the true final error stays small; the wheel loops release the wheels to stiction."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from agvctl.controllers.mpc.rest import Rest, RestConfig
from agvctl.planning import LineSegment, WheelLimits, plan_segments
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"


def figure8(seed, *, rest=True):
    exp = load_experiment(EXPERIMENTS / "figure8_ekf.toml")
    c = exp.spec.controller
    if not rest:
        c = dataclasses.replace(c, pose_settings=dataclasses.replace(c.pose_settings, rest=RestConfig(enabled=False)))
    plant = dataclasses.replace(exp.spec.plant, sensor_seed=seed)
    return dataclasses.replace(exp, spec=dataclasses.replace(exp.spec, settle_s=6.0, controller=c, plant=plant))


def code_changes_per_s(log, last_s=5.0):
    last = log["t_s"] >= log["t_s"][-1] - last_s
    return sum(np.count_nonzero(np.diff(log[f"da_code_{side}"][last])) for side in ("left", "right")) / last_s


@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_at_the_end_of_the_figure8_on_the_ekf_the_vehicle_rests_close_to_the_end(seed):
    log = run_experiment(figure8(seed)).log
    assert code_changes_per_s(log) <= 1.0  # both wheels' DA codes together
    end = np.array([log["ref_x_m"][-1], log["ref_y_m"][-1]])
    assert np.hypot(*(np.array([log["x_m"][-1], log["y_m"][-1]]) - end)) <= 0.01
    assert np.all(log["omega_motor_left_rad_s"][-25:] == 0.0) and np.all(log["omega_motor_right_rad_s"][-25:] == 0.0)
    # stiction holds the stopped wheels: no current holds them against friction or each other
    assert np.all(np.abs(log["current_left_a"][-25:]) <= 0.05) and np.all(np.abs(log["current_right_a"][-25:]) <= 0.05)


def test_at_the_end_of_a_path_the_wheels_draw_no_current_and_stay_where_they_stopped():
    log = run_experiment(load_experiment(EXPERIMENTS / "line.toml")).log
    last = log["t_s"] >= log["t_s"][-1] - 1.0
    for side in ("left", "right"):
        assert np.all(log[f"omega_motor_{side}_rad_s"][last] == 0.0)
        assert np.mean(np.abs(log[f"current_{side}_a"][last])) <= 0.05
    assert np.hypot(log["x_m"][-1] - log["ref_x_m"][-1], log["y_m"][-1] - log["ref_y_m"][-1]) <= 0.002


def test_without_rest_the_controller_chases_every_fix_at_standstill():
    log = run_experiment(figure8(1, rest=False)).log
    assert code_changes_per_s(log) > 10.0


def _line():
    limits = WheelLimits(wheel_speed_m_s=0.5, wheel_accel_m_s2=0.5, wheel_jerk_m_s3=3.0)
    return plan_segments([LineSegment(length_m=1.0)], limits=limits, separation_m=0.54, sample_period_s=0.04)


def test_rest_holds_within_the_estimates_uncertainty_and_lets_go_beyond_it():
    rest = Rest()
    rest.reset(_line())
    end = np.array([1.0, 0.0, 0.0])
    still = np.zeros(2)
    assert not rest(end, still, done=False)  # never before the controller is done
    assert not rest(end, np.array([0.05, 0.05]), done=True)  # nor while the wheels turn
    rest.observe(np.diag([0.002**2, 0.002**2, 0.002**2]))
    assert not rest(end + [0.004, 0.0, 0.0], still, done=True)  # 4 mm off, σ 2 mm: not yet within it
    assert rest(end + [0.002, 0.0, 0.0], still, done=True)  # 2 mm off: no evidence of an error
    assert rest(end + [0.0045, 0.0, 0.0], still, done=True)  # held until the error leaves the release bound
    assert not rest(end + [0.006, 0.0, 0.0], still, done=True)  # beyond max_error_m (5 mm): let go
    rest.observe(np.zeros((3, 3)))  # a perfect estimate: the tolerances decide (1 mm)
    assert rest(end + [0.001, 0.0, 0.0], still, done=True)
    assert not rest(end + [0.0048, 0.0, 0.0], still, done=True)  # 4.8 mm is now certain: let go
