"""What the closed loop records: one row of control columns per sample, and the run's log made of them, the plant's
columns, the reference's and the errors against the reference's path.

:data:`CONTROL_LOG_COLUMNS` are the columns the closed loop adds to the plant's
(:data:`~agvctl.log.PLANT_LOG_COLUMNS`); :mod:`agvctl.sim.loop` records one row of them per sample
(``_control_row``) and makes the log once at the end (``_closed_loop_log``), so that nothing per sample allocates
more than the row.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.base import PoseCommand
from agvctl.estimation.base import (
    CALIBRATION_COLUMNS,
    CalibrationEstimator,
    PoseCovarianceEstimator,
    PoseEstimator,
    consistency,
)
from agvctl.evaluation.metrics import NON_FINITE_COMMAND_STATUS
from agvctl.evaluation.path_metrics import path_error_columns
from agvctl.evaluation.payload import PayloadAccelerometer
from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.planning.reference import Reference, ReferenceSamples
from agvctl.sensing import SENSOR_READING_COLUMNS, Measurements

__all__ = ["CONTROL_LOG_COLUMNS", "SENSOR_NAN_COLUMNS"]


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
    wheel_loop_limited_left: float
    wheel_loop_limited_right: float
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
    "wheel_loop_limited_left",
    "wheel_loop_limited_right",
    *_SENSOR_COLUMNS,
)
"""Columns the closed loop adds to :data:`~agvctl.log.PLANT_LOG_COLUMNS`. ``solver_status`` is 0 when the
pose controller solved, 1 for the shifted previous solution, 2 for the reference feed-forward, 3 for a NaN or
infinite command (the wheel loops get a stop, 0 m/s, instead; ``setpoint_*`` hold what they got);
``wheel_loop_limited_*`` is 1 where the wheel loop's output was clamped to what the amplifier and the DA converter
give (its ``limited``), 0 where it was not, NaN for a wheel controller that does not say; ``wheel_speed_*``
are the true rim speeds ω_mot·r/N of the plant. :class:`ClosedLoopResult` adds the errors against the path,
:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS` (cross-track error, along-track lag, path heading error)."""

_STATUS_CODE = {"solved": 0, "fallback_shifted": 1, "fallback_feedforward": 2}


def _checked_command(cmd: PoseCommand) -> tuple[int, NDArray[np.float64]]:
    """(solver status code, wheel-speed setpoints in m/s) of a pose controller's command: a NaN or infinite
    setpoint is a controller failure (:data:`~agvctl.evaluation.metrics.NON_FINITE_COMMAND_STATUS`) and the wheel
    loops get a stop instead, never a silent 0 V from the DA converter."""
    left, right = cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s
    if not (math.isfinite(left) and math.isfinite(right)):
        return NON_FINITE_COMMAND_STATUS, np.zeros(2)
    return _STATUS_CODE.get(cmd.status, 2), np.array([left, right], dtype=np.float64)


_EstimatorReadout = Callable[[NDArray[np.float64], NDArray[np.float64]], tuple[float, ...]]
"""The estimator's consistency against the true pose and its calibration at one sample, from the estimate and the
true pose: the values of the columns from ``est_sigma_x_m`` on."""

_NO_CONSISTENCY = (math.nan,) * 5
_NO_CALIBRATION = (math.nan,) * len(CALIBRATION_COLUMNS)


def _estimator_readout(estimator: PoseEstimator) -> _EstimatorReadout:
    """What the log records of ``estimator`` at each sample, decided once by the optional protocols it satisfies
    (:class:`~agvctl.estimation.base.PoseCovarianceEstimator`,
    :class:`~agvctl.estimation.base.CalibrationEstimator`): NaN for what it does not have."""
    covariance = estimator if isinstance(estimator, PoseCovarianceEstimator) else None
    calibration = estimator if isinstance(estimator, CalibrationEstimator) else None

    def readout(est: NDArray[np.float64], true_pose: NDArray[np.float64]) -> tuple[float, ...]:
        checks = _NO_CONSISTENCY if covariance is None else consistency(covariance, est, true_pose)
        return (*checks, *(_NO_CALIBRATION if calibration is None else calibration.readout()))

    return readout


def _control_row(
    est: NDArray[np.float64],
    setpoint: NDArray[np.float64],
    sp_motor: NDArray[np.float64],
    da_cmd: NDArray[np.float64],
    solve_s: float,
    status: int,
    limited: tuple[float, float],
    angle: NDArray[np.float64],
    omega: NDArray[np.float64],
    counts: NDArray[np.int64],
    meas: Measurements,
    true_pose: NDArray[np.float64],
    readout: _EstimatorReadout,
) -> _ControlRow:
    """One sample's record, with the estimator's consistency against ``true_pose`` and its calibration."""
    checks = readout(est, true_pose)
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
        x, y, theta, sp_l, sp_r, spm_l, spm_r, da_l, da_r, solve_s, float(status), *limited, angle_l, angle_r,
        omega_l, omega_r, float(count_l), float(count_r), meas.gyro_rate_rad_s, float(fix[0]), float(fix[1]),
        float(fix[2]), fix_t,
        *checks,
    )  # fmt: skip


def _closed_loop_log(
    plant_log: SimLog,
    rows: list[_ControlRow] | NDArray[np.float64],
    ref: ReferenceSamples,
    true_rim_per_motor: NDArray[np.float64],
    reference: Reference,
    payload: PayloadAccelerometer,
    sample_period_s: float,
) -> SimLog:
    """The plant's columns, the control columns recorded per sample (rows of :class:`_ControlRow`, or their
    array), those derived from the reference, the
    errors against the reference's path (:data:`~agvctl.evaluation.path_metrics.PATH_LOG_COLUMNS`, computed once for
    the whole run from its poses: one k-d tree on the path, none of it in the per-sample loop) and what the
    payload's accelerometer reads (:data:`~agvctl.evaluation.payload.PAYLOAD_LOG_COLUMNS`, from the true motion)."""
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
    ordered.update(payload.read(cols["speed_m_s"], cols["yaw_rate_rad_s"], sample_period_s))
    return SimLog(ordered)
