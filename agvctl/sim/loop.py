"""The closed loop: reference → pose controller → wheel-speed loops → DA/amplifier → full plant, every T_s.

A plain loop over control ticks t_k = k·T_s (never t += dt). At each tick, following the sample-and-hold rule:

1. measure: the sensors of the true vehicle (:mod:`agvctl.sensing`: encoder counts latched at t_k, gyro,
   position fixes arriving), the motor speeds (:mod:`agvctl.estimation.wheel_speed`: the true ones, or estimated
   from the counts) and estimate the pose (:mod:`agvctl.estimation`: the true pose, odometry from the counts with the
   *controller's* belief of r and b, or the EKF);
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
from numpy.typing import ArrayLike, NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.base import GovernedPoseController, PoseController, WheelSpeedController
from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator, consistency
from agvctl.estimation.registry import ESTIMATORS, WHEEL_SPEED_ESTIMATORS
from agvctl.evaluation.path_metrics import PATH_LOG_COLUMNS, path_error_columns
from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference, ReferenceSamples
from agvctl.plant.full import PlantOptions
from agvctl.sensing import SENSOR_READING_COLUMNS, Measurements, Sensors
from agvctl.sim.stepper import PlantStepper

__all__ = ["CONTROL_LOG_COLUMNS", "SENSOR_NAN_COLUMNS", "ClosedLoopResult", "ComputeDelay", "run_closed_loop"]

ComputeDelay = Literal["none", "one_sample"]

_SENSOR_COLUMNS = (
    "motor_angle_left_rad",
    "motor_angle_right_rad",
    "measured_omega_motor_left_rad_s",
    "measured_omega_motor_right_rad_s",
    *SENSOR_READING_COLUMNS,
    "est_sigma_x_m",
    "est_sigma_y_m",
    "est_sigma_theta_rad",
    "nees",
    "nis",
)
"""What the sensors read and the estimators made of it: the true shaft angles (the encoders' source), the motor
speeds the wheel loops used, the latched counts, the gyro, the last fix arriving at the sample (NaN when none) with
its measurement time, the estimate's σ and its NEES against the truth, and the NIS of a fix (NaN for estimators
without a covariance)."""
SENSOR_NAN_COLUMNS = _SENSOR_COLUMNS[6:]
"""The columns that are NaN where there is no reading: no gyro, no fix arriving, no covariance, no fix's NIS."""

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
    *_SENSOR_COLUMNS,
)
"""Columns the closed loop adds to :data:`~agvctl.log.PLANT_LOG_COLUMNS`. ``solver_status`` is 0 when the
pose controller solved, 1 for the shifted previous solution, 2 for the reference feed-forward; ``wheel_speed_*``
are the true rim speeds ω_mot·r/N of the plant. :class:`ClosedLoopResult` adds the errors against the path,
:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS` (cross-track error, along-track lag, path heading error)."""

_PER_SAMPLE = (
    "est_x_m",
    "est_y_m",
    "est_theta_rad",
    "setpoint_wheel_speed_left_m_s",
    "setpoint_wheel_speed_right_m_s",
    "setpoint_omega_motor_left_rad_s",
    "setpoint_omega_motor_right_rad_s",
    "da_command_left_v",
    "da_command_right_v",
    "solve_time_s",
    "solver_status",
    *_SENSOR_COLUMNS,
)
"""The control columns recorded every sample, in the order of the loop's record line."""

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

    def __post_init__(self) -> None:
        """Complete the log with the errors against the reference's *path* (:data:`PATH_LOG_COLUMNS`), computed
        once for the whole run from its poses (one k-d tree on the path; none of this in the per-sample loop)."""
        log = self.log
        if all(name in log for name in ("x_m", "y_m", "theta_rad")) and not all(n in log for n in PATH_LOG_COLUMNS):
            errors = path_error_columns(log["t_s"], log["x_m"], log["y_m"], log["theta_rad"], self.reference)
            log.columns.update(errors)


