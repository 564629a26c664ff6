"""Estimation on logged data: every estimator, the EKF and an RTS smoother over a closed-loop ``log.csv``.

A closed-loop log records what the sensors read (``encoder_count_*``, ``gyro_rate_rad_s``, the fixes as they
arrived with ``fix_measured_t_s``), so the estimators can be run again offline, with other settings or another
believed vehicle::

    from agvctl.params import load_vehicle
    from agvctl.estimation.offline import filter_log, read_log, smooth_log

    log = read_log("out/figure8_ekf/log.csv")
    smoothed = smooth_log(log, load_vehicle())        # est_x_m, est_y_m, est_theta_rad, est_sigma_*, ...

:func:`estimate_log` runs any pose estimator (a name of :data:`~agvctl.estimation.registry.ESTIMATORS`, or yours) and
:func:`wheel_speeds_log` any wheel-speed estimator over the logged readings, fed as the loop fed them.
:func:`filter_log` replays the causal EKF exactly as the loop ran it (fixes applied when they arrived, with or
without latency compensation). :func:`smooth_log` knows the whole run: each fix is applied at the sample it was
measured (no latency to handle offline), then a Rauch-Tung-Striebel backward pass gives every sample the
estimate from all the data. Only the last fix arriving at a sample is logged (fix rates up to 1/T_s).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.config import MAX_LOG_BYTES, read_text
from agvctl.errors import ConfigError, expect_instance
from agvctl.estimation.base import PoseEstimator, TruthSensor, WheelSpeedEstimator
from agvctl.estimation.ekf import CALIBRATION_STATES, EkfSettings, PoseEkf
from agvctl.estimation.registry import ESTIMATORS, WHEEL_SPEED_ESTIMATORS
from agvctl.log import SimLog
from agvctl.params import SIDES, VehicleParams
from agvctl.sensing import SENSOR_READING_COLUMNS, Measurements, PositionFix, Sensors

__all__ = [
    "ESTIMATE_COLUMNS",
    "estimate_log",
    "filter_log",
    "log_encoder_counts",
    "log_fixes",
    "read_log",
    "resense_log",
    "smooth_log",
    "wheel_speeds_log",
]

FloatArray = NDArray[np.float64]

ESTIMATE_COLUMNS = (
    "t_s",
    "est_x_m",
    "est_y_m",
    "est_theta_rad",
    "est_sigma_x_m",
    "est_sigma_y_m",
    "est_sigma_theta_rad",
    *CALIBRATION_STATES,
    *(f"{name}_sigma" for name in CALIBRATION_STATES),
    "nees",
)
"""The columns :func:`filter_log` and :func:`smooth_log` return (``radius_error_*``, ``separation_error``: the
calibration states ε, relative, and their σ;
``nees``: eᵀP⁻¹e of the pose against the log's true pose, 3 degrees of freedom, NaN for a log without it)."""


def read_log(path: str | Path) -> SimLog:
    """Read a log written by :meth:`SimLog.to_csv` (``agvctl run``'s ``log.csv``).

    Parameters
    ----------
    path : str or Path
        The CSV file: a header naming the columns, then one row per sample. A byte-order mark (Excel's "CSV
        UTF-8") is dropped.

    Returns
    -------
    SimLog
        Every column as floats.

    Raises
    ------
    ConfigError
        One line naming the file and, where it applies, the line: a missing or unreadable file, an empty file or
        header, a row of another length than the header, a cell that is not a number (NaN is kept: the log writes
        it for values that do not apply).
    """
    source = str(path)
    rows = list(csv.reader(read_text(path, MAX_LOG_BYTES).splitlines()))
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise ConfigError(source, "", "empty file (expected a header row naming the columns)")
    header = [h.strip() for h in rows[0]]
    data = np.empty((len(rows) - 1, len(header)))
    for i, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise ConfigError(source, f"line {i + 2}", f"expected {len(header)} cells (got {len(row)})")
        try:
            data[i] = [float(cell) for cell in row]
        except ValueError:
            bad = next(c for c in row if not _is_number(c))
            raise ConfigError(source, f"line {i + 2}", f"not a number: {bad[:40]!r}") from None
    return SimLog({name: np.array(data[:, j]) for j, name in enumerate(header)})


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def resense_log(log: SimLog, vehicle: VehicleParams, *, seed: int) -> SimLog:
    """A log with its sensor columns read again with another noise seed: the same true run, another sensor
    realisation (for Monte Carlo consistency checks of an estimator).

    Parameters
    ----------
    log : SimLog
        A closed-loop log with the true shaft angles and pose.
    vehicle : VehicleParams
        The true vehicle, whose sensors read: counts from the true shaft angles, gyro and fixes from the true pose.
    seed : int
        The sensors' noise seed.

    Returns
    -------
    SimLog
        A copy of ``log`` with new sensor columns.
    """
    sensors = Sensors(vehicle, seed=seed)
    angles = np.column_stack([log["motor_angle_left_rad"], log["motor_angle_right_rad"]])
    poses = np.column_stack([log["x_m"], log["y_m"], log["theta_rad"]])
    cols = dict(log.columns)
    new = {name: np.full(len(log), math.nan) for name in SENSOR_READING_COLUMNS}
    for k in range(len(log)):
        counts = sensors.encoder_counts(angles[k])
        meas = sensors.read(k, counts, poses[k], np.zeros(2))
        new["encoder_count_left"][k], new["encoder_count_right"][k] = counts
        new["gyro_rate_rad_s"][k] = meas.gyro_rate_rad_s
        if meas.fixes:
            fix = meas.fixes[-1]
            new["fix_x_m"][k], new["fix_y_m"][k], new["fix_theta_rad"][k] = fix.pose
            new["fix_measured_t_s"][k] = fix.measured_t_s
    cols.update(new)
    return SimLog(cols)


def log_fixes(log: SimLog, ts: float) -> list[tuple[PositionFix, ...]]:
    """The fixes arriving at each sample of a log, from its ``fix_*`` columns.

    Parameters
    ----------
    log : SimLog
        A closed-loop log.
    ts : float
        Its sample period T_s, s.

    Returns
    -------
    list of tuple of PositionFix
        Per sample, the fix that arrived then (none, or one: the log keeps the last one of a sample).
    """
    out: list[tuple[PositionFix, ...]] = []
    for t_meas, x, y, th in zip(
        log["fix_measured_t_s"], log["fix_x_m"], log["fix_y_m"], log["fix_theta_rad"], strict=True
    ):
        if math.isnan(t_meas):
            out.append(())
        else:
            j = int(round(t_meas / ts))
            out.append((PositionFix(j, j * ts, np.array([x, y, th])),))
    return out


def _start(log: SimLog) -> FloatArray:
    """The pose the loop started the estimator from: the first row's estimate."""
    return np.array([log["est_x_m"][0], log["est_y_m"][0], log["est_theta_rad"][0]])


def log_encoder_counts(log: SimLog) -> NDArray[np.int64]:
    """The latched encoder counts of a log.

    Parameters
    ----------
    log : SimLog
        A closed-loop log.

    Returns
    -------
    ndarray of int
        Samples × 2: left, right.
    """
    return np.column_stack([log["encoder_count_left"], log["encoder_count_right"]]).round().astype(np.int64)


def _table(log: SimLog, states: FloatArray, covs: FloatArray) -> SimLog:
    sig = np.sqrt(np.diagonal(covs, axis1=1, axis2=2))
    nees = np.full(len(log), math.nan)
    if "x_m" in log:
        e = states[:, :3] - np.column_stack([log["x_m"], log["y_m"], log["theta_rad"]])
        e[:, 2] = wrap_angle(e[:, 2])
        nees = np.einsum("ki,ki->k", e, np.linalg.solve(covs[:, :3, :3], e[:, :, None])[:, :, 0])
    cols = [log["t_s"], *states[:, :3].T, *sig[:, :3].T, *states[:, 3:].T, *sig[:, 3:].T, nees]
    return SimLog({name: np.asarray(c, dtype=float) for name, c in zip(ESTIMATE_COLUMNS, cols, strict=True)})


def _pair(log: SimLog, name: str) -> FloatArray:
    return np.column_stack([log[name.format("left")], log[name.format("right")]])


def estimate_log(log: SimLog, vehicle: VehicleParams, localization: str | PoseEstimator = "odometry") -> SimLog:
    """A pose estimator run over a log, started at the log's first estimate and fed each row's readings as the loop
    fed them.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with its sensor columns.
    vehicle : VehicleParams
        The believed vehicle.
    localization : str or PoseEstimator
        A name of :data:`~agvctl.estimation.registry.ESTIMATORS`, or an estimator of your own.

    Returns
    -------
    SimLog
        ``t_s``, ``est_x_m``, ``est_y_m``, ``est_theta_rad``.
    """
    estimator = ESTIMATORS[localization](vehicle) if isinstance(localization, str) else localization
    estimator.reset(_start(log))
    rim_per_motor = np.array([vehicle.rim_per_motor_rad(side) for side in SIDES])
    counts, fixes = log_encoder_counts(log), log_fixes(log, vehicle.control.sample_period_s)
    poses = np.column_stack([log["x_m"], log["y_m"], log["theta_rad"]])
    wheel = _pair(log, "measured_omega_motor_{}_rad_s") * rim_per_motor
    true_omega = _pair(log, "omega_motor_{}_rad_s")
    truth = estimator if isinstance(estimator, TruthSensor) else None  # a perfect sensor reads the log's truth
    t, gyro = log["t_s"], log["gyro_rate_rad_s"]
    est = np.empty((len(log), 3))
    for k in range(len(log)):
        if truth is not None:
            truth.observe_truth(poses[k], true_omega[k])
        meas = Measurements(k, float(t[k]), wheel[k], counts[k], float(gyro[k]), fixes[k])
        est[k] = estimator.update(meas)
    return SimLog({"t_s": np.array(t), "est_x_m": est[:, 0], "est_y_m": est[:, 1], "est_theta_rad": est[:, 2]})


def wheel_speeds_log(log: SimLog, vehicle: VehicleParams, wheel_speed: str | WheelSpeedEstimator = "kalman") -> SimLog:
    """A wheel-speed estimator run over a log's counts and DA commands.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with its counts and DA commands.
    vehicle : VehicleParams
        The believed vehicle.
    wheel_speed : str or WheelSpeedEstimator
        A name of :data:`~agvctl.estimation.registry.WHEEL_SPEED_ESTIMATORS`, or an estimator of your own.

    Returns
    -------
    SimLog
        ``t_s``, ``omega_motor_left_rad_s``, ``omega_motor_right_rad_s``.
    """
    speeds = WHEEL_SPEED_ESTIMATORS[wheel_speed](vehicle) if isinstance(wheel_speed, str) else wheel_speed
    speeds.reset()
    counts, true_omega = log_encoder_counts(log), _pair(log, "omega_motor_{}_rad_s")
    poses = np.column_stack([log["x_m"], log["y_m"], log["theta_rad"]])
    truth = speeds if isinstance(speeds, TruthSensor) else None  # a perfect sensor reads the log's truth
    commands = _pair(log, "da_command_{}_v")
    omega = np.empty((len(log), 2))
    for k in range(len(log)):
        if truth is not None:
            truth.observe_truth(poses[k], true_omega[k])
        omega[k] = speeds.update(counts[k])
        speeds.applied(commands[k])
    return SimLog(
        {"t_s": np.array(log["t_s"]), "omega_motor_left_rad_s": omega[:, 0], "omega_motor_right_rad_s": omega[:, 1]}
    )


def filter_log(
    log: SimLog,
    vehicle: VehicleParams,
    settings: EkfSettings | None = None,
    *,
    initial_pose: FloatArray | None = None,
) -> SimLog:
    """The causal EKF over a log, as the loop runs it.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with its sensor columns (a run's ``log.csv`` through :func:`read_log`, or
        :attr:`ClosedLoopResult.log <agvctl.sim.loop.ClosedLoopResult>`).
    vehicle : VehicleParams
        The believed vehicle (what the controllers believed in the run).
    settings : EkfSettings or None
        The EKF's tuning; None: :class:`~agvctl.estimation.ekf.EkfSettings`'s defaults.
    initial_pose : ndarray or None
        The start: x (m), y (m), heading (rad); None: the log's first estimate, as the loop did.

    Returns
    -------
    SimLog
        The estimate per sample: ``est_x_m``, ``est_y_m``, ``est_theta_rad``, their σ, the radius errors, NEES
        and NIS."""
    expect_instance(log, SimLog, "filter_log", "log")
    expect_instance(vehicle, VehicleParams, "filter_log", "vehicle")
    if settings is not None:
        expect_instance(settings, EkfSettings, "filter_log", "settings")
    ekf = PoseEkf(vehicle, settings)
    ekf.reset(_start(log) if initial_pose is None else np.asarray(initial_pose, dtype=float))
    counts, gyro, fixes = (
        log_encoder_counts(log),
        log["gyro_rate_rad_s"],
        log_fixes(log, vehicle.control.sample_period_s),
    )
    n = len(ekf.x)
    states, covs = np.empty((len(log), n)), np.empty((len(log), n, n))
    for k in range(len(log)):
        ekf.step(k, counts[k], float(gyro[k]), fixes[k])
        states[k], covs[k] = ekf.x, ekf.P
    return _table(log, states, covs)


def smooth_log(log: SimLog, vehicle: VehicleParams, settings: EkfSettings | None = None) -> SimLog:
    """The Rauch-Tung-Striebel smoothed estimate over a log: the EKF forward with every fix at the sample it was
    measured, then backwards ``x_s,k = x_k + C_k (x_s,k+1 − x⁻_k+1)``, ``C_k = P_k F_k+1ᵀ (P⁻_k+1)⁻¹``.

    Parameters
    ----------
    log : SimLog
        A closed-loop log with its sensor columns.
    vehicle : VehicleParams
        The believed vehicle.
    settings : EkfSettings or None
        The EKF's tuning; None: :class:`~agvctl.estimation.ekf.EkfSettings`'s defaults.

    Returns
    -------
    SimLog
        The smoothed estimate per sample, in the columns of :func:`filter_log`."""
    expect_instance(log, SimLog, "smooth_log", "log")
    expect_instance(vehicle, VehicleParams, "smooth_log", "vehicle")
    if settings is not None:
        expect_instance(settings, EkfSettings, "smooth_log", "settings")
    ekf = PoseEkf(vehicle, settings)
    ekf.reset(_start(log))
    n, m, ts = len(log), len(ekf.x), vehicle.control.sample_period_s
    counts, gyro = log_encoder_counts(log), log["gyro_rate_rad_s"]
    by_sample: dict[int, list[PositionFix]] = {}
    for arrived in log_fixes(log, ts):
        for fix in arrived:
            by_sample.setdefault(fix.measured_sample, []).append(fix)
    x, P = ekf.x.copy(), ekf.P.copy()
    xs, Ps = np.empty((n, m)), np.empty((n, m, m))
    x_pred, P_pred, Fs = np.empty((n, m)), np.empty((n, m, m)), np.empty((n, m, m))
    for k in range(n):
        if k > 0:
            d = (counts[k] - counts[k - 1]) * ekf.metres_per_count
            travel = np.array([d[0], d[1], (gyro[k] - vehicle.sensors.gyro_bias_rad_s) * ts])
            x, F, Q = ekf.transition(x, travel)
            P = F @ P @ F.T + Q
            Fs[k] = F
        x_pred[k], P_pred[k] = x, P
        for fix in by_sample.get(k, []):
            x, P, _nis = ekf.fix_update(x, P, fix.pose)
        xs[k], Ps[k] = x, P
    for k in range(n - 2, -1, -1):  # the backward pass
        C = np.linalg.solve(P_pred[k + 1], Fs[k + 1] @ Ps[k]).T
        xs[k] = xs[k] + C @ (xs[k + 1] - x_pred[k + 1])
        Ps[k] = Ps[k] + C @ (Ps[k + 1] - P_pred[k + 1]) @ C.T
    return _table(log, xs, Ps)
