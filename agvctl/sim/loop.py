"""The closed loop: reference → pose controller → wheel-speed loops → DA/amplifier → full plant, every T_s.

A plain loop over control ticks t_k = k·T_s (never t += dt). At each tick, following the sample-and-hold rule:

1. measure: the sensors of the true vehicle (:mod:`agvctl.sensing`: encoder counts latched at t_k, gyro,
   position fixes arriving), the motor speeds (:mod:`agvctl.estimation.wheel_speed`: the true ones, or estimated
   from the counts) and estimate the pose (:mod:`agvctl.estimation`: the true pose, odometry from the counts with the
   *controller's* belief of r and b, or the EKF). The truth stays on this side: only a component declared a perfect
   sensor (:class:`~agvctl.estimation.base.TruthSensor`, the ``exact`` speeds and the ``truth`` pose) is handed it;
2. the pose controller computes wheel-speed setpoints from the pose, the measured wheel speeds and the
   reference (with ``compute_delay = "one_sample"`` the setpoints computed at t_k act from t_k+1);
3. the wheel-speed loops turn setpoint and measured motor speed into DA voltage commands;
4. the actuator chain (DA converter, amplifier) turns them into motor voltages, held over [t_k, t_k+1) while the
   full nonlinear plant is integrated with the *true* vehicle's parameters.

The controllers know only the controller vehicle (the nominal model); the plant may differ (``[plant] set``). The
components' optional parts (:class:`~agvctl.controllers.base.PoseCovarianceObserver`,
:class:`~agvctl.controllers.base.LimitReporting`, :class:`~agvctl.estimation.base.PoseCovarianceEstimator`,
:class:`~agvctl.estimation.base.CalibrationEstimator`, :class:`~agvctl.estimation.base.TruthSensor`) are small
protocols, checked once at set-up.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.controllers.base import LimitReporting, PoseController, PoseCovarianceObserver, WheelSpeedController
from agvctl.errors import ConfigError
from agvctl.estimation.base import PoseCovarianceEstimator, PoseEstimator, TruthSensor, WheelSpeedEstimator
from agvctl.estimation.registry import ESTIMATORS, WHEEL_SPEED_ESTIMATORS
from agvctl.evaluation.payload import PayloadAccelerometer
from agvctl.log import SimLog
from agvctl.params import SIDES, VehicleParams
from agvctl.params.schema import check_sample_count
from agvctl.planning.reference import Reference
from agvctl.plant.full import PlantOptions
from agvctl.sensing import Measurements, Sensors
from agvctl.sim.compiled_loop import LoopPlan, compiled_parts, run_compiled
from agvctl.sim.records import (
    CONTROL_LOG_COLUMNS,
    SENSOR_NAN_COLUMNS,
    _checked_command,
    _closed_loop_log,
    _control_row,
    _ControlRow,
    _estimator_readout,
)
from agvctl.sim.stepper import PlantStepper

__all__ = [
    "CONTROL_LOG_COLUMNS",
    "MAX_INITIAL_POSE",
    "SENSOR_NAN_COLUMNS",
    "ClosedLoopResult",
    "ComputeDelay",
    "run_closed_loop",
]

MAX_INITIAL_POSE = 1e4
"""The largest ``|x_m|``, ``|y_m|`` (m) and ``|theta_rad|`` of a run's initial pose: ten kilometres from the origin,
beyond any hall, and a heading still resolved to a micro-radian in double precision."""

ComputeDelay = Literal["none", "one_sample"]


@document_fields
@dataclass(frozen=True)
class ClosedLoopResult:
    """A closed-loop run: the full log (with the errors against the reference's path), its duration and timing."""

    log: SimLog
    """The log: :data:`~agvctl.log.PLANT_LOG_COLUMNS`, :data:`CONTROL_LOG_COLUMNS` and the errors against the
    reference's path (:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS`), one row per sample."""
    reference: Reference
    """The reference tracked."""
    wall_time_s: float
    """Wall time of the loop (controllers and plant), excluding setup and plots, s."""
    setup_time_s: float
    """Wall time of the setup (the plant compiled or loaded, the estimators and controllers reset), s."""
    solver_failures: int
    """Samples at which the pose controller fell back or commanded a non-finite setpoint."""
    n_samples: int
    """The run's length in samples: the log has one row more, the final state."""
    sample_period_s: float
    """The control sample period T_s, s."""
    loop: Literal["c", "python"] = "python"
    """Where the loop ran: ``"c"`` where every part had a compiled step (:mod:`agvctl.sim.compiled_loop`), else
    ``"python"``; the log is the same either way."""


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
    """The estimator's update, then, for a controller that wants to know how good its pose is
    (:class:`~agvctl.controllers.base.PoseCovarianceObserver`) and an estimator that knows
    (:class:`~agvctl.estimation.base.PoseCovarianceEstimator`), the estimate's covariance handed to the controller;
    decided once, here."""
    if not (isinstance(pose_controller, PoseCovarianceObserver) and isinstance(estimator, PoseCovarianceEstimator)):
        return estimator.update
    observer, known = pose_controller, estimator

    def step(meas: Measurements) -> NDArray[np.float64]:
        est = estimator.update(meas)
        observer.observe_pose_covariance(np.asarray(known.pose_covariance, dtype=np.float64))
        return est

    return step


def _truth_step(
    estimator: PoseEstimator, speeds: WheelSpeedEstimator
) -> Callable[[NDArray[np.float64], NDArray[np.float64]], None]:
    """What hands the true pose and motor speeds (rad/s) to the components declared perfect sensors
    (:class:`~agvctl.estimation.base.TruthSensor`), each sample before they update; decided once, here. A real
    estimator is never handed the truth."""
    perfect = [c for c in (estimator, speeds) if isinstance(c, TruthSensor)]

    def step(pose: NDArray[np.float64], omega_motor_rad_s: NDArray[np.float64]) -> None:
        for component in perfect:
            component.observe_truth(pose, omega_motor_rad_s)

    return step


def _limited_step(wheel_controller: WheelSpeedController) -> Callable[[], tuple[float, float]]:
    """Whether each wheel loop's output was just clamped (1.0 or 0.0), for a wheel controller that says
    (:class:`~agvctl.controllers.base.LimitReporting`); NaN for one that does not. Decided once, here."""
    if not isinstance(wheel_controller, LimitReporting):
        return lambda: (math.nan, math.nan)
    reporting = wheel_controller

    def step() -> tuple[float, float]:
        left, right = reporting.limited
        return float(bool(left)), float(bool(right))

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
    payload: object,
) -> tuple[float, float, float] | None:
    """The run's arguments checked as an experiment file's are (the initial pose as three floats, or None)."""
    if payload is not None and not isinstance(payload, PayloadAccelerometer):
        raise ConfigError("run_closed_loop", "payload", f"expected a PayloadAccelerometer (got {payload!r:.60})")
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
    if len(pose) != 3 or not all(math.isfinite(v) and abs(v) <= MAX_INITIAL_POSE for v in pose):
        raise ConfigError(
            "run_closed_loop", "initial_pose", f"expected 3 finite numbers within ±{MAX_INITIAL_POSE:g} (got {pose})"
        )
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
    payload: PayloadAccelerometer | None = None,
    progress: Callable[[float], None] | None = None,
    compiled: bool = True,
) -> ClosedLoopResult:
    """Run the cascade on the full plant for the reference's duration plus ``settle_s``.

    A controller that keeps its own clock (:attr:`~agvctl.controllers.base.PoseCommand.reference_done` set) sets the
    run's length instead. :func:`~agvctl.scenario.experiment.run_experiment` runs an experiment file.

    Parameters
    ----------
    plant_vehicle : VehicleParams
        The true vehicle: the plant, its actuator chain and its sensors.
    controller_vehicle : VehicleParams
        The vehicle the controllers and estimators believe in; its sample period T_s (s) is the loop's.
    reference : Reference
        The planned reference, tracked from its time 0 (the pose controller is reset to it).
    pose_controller : PoseController
        Wheel-speed setpoints (m/s) from the estimated pose and the measured wheel speeds.
    wheel_controller : WheelSpeedController
        DA voltage commands (V) from the setpoints and the measured motor speeds.
    initial_pose : tuple of float or None
        The vehicle's start: x (m), y (m), heading (rad); None: the reference's start.
    settle_s : float
        How long the run goes on after the reference ends, 0 … 600 s.
    compute_delay : {'none', 'one_sample'}
        ``"one_sample"`` applies the setpoints computed at t_k from t_k+1 on.
    localization : str or PoseEstimator
        A name of :data:`~agvctl.estimation.registry.ESTIMATORS` (built on ``controller_vehicle``), or one.
    wheel_speed : str or WheelSpeedEstimator
        A name of :data:`~agvctl.estimation.registry.WHEEL_SPEED_ESTIMATORS`, or one.
    sensor_seed : int
        The seed of the true sensors' noise, ≥ 0.
    plant_options : PlantOptions or None
        The nonlinear effects the plant includes (None: all of them).
    payload : PayloadAccelerometer or None
        The payload's accelerometer: its point and bandwidth (None: the axle's midpoint, the default bandwidth).
    progress : callable or None
        Called with the fraction done (0 … 1) about every second of simulated time.
    compiled : bool
        Run in C where every part has a compiled step (:mod:`agvctl.sim.compiled_loop`, the same log); or never.

    Returns
    -------
    ClosedLoopResult
        The run's log, timing and solver failures.

    Raises
    ------
    ConfigError
        ``run_closed_loop: <argument>: <problem>`` for an argument no experiment file can hold.
    """
    t_setup, ts = time.perf_counter(), controller_vehicle.control.sample_period_s
    given = _check_run(plant_vehicle, ts, initial_pose, settle_s, compute_delay, sensor_seed, payload)
    length, initial_pose = _RunLength(reference.duration_s, settle_s, ts), _start_pose(reference, given)
    plant = PlantStepper(plant_vehicle, initial_state=[0.0, 0.0, *initial_pose], options=plant_options)
    estimator, speeds = _estimators(controller_vehicle, localization, wheel_speed, initial_pose)
    pose_controller.reset(reference)
    wheel_controller.reset()
    parts = (plant, Sensors(plant_vehicle, seed=sensor_seed), estimator, speeds, pose_controller, wheel_controller)
    setup = time.perf_counter() - t_setup
    delay, rims = _Delay(compute_delay), _rim_per_motor(controller_vehicle)
    rows, failures, n, wall, where = _run_in_c_or_python(parts, delay, rims, length, progress, compiled)
    ref, payload = reference.sample(np.arange(n + 1) * ts), payload or PayloadAccelerometer()
    log = _closed_loop_log(plant.log(), rows, ref, _rim_per_motor(plant_vehicle), reference, payload, ts)
    return ClosedLoopResult(log, reference, wall, setup, failures, n, ts, where)


