"""The closed loop: reference → pose controller → wheel-speed loops → DA/amplifier → full plant, every T_s.

A plain loop over control ticks t_k = k·T_s (never t += dt). At each tick, following the sample-and-hold rule:

1. measure: the motor speeds at t_k (the true ones, as encoders would) and the pose estimate (the true pose,
   or odometry integrated from the measured wheel speeds with the *controller's* belief of r and b);
2. the pose controller computes wheel-speed setpoints from the pose, the measured wheel speeds and the
   reference (with ``compute_delay = "one_sample"`` the setpoints computed at t_k act from t_k+1);
3. the wheel-speed loops turn setpoint and measured motor speed into DA voltage commands;
4. the actuator chain (DA converter, amplifier) turns them into motor voltages, held over [t_k, t_k+1) while the
   full nonlinear plant is integrated with the *true* vehicle's parameters.

The controllers know only the controller vehicle (the nominal model); the plant may differ (``[plant] set``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.actuator import Actuator
from agvctl.controllers.base import PoseController, WheelSpeedController
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference
from agvctl.plant.full import AUX_NAMES, PlantOptions, parameter_vector
from agvctl.sim.integrator import STATS_NAMES, compiled_plant, sample_splits
from agvctl.sim.log import PLANT_LOG_COLUMNS, SimLog

__all__ = ["CONTROL_LOG_COLUMNS", "ClosedLoopResult", "ComputeDelay", "Localization", "run_closed_loop"]

ComputeDelay = Literal["none", "one_sample"]
Localization = Literal["truth", "odometry"]

CONTROL_LOG_COLUMNS = (
    "ref_x_m",
    "ref_y_m",
    "ref_theta_rad",
    "ref_wheel_speed_left_m_s",
    "ref_wheel_speed_right_m_s",
    "est_x_m",
    "est_y_m",
    "est_theta_rad",
    "setpoint_wheel_speed_left_m_s",
    "setpoint_wheel_speed_right_m_s",
    "setpoint_omega_motor_left_rad_s",
    "setpoint_omega_motor_right_rad_s",
    "wheel_speed_left_m_s",
    "wheel_speed_right_m_s",
    "da_command_left_v",
    "da_command_right_v",
    "position_error_m",
    "heading_error_rad",
    "solve_time_s",
    "solver_status",
)
"""Columns the closed loop adds to :data:`~agvctl.sim.log.PLANT_LOG_COLUMNS`. ``solver_status`` is 0 when the
pose controller solved, 1 for the shifted previous solution, 2 for the reference feed-forward; ``wheel_speed_*``
are the true rim speeds ω_mot·r/N of the plant."""

_STATUS_CODE = {"solved": 0, "fallback_shifted": 1, "fallback_feedforward": 2}


@dataclass
class ClosedLoopResult:
    """A closed-loop run: the full log, its duration and timing."""

    log: SimLog
    reference: Reference
    wall_time_s: float
    """Wall time of the loop (controllers and plant), excluding setup and plots."""
    setup_time_s: float
    solver_failures: int
    n_samples: int
    sample_period_s: float


def _wrap(angle: NDArray[np.float64] | float) -> NDArray[np.float64]:
    return np.asarray((np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi, dtype=float)


def run_closed_loop(
    *,
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    reference: Reference,
    pose_controller: PoseController,
    wheel_controller: WheelSpeedController,
    initial_pose: tuple[float, float, float] | None = None,
    settle_s: float = 0.0,
    compute_delay: ComputeDelay = "none",
    localization: Localization = "truth",
    plant_options: PlantOptions | None = None,
    progress: Callable[[float], None] | None = None,
) -> ClosedLoopResult:
    """Run the cascade on the full plant for the reference's duration plus ``settle_s``.

    ``initial_pose`` (x_m, y_m, theta_rad) defaults to the reference's start. ``progress``, if given, is called
    with the fraction done (0…1) about every second of simulated time.
    """
    t_setup = time.perf_counter()
    ts = controller_vehicle.control.sample_period_s
    if plant_vehicle.control.sample_period_s != ts:
        raise ValueError("the plant and the controller must share control.sample_period_s")
    n = int(math.ceil((reference.duration_s + settle_s) / ts - 1e-9))
    n = max(n, 1)
    t = np.arange(n + 1) * ts
    ref = reference.sample(t)

    plant = compiled_plant(plant_options)
    splits = sample_splits(plant_vehicle)
    p_true = parameter_vector(plant_vehicle)
    actuator = Actuator(plant_vehicle)
    d_true = plant_vehicle.derived
    zone = np.array(
        [
            plant_vehicle.motor.left.stiction_n_m / d_true.left.friction_gain_p,
            plant_vehicle.motor.right.stiction_n_m / d_true.right.friction_gain_p,
        ]
    )
    friction_on = (plant_options or PlantOptions()).friction
    # the controller's belief: motor speed (rad/s) ↔ rim speed (m/s)
    cv = controller_vehicle
    rim_per_motor = np.array(
        [cv.wheels.radius_left_m / cv.motor.left.gear_ratio, cv.wheels.radius_right_m / cv.motor.right.gear_ratio]
    )
    b_belief = cv.wheels.separation_m
    true_rim_per_motor = np.array(
        [
            plant_vehicle.wheels.radius_left_m / plant_vehicle.motor.left.gear_ratio,
            plant_vehicle.wheels.radius_right_m / plant_vehicle.motor.right.gear_ratio,
        ]
    )

    x0_pose = (
        initial_pose if initial_pose is not None else (float(ref.x_m[0]), float(ref.y_m[0]), float(ref.theta_rad[0]))
    )
    x = np.array([0.0, 0.0, *x0_pose])
    est = np.array(x0_pose, dtype=float)

    pose_controller.reset(reference)
    wheel_controller.reset()

    cols = {name: np.zeros(n + 1) for name in (*PLANT_LOG_COLUMNS, *CONTROL_LOG_COLUMNS)}
    aux_idx = {name: i for i, name in enumerate(AUX_NAMES)}
    stats_idx = {name: i for i, name in enumerate(STATS_NAMES)}
    setup = time.perf_counter() - t_setup

    failures = 0
    pending = np.zeros(2)  # setpoints computed last tick (one-sample compute delay)
    wheel_prev = np.zeros(2)
    progress_every = max(1, int(round(1.0 / ts)))
    u_motor = np.zeros(2)
    t0 = time.perf_counter()
    for k in range(n + 1):
        # 1. measure
        pre = x[:2]
        omega = pre - np.clip(pre, -zone, zone) if friction_on else pre.copy()
        wheel_meas = omega * rim_per_motor
        if localization == "odometry" and k > 0:
            # trapezoid over the last sample with the believed geometry (eqs 39-43)
            v_avg = 0.5 * (wheel_meas + wheel_prev)
            speed = 0.5 * (v_avg[0] + v_avg[1])
            dtheta = (v_avg[1] - v_avg[0]) / b_belief * ts
            mid = est[2] + 0.5 * dtheta
            est = est + np.array([speed * ts * math.cos(mid), speed * ts * math.sin(mid), dtheta])
        elif localization == "truth":
            est = x[2:5].copy()
        wheel_prev = wheel_meas

        # 2. pose controller
        tc = time.perf_counter()
        cmd = pose_controller.update(float(t[k]), est, wheel_meas)
        solve = time.perf_counter() - tc
        status = _STATUS_CODE.get(cmd.status, 2)
        if status:
            failures += 1
        new_sp = np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s])
        if compute_delay == "one_sample":  # computed at t_k, applied from t_k+1 (at rest before the first)
            setpoint, pending = pending, new_sp
        else:
            setpoint = new_sp
        sp_motor = setpoint / rim_per_motor

        # 3. wheel-speed loops  4. actuator and plant
        da_cmd = wheel_controller.update(sp_motor, omega)
        out = actuator.apply(da_cmd)
        u_motor = out.motor_voltage_v
        if k < n:
            x_next, aux, stats = plant.step(x, u_motor, p_true, ts, splits)
        else:  # the final row: the state at the end, the last input still applied
            aux = plant.aux(x, u_motor, p_true)
            stats = np.array([aux[4], aux[5], abs(aux[2]), abs(aux[3]), abs(aux[6]), abs(aux[7])])
            x_next = x

        # log row k
        cols["t_s"][k] = t[k]
        cols["da_code_left"][k], cols["da_code_right"][k] = out.da_code
        cols["da_voltage_left_v"][k], cols["da_voltage_right_v"][k] = out.da_voltage_v
        cols["da_clipped_left"][k], cols["da_clipped_right"][k] = out.da_clipped
        cols["motor_voltage_left_v"][k], cols["motor_voltage_right_v"][k] = u_motor
        cols["da_command_left_v"][k], cols["da_command_right_v"][k] = da_cmd
        for name in (
            "current_left_a",
            "current_right_a",
            "omega_motor_left_rad_s",
            "omega_motor_right_rad_s",
            "wheel_accel_left_m_s2",
            "wheel_accel_right_m_s2",
            "speed_m_s",
            "yaw_rate_rad_s",
        ):
            cols[name][k] = aux[aux_idx[name]]
        for name in STATS_NAMES:
            cols[name][k] = stats[stats_idx[name]]
        cols["current_limited_left"][k] = stats[0] > 0
        cols["current_limited_right"][k] = stats[1] > 0
        cols["x_m"][k], cols["y_m"][k], cols["theta_rad"][k] = x[2], x[3], x[4]
        cols["est_x_m"][k], cols["est_y_m"][k], cols["est_theta_rad"][k] = est
        cols["setpoint_wheel_speed_left_m_s"][k], cols["setpoint_wheel_speed_right_m_s"][k] = setpoint
        cols["setpoint_omega_motor_left_rad_s"][k], cols["setpoint_omega_motor_right_rad_s"][k] = sp_motor
        cols["solve_time_s"][k] = solve
        cols["solver_status"][k] = status
        x = x_next
        if progress is not None and k % progress_every == 0:
            progress(k / n)
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)

    cols["wheel_speed_left_m_s"] = cols["omega_motor_left_rad_s"] * true_rim_per_motor[0]
    cols["wheel_speed_right_m_s"] = cols["omega_motor_right_rad_s"] * true_rim_per_motor[1]
    cols["ref_x_m"], cols["ref_y_m"], cols["ref_theta_rad"] = ref.x_m, ref.y_m, ref.theta_rad
    cols["ref_wheel_speed_left_m_s"] = ref.wheel_speed_left_m_s
    cols["ref_wheel_speed_right_m_s"] = ref.wheel_speed_right_m_s
    cols["position_error_m"] = np.hypot(cols["x_m"] - ref.x_m, cols["y_m"] - ref.y_m)
    cols["heading_error_rad"] = _wrap(cols["theta_rad"] - ref.theta_rad)
    return ClosedLoopResult(
        log=SimLog(cols),
        reference=reference,
        wall_time_s=wall,
        setup_time_s=setup,
        solver_failures=failures,
        n_samples=n,
        sample_period_s=ts,
    )
