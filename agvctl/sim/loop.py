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
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.base import PoseCommand, PoseController, WheelSpeedController
from agvctl.errors import ConfigError
from agvctl.estimation.base import (
    CALIBRATION_COLUMNS,
    PoseEstimator,
    WheelSpeedEstimator,
    calibration_readout,
    consistency,
)
from agvctl.estimation.registry import ESTIMATORS, WHEEL_SPEED_ESTIMATORS
from agvctl.evaluation.metrics import NON_FINITE_COMMAND_STATUS
from agvctl.evaluation.path_metrics import path_error_columns
from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.params import SIDES, VehicleParams
from agvctl.params.schema import check_sample_count
from agvctl.planning.reference import Reference, ReferenceSamples
from agvctl.plant.full import PlantOptions
from agvctl.sensing import SENSOR_READING_COLUMNS, Measurements, Sensors
from agvctl.sim.stepper import PlantStepper

__all__ = ["CONTROL_LOG_COLUMNS", "SENSOR_NAN_COLUMNS", "ClosedLoopResult", "ComputeDelay", "run_closed_loop"]

ComputeDelay = Literal["none", "one_sample"]


class _ControlRow(NamedTuple):
    """What the loop records at each sample, by column name (plain floats)."""

    est_x_m: float
    est_y_m: float
    est_theta_rad: float
    setpoint_wheel_speed_left_m_s: float
    setpoint_wheel_speed_right_m_s: float
    setpoint_omega_motor_left_rad_s: float
    setpoint_omega_motor_right_rad_s: float
    da_command_left_v: float
    da_command_right_v: float
    solve_time_s: float
    solver_status: float
    motor_angle_left_rad: float
    motor_angle_right_rad: float
    measured_omega_motor_left_rad_s: float
    measured_omega_motor_right_rad_s: float
    encoder_count_left: float
    encoder_count_right: float
    gyro_rate_rad_s: float
    fix_x_m: float
    fix_y_m: float
    fix_theta_rad: float
    fix_measured_t_s: float
    est_sigma_x_m: float
    est_sigma_y_m: float
    est_sigma_theta_rad: float
    nees: float
    nis: float
    est_radius_error_left: float
    est_radius_error_right: float
    est_separation_error: float
    est_sigma_radius_error_left: float
    est_sigma_radius_error_right: float
    est_sigma_separation_error: float
    fixes_rejected: float
    fixes_dropped: float
    fixes_reordered: float


_SENSOR_COLUMNS = _ControlRow._fields[_ControlRow._fields.index("motor_angle_left_rad") :]
"""What the sensors read and the estimators made of it: the true shaft angles (the encoders' source), the motor
speeds the wheel loops used, the latched counts (and the rest of :data:`~agvctl.sensing.SENSOR_READING_COLUMNS`: the
gyro, the last fix arriving at the sample, NaN when none, with its measurement time), the estimate's σ and its NEES
against the truth, and the NIS of a fix (NaN for estimators without a covariance), then the odometry calibration
and the fixes' bookkeeping (:data:`~agvctl.estimation.base.CALIBRATION_COLUMNS`)."""
assert set(SENSOR_READING_COLUMNS) <= set(_SENSOR_COLUMNS)
assert _SENSOR_COLUMNS[-len(CALIBRATION_COLUMNS) :] == CALIBRATION_COLUMNS