def _rim_per_motor(vehicle: VehicleParams) -> NDArray[np.float64]:
    """r/N per side (m/rad): motor speed (rad/s) to rim speed (m/s)."""
    w, m = vehicle.wheels, vehicle.motor
    return np.array([w.radius_left_m / m.left.gear_ratio, w.radius_right_m / m.right.gear_ratio])


class _Delay:
    """The compute delay: ``one_sample`` applies at t_k+1 what was computed at t_k (at rest before the first)."""

    def __init__(self, kind: ComputeDelay) -> None:
        self.kind = kind
        self._pending = np.zeros(2)

    def __call__(self, setpoint: NDArray[np.float64]) -> NDArray[np.float64]:
        if self.kind == "none":
            return setpoint
        applied, self._pending = self._pending, setpoint
        return applied


def _longest_run(duration_s: float, settle_s: float, ts: float) -> int:
    """Samples a governed run may take at most: twice the reference's duration (at least 30 s more), then
    ``settle_s`` — a vehicle that has not reached the end by then is reported where it is."""
    return max(int(math.ceil((max(2.0 * duration_s, duration_s + 30.0) + settle_s) / ts - 1e-9)), 1)


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
    localization: str | PoseEstimator = "truth",
    wheel_speed: str | WheelSpeedEstimator = "exact",
    sensor_seed: int = 0,
    plant_options: PlantOptions | None = None,
    progress: Callable[[float], None] | None = None,
) -> ClosedLoopResult:
    """Run the cascade on the full plant for the reference's duration plus ``settle_s``.

    ``initial_pose`` (x_m, y_m, theta_rad) defaults to the reference's start. ``localization`` names an estimator
    of :data:`~agvctl.estimation.registry.ESTIMATORS` (built for the controller's vehicle) or is one; ``wheel_speed``
    likewise names one of :data:`~agvctl.estimation.wheel_speed.WHEEL_SPEED_ESTIMATORS` or is one. ``sensor_seed`` seeds
    the true vehicle's sensor noise. ``progress``, if given, is called with the fraction done (0…1) about every
    second of simulated time.
    """
    t_setup = time.perf_counter()
    ts = controller_vehicle.control.sample_period_s
    if plant_vehicle.control.sample_period_s != ts:
        raise ValueError("the plant and the controller must share control.sample_period_s")
    n_planned = max(int(math.ceil((reference.duration_s + settle_s) / ts - 1e-9)), 1)
    governor = pose_controller if isinstance(pose_controller, GovernedPoseController) else None
    n = n_longest = _longest_run(reference.duration_s, settle_s, ts) if governor is not None else n_planned
    t = np.arange(n + 1) * ts
    ref = reference.sample(t)
    start = (float(ref.x_m[0]), float(ref.y_m[0]), float(ref.theta_rad[0])) if initial_pose is None else initial_pose
    plant = PlantStepper(plant_vehicle, initial_state=[0.0, 0.0, *start], options=plant_options)
    estimator = ESTIMATORS[localization](controller_vehicle) if isinstance(localization, str) else localization
    estimator.reset(np.array(start, dtype=float))
    sensors = Sensors(plant_vehicle, seed=sensor_seed)
    speeds = WHEEL_SPEED_ESTIMATORS[wheel_speed](controller_vehicle) if isinstance(wheel_speed, str) else wheel_speed
    speeds.reset()
    rim_per_motor = _rim_per_motor(controller_vehicle)  # the controller's belief
    delay = _Delay(compute_delay)
    pose_controller.reset(reference)
    wheel_controller.reset()
    control: list[list[float]] = []  # the rows of _PER_SAMPLE, one per sample, as plain numbers
    failures = 0
    end_reached_k: int | None = None  # the sample at which a governed reference reached its end
    progress_every = max(1, int(round(1.0 / ts)))
    setup = time.perf_counter() - t_setup
    t0 = time.perf_counter()
    for k in range(n + 1):
        angle = plant.motor_angle_rad  # 1. measure and estimate
        counts = sensors.encoder_counts(angle)
        omega = speeds.update(counts, plant.measure())
        wheel_meas = omega * rim_per_motor
        meas = sensors.read(k, counts, plant.pose, wheel_meas)
        est = estimator.update(meas)
        tc = time.perf_counter()  # 2. pose controller
        cmd = pose_controller.update(float(t[k]), est, wheel_meas)
        solve = time.perf_counter() - tc
        if governor is not None:  # the run ends settle_s after the governed reference is done (again, if it resumes)
            done = governor.reference_time_s >= reference.duration_s - 1e-9
            if done and end_reached_k is None:
                end_reached_k = k
                n = min(n_longest, max(n_planned, k + int(math.ceil(settle_s / ts - 1e-9))))
            elif not done and end_reached_k is not None:
                end_reached_k, n = None, n_longest
        status = _STATUS_CODE.get(cmd.status, 2)
        failures += status > 0
        setpoint = delay(np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s]))
        sp_motor = setpoint / rim_per_motor
        da_cmd = wheel_controller.update(sp_motor, omega)  # 3. wheel-speed loops
        speeds.applied(da_cmd)
        if k < n:  # 4. actuator and plant; the final row holds the state at the end, the last input applied
            plant.step(da_cmd)
        else:
            plant.finish(da_cmd)
        checks = consistency(estimator, est, meas.true_pose)
        sensed = [*_plain(angle), *_plain(omega), *_plain(counts), *_sensor_row(meas), *checks]
        control.append([*_plain(est), *_plain(setpoint), *_plain(sp_motor), *_plain(da_cmd), solve, status, *sensed])
        if progress is not None and k % progress_every == 0:
            progress(k / n)
        if k >= n:
            break
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    ref = reference.sample(t[: n + 1])
    return ClosedLoopResult(
        log=_closed_loop_log(plant.log(), np.array(control, dtype=np.float64), ref, _rim_per_motor(plant_vehicle)),
        reference=reference,
        wall_time_s=wall,
        setup_time_s=setup,
        solver_failures=failures,
        n_samples=n,
        sample_period_s=ts,
    )