def _start_pose(reference: Reference, pose: tuple[float, float, float] | None) -> tuple[float, float, float]:
    """The run's initial pose: the one given, or the reference's start."""
    if pose is not None:
        return pose
    ref0 = reference.sample(np.zeros(1))
    return (float(ref0.x_m[0]), float(ref0.y_m[0]), float(ref0.theta_rad[0]))


_Parts = tuple[PlantStepper, Sensors, PoseEstimator, WheelSpeedEstimator, PoseController, WheelSpeedController]


def _run_in_c_or_python(
    parts: _Parts,
    delay: _Delay,
    rim_per_motor: NDArray[np.float64],
    length: _RunLength,
    progress: Callable[[float], None] | None,
    compiled: bool,
) -> tuple[list[_ControlRow] | NDArray[np.float64], int, int, float, Literal["c", "python"]]:
    """The loop in C where it can run there (and ``compiled``: the pose and the motor speeds the truth, the plant
    compiled; each controller's compiled step, or a call into Python), else in Python: (the control rows recorded,
    the solver failures, the run's length in samples, the wall time of the loop in s, where it ran)."""
    plant, sensors, estimator, speeds, pose_controller, wheel_controller = parts
    in_c = compiled_parts(plant, estimator, speeds, pose_controller, wheel_controller) if compiled else None
    if in_c is None:
        return (*_run(*parts, delay, rim_per_motor, length, progress), "python")
    one_sample = delay.kind == "one_sample"
    plan = LoopPlan(
        pose_controller, wheel_controller, rim_per_motor, length.samples, length.longest, length.after, one_sample
    )
    return (*run_compiled(in_c, plant, sensors, plan, progress), "c")


