"""The wheels follow their setpoints where their loops have authority: the signal behind the default gate's
``wheel_speed_error_max_m_s``, and the loops' own word on when they are clamped."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvctl.controllers.pi import default_pi_gains
from agvctl.controllers.pi.tuning import closed_loop_time_constant_s
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.evaluation.limits import default_limits
from agvctl.evaluation.metrics import SPEED_ERROR_WINDOW_S, wheel_speed_error_m_s
from agvctl.feasibility import torque_accel_limit_m_s2
from agvctl.log import SimLog
from agvctl.params import load_vehicle

TS = 0.04


def wheel_log(setpoint: np.ndarray, speed: np.ndarray, limited: np.ndarray | float = 0.0) -> SimLog:
    """Both wheels alike: their setpoints, their speeds and the loops' clamp flags, one row per sample."""
    n = len(setpoint)
    flags = np.broadcast_to(np.asarray(limited, dtype=float), (n,)).copy()
    columns = {"t_s": np.arange(n) * TS, "cross_track_error_m": np.zeros(n)}
    for side in ("left", "right"):
        columns[f"setpoint_wheel_speed_{side}_m_s"] = setpoint
        columns[f"wheel_speed_{side}_m_s"] = speed
        columns[f"wheel_loop_limited_{side}"] = flags
    return SimLog(columns)


def test_a_wheel_driven_at_0_8_of_its_setpoint_misses_by_a_fifth_of_it() -> None:
    setpoint = np.full(100, 0.5)
    error = wheel_speed_error_m_s(wheel_log(setpoint, 0.8 * setpoint), TS)
    window = round(SPEED_ERROR_WINDOW_S / TS)
    assert np.all(error[:window] == 0.0)  # not judged before a whole window has passed
    assert error[window:] == pytest.approx(0.1)


def test_a_window_in_which_the_loop_was_clamped_is_not_judged() -> None:
    setpoint = np.full(100, 0.5)
    limited = np.zeros(100)
    limited[::20] = 1.0  # clamped once in every 0.8 s: no whole second free of it
    assert np.max(wheel_speed_error_m_s(wheel_log(setpoint, 0.8 * setpoint, limited), TS)) == 0.0


def test_a_wheel_controller_that_does_not_say_when_it_is_clamped_is_not_judged() -> None:
    setpoint = np.full(100, 0.5)
    assert np.max(wheel_speed_error_m_s(wheel_log(setpoint, 0.8 * setpoint, math.nan), TS)) == 0.0


def test_the_designed_loop_following_a_ramp_at_the_motors_full_torque_stays_within_the_default_bound() -> None:
    """The MPC's model of the closed loop, a first-order lag of τ (31 ms), behind a setpoint ramping at the
    largest acceleration the motors' torque gives: it lags by about τ·a, under the default's T_s·a."""
    vehicle = load_vehicle()
    tau = closed_loop_time_constant_s(vehicle, default_pi_gains(vehicle).gains)
    accel = torque_accel_limit_m_s2(vehicle)
    pole = math.exp(-TS / tau)
    setpoint = np.minimum(accel * TS * np.arange(100), 0.9)
    speed = np.zeros(100)
    for k in range(99):
        speed[k + 1] = pole * speed[k] + (1.0 - pole) * setpoint[k]
    bound = default_limits(vehicle, wheel_log(setpoint, speed))["wheel_speed_error_max_m_s"].bound
    assert bound == pytest.approx(accel * vehicle.control.sample_period_s)
    assert 0.0 < np.max(wheel_speed_error_m_s(wheel_log(setpoint, speed), TS)) < bound


def test_the_pi_loops_say_they_are_clamped_at_the_current_limit_and_not_on_a_small_step() -> None:
    vehicle = load_vehicle()
    loops = PIWheelController(vehicle, default_pi_gains(vehicle).gains)
    loops.update(np.array([300.0, 300.0]), np.zeros(2))  # a step to near full speed from rest
    assert loops.limited == (True, True)
    loops.reset()
    loops.update(np.array([1.0, 1.0]), np.zeros(2))
    assert loops.limited == (False, False)