def _plain(values: ArrayLike) -> list[float]:
    """Values as plain Python floats, for a row of the log."""
    plain: list[float] = np.asarray(values, dtype=np.float64).tolist()
    return plain


def _sensor_row(meas: Measurements) -> tuple[float, ...]:
    """The gyro and the last fix arriving at this sample (its pose and measurement time; NaN when none)."""
    if not meas.fixes:
        return (meas.gyro_rate_rad_s, math.nan, math.nan, math.nan, math.nan)
    fix = meas.fixes[-1]
    return (meas.gyro_rate_rad_s, *fix.pose, fix.measured_t_s)


def _closed_loop_log(
    plant_log: SimLog, control: NDArray[np.float64], ref: ReferenceSamples, true_rim_per_motor: NDArray[np.float64]
) -> SimLog:
    """The plant's columns, the control columns recorded per sample and those derived from the reference."""
    cols = dict(plant_log.columns)
    cols.update({name: control[:, j] for j, name in enumerate(_PER_SAMPLE)})
    cols["wheel_speed_left_m_s"] = cols["omega_motor_left_rad_s"] * true_rim_per_motor[0]
    cols["wheel_speed_right_m_s"] = cols["omega_motor_right_rad_s"] * true_rim_per_motor[1]
    cols["ref_x_m"], cols["ref_y_m"], cols["ref_theta_rad"] = ref.x_m, ref.y_m, ref.theta_rad
    cols["ref_wheel_speed_left_m_s"] = ref.wheel_speed_left_m_s
    cols["ref_wheel_speed_right_m_s"] = ref.wheel_speed_right_m_s
    cols["position_error_m"] = np.hypot(cols["x_m"] - ref.x_m, cols["y_m"] - ref.y_m)
    cols["heading_error_rad"] = wrap_angle(cols["theta_rad"] - ref.theta_rad)
    return SimLog({name: cols[name] for name in (*PLANT_LOG_COLUMNS, *CONTROL_LOG_COLUMNS)})