def _run(
    plant: PlantStepper,
    sensors: Sensors,
    estimator: PoseEstimator,
    speeds: WheelSpeedEstimator,
    pose_controller: PoseController,
    wheel_controller: WheelSpeedController,
    delay: _Delay,
    rim_per_motor: NDArray[np.float64],
    length: _RunLength,
    progress: Callable[[float], None] | None,
) -> tuple[list[_ControlRow], int, int, float]:
    """The loop over the samples, set up: (the rows recorded, the solver failures, the run's length in samples, the
    wall time of the loop in s)."""
    ts = plant.sample_period_s
    rows: list[_ControlRow] = []
    estimate = _estimate_step(estimator, pose_controller)
    truth = _truth_step(estimator, speeds)
    limited_now = _limited_step(wheel_controller)
    readout = _estimator_readout(estimator)
    failures, n, k = 0, length.samples, 0
    progress_every = max(1, int(round(1.0 / ts)))
    t0 = time.perf_counter()
    while True:
        angle = plant.motor_angle_rad  # 1. measure and estimate
        counts = sensors.encoder_counts(angle)
        pose = plant.pose
        truth(pose, plant.measure())
        omega = speeds.update(counts)
        wheel_meas = omega * rim_per_motor
        meas = sensors.read(k, counts, pose, wheel_meas)
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
        limited = limited_now()
        speeds.applied(da_cmd)
        if k < n:  # 4. actuator and plant; the final row holds the state at the end, the last input applied
            plant.step(da_cmd)
        else:
            plant.finish(da_cmd)
        sample = (est, setpoint, sp_motor, da_cmd, solve, status, limited, angle, omega, counts, meas, pose, readout)
        rows.append(_control_row(*sample))
        if progress is not None and k % progress_every == 0:
            progress(k / n)
        if k >= n:
            break
        k += 1
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    return rows, failures, n, wall