SENSOR_NAN_COLUMNS = _SENSOR_COLUMNS[_SENSOR_COLUMNS.index("gyro_rate_rad_s") :]
"""The columns that are NaN where there is no reading: no gyro, no fix arriving, no covariance, no fix's NIS, no
calibration."""

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
pose controller solved, 1 for the shifted previous solution, 2 for the reference feed-forward, 3 for a NaN or
infinite command (the wheel loops get a stop, 0 m/s, instead; ``setpoint_*`` hold what they got); ``wheel_speed_*``
are the true rim speeds ω_mot·r/N of the plant. :class:`ClosedLoopResult` adds the errors against the path,
:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS` (cross-track error, along-track lag, path heading error)."""

_STATUS_CODE = {"solved": 0, "fallback_shifted": 1, "fallback_feedforward": 2}


@dataclass(frozen=True)
class ClosedLoopResult:
    """A closed-loop run: the full log (with the errors against the reference's path), its duration and timing."""

    log: SimLog
    reference: Reference
    wall_time_s: float
    """Wall time of the loop (controllers and plant), excluding setup and plots."""
    setup_time_s: float
    solver_failures: int
    n_samples: int
    sample_period_s: float


def _rim_per_motor(vehicle: VehicleParams) -> NDArray[np.float64]:
    """r/N per side (m/rad): motor speed (rad/s) to rim speed (m/s)."""
    return np.array([vehicle.rim_per_motor_rad(side) for side in SIDES])


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


class _RunLength:
    """How many samples the run takes. A controller on the loop's clock (``reference_done`` None) gets the
    reference's duration plus ``settle_s``; one that keeps its own clock runs until ``settle_s`` after it is done
    with the reference (again, if it resumes), at most twice the reference's duration (at least 30 s more) plus
    ``settle_s`` — a vehicle that has not reached the end by then is reported where it is."""

    def __init__(self, duration_s: float, settle_s: float, sample_period_s: float) -> None:
        ts = sample_period_s
        self.planned = max(int(math.ceil((duration_s + settle_s) / ts - 1e-9)), 1)
        self.longest = max(int(math.ceil((max(2.0 * duration_s, duration_s + 30.0) + settle_s) / ts - 1e-9)), 1)
        what = (
            f"the closed loop (a {duration_s:g} s reference, run up to twice as long, and settle_s = {settle_s:g} s, "
            f"at {ts:g} s a sample)"
        )
        check_sample_count(self.longest, "run_closed_loop", "reference", what)
        self.settle = int(math.ceil(settle_s / ts - 1e-9))
        self.samples = self.planned
        self._governed = False
        self._done_at: int | None = None

    def after(self, k: int, reference_done: bool | None) -> int:
        """The run's length in samples, after the controller's command at sample ``k``."""
        if reference_done is None:
            return self.samples
        if not self._governed:
            self._governed, self.samples = True, self.longest
        if reference_done and self._done_at is None:
            self._done_at = k
            self.samples = min(self.longest, max(self.planned, k + self.settle))
        elif not reference_done and self._done_at is not None:
            self._done_at, self.samples = None, self.longest
        return self.samples


def _estimators(
    vehicle: VehicleParams,
    localization: str | PoseEstimator,
    wheel_speed: str | WheelSpeedEstimator,
    initial_pose: tuple[float, float, float],
) -> tuple[PoseEstimator, WheelSpeedEstimator]:
    """The pose and wheel-speed estimators (by registry name, or given) on the controller's ``vehicle``, reset to
    ``initial_pose`` and to rest."""
    estimator = ESTIMATORS[localization](vehicle) if isinstance(localization, str) else localization
    estimator.reset(np.array(initial_pose, dtype=float))
    speeds = WHEEL_SPEED_ESTIMATORS[wheel_speed](vehicle) if isinstance(wheel_speed, str) else wheel_speed
    speeds.reset()
    return estimator, speeds


def _estimate_step(
    estimator: PoseEstimator, pose_controller: PoseController
) -> Callable[[Measurements], NDArray[np.float64]]:
    """The estimator's update, then, for a controller that wants to know how good its pose is (one with an
    ``observe_pose_covariance``) and an estimator that knows (one with a ``pose_covariance``), the estimate's
    covariance handed to the controller."""
    observe = getattr(pose_controller, "observe_pose_covariance", None)
    if observe is None or getattr(estimator, "pose_covariance", None) is None:
        return estimator.update

    def step(meas: Measurements) -> NDArray[np.float64]:
        est = estimator.update(meas)
        observe(np.asarray(getattr(estimator, "pose_covariance"), dtype=np.float64))  # noqa: B009 - not in the protocol
        return est

    return step


MAX_SETTLE_S = 600.0
"""The longest settling time after the reference (s), as in an experiment file."""


def _check_run(
    plant_vehicle: VehicleParams,
    sample_period_s: float,
    initial_pose: object,
    settle_s: float,
    compute_delay: str,
    sensor_seed: int,
) -> tuple[float, float, float] | None:
    """The run's arguments checked as an experiment file's are (the initial pose as three floats, or None)."""
    if plant_vehicle.control.sample_period_s != sample_period_s:
        raise ConfigError("run_closed_loop", "plant_vehicle", "must share the controller's control.sample_period_s")
    if not (isinstance(settle_s, int | float) and 0.0 <= settle_s <= MAX_SETTLE_S):
        raise ConfigError("run_closed_loop", "settle_s", f"must be within 0 … {MAX_SETTLE_S:g} s (got {settle_s!r})")
    if compute_delay not in ("none", "one_sample"):
        raise ConfigError("run_closed_loop", "compute_delay", f"must be 'none' or 'one_sample' (got {compute_delay!r})")
    if isinstance(sensor_seed, bool) or not isinstance(sensor_seed, int) or sensor_seed < 0:
        raise ConfigError("run_closed_loop", "sensor_seed", f"must be an integer >= 0 (got {sensor_seed!r})")
    if initial_pose is None:
        return None
    try:
        pose = tuple(float(v) for v in initial_pose)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise ConfigError("run_closed_loop", "initial_pose", "expected (x_m, y_m, theta_rad)") from None
    if len(pose) != 3 or not all(math.isfinite(v) and abs(v) <= 1e4 for v in pose):
        raise ConfigError("run_closed_loop", "initial_pose", f"expected 3 finite numbers within ±1e4 (got {pose})")
    return (pose[0], pose[1], pose[2])


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
    of :data:`~agvctl.estimation.registry.ESTIMATORS` (built for the controller's vehicle) or is one;
    ``wheel_speed`` likewise names one of :data:`~agvctl.estimation.registry.WHEEL_SPEED_ESTIMATORS` or is one.
    ``sensor_seed`` seeds the true vehicle's sensor noise. ``progress``, if given, is called with the fraction done
    (0…1) about every second of simulated time. A controller that keeps its own clock (its commands'
    :attr:`~agvctl.controllers.base.PoseCommand.reference_done` set) sets the run's length.

    Raises ``ConfigError`` (``run_closed_loop: <argument>: <problem>``) for an argument no experiment file can hold.
    """
    t_setup = time.perf_counter()
    ts = controller_vehicle.control.sample_period_s
    initial_pose = _check_run(plant_vehicle, ts, initial_pose, settle_s, compute_delay, sensor_seed)
    length = _RunLength(reference.duration_s, settle_s, ts)
    if initial_pose is None:
        ref0 = reference.sample(np.zeros(1))
        initial_pose = (float(ref0.x_m[0]), float(ref0.y_m[0]), float(ref0.theta_rad[0]))
    plant = PlantStepper(plant_vehicle, initial_state=[0.0, 0.0, *initial_pose], options=plant_options)
    estimator, speeds = _estimators(controller_vehicle, localization, wheel_speed, initial_pose)
    sensors = Sensors(plant_vehicle, seed=sensor_seed)
    rim_per_motor = _rim_per_motor(controller_vehicle)  # the controller's belief
    delay = _Delay(compute_delay)
    pose_controller.reset(reference)
    wheel_controller.reset()
    rows: list[_ControlRow] = []
    estimate = _estimate_step(estimator, pose_controller)
    failures, n, k = 0, length.samples, 0
    progress_every = max(1, int(round(1.0 / ts)))
    setup = time.perf_counter() - t_setup
    t0 = time.perf_counter()
    while True:
        angle = plant.motor_angle_rad  # 1. measure and estimate
        counts = sensors.encoder_counts(angle)
        omega = speeds.update(counts, plant.measure())
        wheel_meas = omega * rim_per_motor
        meas = sensors.read(k, counts, plant.pose, wheel_meas)
        est = estimate(meas)
        tc = time.perf_counter()  # 2. pose controller
        cmd = pose_controller.update(k * ts, est, wheel_meas)
        solve = time.perf_counter() - tc
        n = length.after(k, cmd.reference_done)
        status, commanded = _checked_command(cmd)
        failures += status > 0
        setpoint = delay(commanded)
        sp_motor = setpoint / rim_per_motor
        da_cmd = wheel_controller.update(sp_motor, omega)  # 3. wheel-speed loops
        speeds.applied(da_cmd)
        if k < n:  # 4. actuator and plant; the final row holds the state at the end, the last input applied
            plant.step(da_cmd)
        else:
            plant.finish(da_cmd)
        rows.append(_control_row(est, setpoint, sp_motor, da_cmd, solve, status, angle, omega, counts, meas, estimator))
        if progress is not None and k % progress_every == 0:
            progress(k / n)
        if k >= n:
            break
        k += 1
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    ref = reference.sample(np.arange(n + 1) * ts)
    log = _closed_loop_log(plant.log(), rows, ref, _rim_per_motor(plant_vehicle), reference)
    return ClosedLoopResult(log, reference, wall, setup, failures, n, ts)


def _checked_command(cmd: PoseCommand) -> tuple[int, NDArray[np.float64]]:
    """(solver status code, wheel-speed setpoints in m/s) of a pose controller's command: a NaN or infinite
    setpoint is a controller failure (:data:`~agvctl.evaluation.metrics.NON_FINITE_COMMAND_STATUS`) and the wheel
    loops get a stop instead, never a silent 0 V from the DA converter."""
    setpoint = np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s], dtype=np.float64)
    if not np.all(np.isfinite(setpoint)):
        return NON_FINITE_COMMAND_STATUS, np.zeros(2)
    return _STATUS_CODE.get(cmd.status, 2), setpoint


def _control_row(
    est: NDArray[np.float64],
    setpoint: NDArray[np.float64],
    sp_motor: NDArray[np.float64],
    da_cmd: NDArray[np.float64],
    solve_s: float,
    status: int,
    angle: NDArray[np.float64],
    omega: NDArray[np.float64],
    counts: NDArray[np.int64],
    meas: Measurements,
    estimator: PoseEstimator,
) -> _ControlRow:
    """One sample's record, with the estimator's consistency and calibration."""
    checks = (*consistency(estimator, est, meas.true_pose), *calibration_readout(estimator))
    x, y, theta = np.asarray(est, dtype=np.float64).tolist()
    sp_l, sp_r = setpoint.tolist()
    spm_l, spm_r = sp_motor.tolist()
    da_l, da_r = da_cmd.tolist()
    angle_l, angle_r = angle.tolist()
    omega_l, omega_r = omega.tolist()
    count_l, count_r = counts.tolist()
    fix = meas.fixes[-1].pose if meas.fixes else (math.nan, math.nan, math.nan)
    fix_t = meas.fixes[-1].measured_t_s if meas.fixes else math.nan
    return _ControlRow(
        x, y, theta, sp_l, sp_r, spm_l, spm_r, da_l, da_r, solve_s, float(status), angle_l, angle_r, omega_l, omega_r,
        float(count_l), float(count_r), meas.gyro_rate_rad_s, float(fix[0]), float(fix[1]), float(fix[2]), fix_t,
        *checks,
    )  # fmt: skip


def _closed_loop_log(
    plant_log: SimLog,
    rows: list[_ControlRow],
    ref: ReferenceSamples,
    true_rim_per_motor: NDArray[np.float64],
    reference: Reference,
) -> SimLog:
    """The plant's columns, the control columns recorded per sample, those derived from the reference and the
    errors against the reference's path (:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS`, computed once for
    the whole run from its poses: one k-d tree on the path, none of it in the per-sample loop)."""
    cols = dict(plant_log.columns)
    control = np.array(rows, dtype=np.float64)
    cols.update({name: control[:, j] for j, name in enumerate(_ControlRow._fields)})
    cols["wheel_speed_left_m_s"] = cols["omega_motor_left_rad_s"] * true_rim_per_motor[0]
    cols["wheel_speed_right_m_s"] = cols["omega_motor_right_rad_s"] * true_rim_per_motor[1]
    cols["ref_x_m"], cols["ref_y_m"], cols["ref_theta_rad"] = ref.x_m, ref.y_m, ref.theta_rad
    cols["ref_wheel_speed_left_m_s"] = ref.wheel_speed_left_m_s
    cols["ref_wheel_speed_right_m_s"] = ref.wheel_speed_right_m_s
    cols["position_error_m"] = np.hypot(cols["x_m"] - ref.x_m, cols["y_m"] - ref.y_m)
    cols["heading_error_rad"] = wrap_angle(cols["theta_rad"] - ref.theta_rad)
    ordered = {name: cols[name] for name in (*PLANT_LOG_COLUMNS, *CONTROL_LOG_COLUMNS)}
    ordered.update(path_error_columns(cols["t_s"], cols["x_m"], cols["y_m"], cols["theta_rad"], reference))
    return SimLog(ordered)
