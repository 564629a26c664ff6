"""The closed loop run in C, where every part of it has a compiled step: the same samples, the same log.

Where the pose controller and the wheel controller are :class:`~agvctl.controllers.base.CompiledStep` ones (the
generated laws ``ramsete_c`` and ``ltv_lqr_c``, the generated loops ``pi_c``, or a user's own C behind the same
protocol), the pose and the motor speeds are the truth (``localization = "truth"``, ``wheel_speed = "exact"``) and
the plant is compiled, :func:`agvctl.sim.loop.run_closed_loop` hands the run to :func:`run_compiled`. A small C loop
(``templates/closed_loop.c.j2``) then calls the controllers' steps, the DA converter and the amplifier, and the
plant's compiled sample step, sample after sample, without coming back to Python; Python makes the log once at
the end from what the C recorded: the plant's columns through :meth:`~agvctl.sim.stepper.PlantStepper.append`, the
shaft angles and the encoder counts, and the sensors' readings (the gyro, the fixes), which nothing in such a loop
reads and which are drawn from the same seeded streams in the same order.

The C mirrors the Python loop's arithmetic operation by operation, so the two logs agree to the last bit, the
pose controller's measured computing time (``solve_time_s``, here the C step alone) excepted; the tests hold it
to that. The Python loop is the specification; this is the same loop, compiled.
"""

from __future__ import annotations

import ctypes
import functools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import CompiledStep, CStep, PoseController, WheelSpeedController
from agvctl.controllers.pi.c_loops import GeneratedC, compile_generated_c
from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator
from agvctl.estimation.odometry import TruthEstimator
from agvctl.estimation.wheel_speed import ExactSpeed
from agvctl.evaluation.metrics import NON_FINITE_COMMAND_STATUS
from agvctl.plant.codegen import CFunctionAddress, c_templates
from agvctl.plant.full import AUX_NAMES, STATE_NAMES
from agvctl.plant.integrator import STATS_NAMES, merge_stats
from agvctl.sensing import Sensors
from agvctl.sim.records import _NO_CALIBRATION, _NO_CONSISTENCY, _ControlRow
from agvctl.sim.stepper import PlantStepper

__all__ = ["CompiledParts", "compiled_parts", "run_compiled"]

_CONTROL = (
    "setpoint_wheel_speed_left_m_s",
    "setpoint_wheel_speed_right_m_s",
    "setpoint_omega_motor_left_rad_s",
    "setpoint_omega_motor_right_rad_s",
    "da_command_left_v",
    "da_command_right_v",
    "solve_time_s",
    "solver_status",
    "wheel_loop_limited_left",
    "wheel_loop_limited_right",
    "measured_omega_motor_left_rad_s",
    "measured_omega_motor_right_rad_s",
)
"""What the C records per sample (its ``control`` rows), by log column, in the C's order."""
_FALLBACK_STATUS = 2
"""The status of a compiled pose controller's fallback (the reference's wheel speeds, ``fallback_feedforward``)."""


class _Loop(ctypes.Structure):
    """The C's ``agv_loop``: what the loop is made of (the field order is the template's)."""

    _fields_ = [
        ("plant", ctypes.c_void_p),
        ("arg", ctypes.c_void_p),
        ("res", ctypes.c_void_p),
        ("iw", ctypes.c_void_p),
        ("w", ctypes.c_void_p),
        ("parameters", ctypes.c_void_p),
        ("substep_s", ctypes.c_double),
        ("splits", ctypes.c_long),
        ("friction", ctypes.c_long),
        ("dead_zone_rad_s", ctypes.c_double * 2),
        ("mid_v", ctypes.c_double),
        ("volts_per_code", ctypes.c_double),
        ("code_min", ctypes.c_double),
        ("code_max", ctypes.c_double),
        ("amplifier_gain", ctypes.c_double),
        ("voltage_limit_v", ctypes.c_double),
        ("pose", ctypes.c_void_p),
        ("pose_state", ctypes.c_void_p),
        ("wheels", ctypes.c_void_p),
        ("wheels_state", ctypes.c_void_p),
        ("rim_per_motor_m", ctypes.c_double * 2),
        ("one_sample_delay", ctypes.c_long),
    ]


@functools.cache
def _loop_function() -> ctypes._CFuncPtr:  # type: ignore[name-defined]
    """The C loop, rendered, compiled with the strict flags into the cache of compiled code, and loaded (once)."""
    values = {
        "n_state": len(STATE_NAMES),
        "n_aux": len(AUX_NAMES),
        "n_stats": len(STATS_NAMES),
        "n_control": len(_CONTROL),
        "non_finite_status": NON_FINITE_COMMAND_STATUS,
        "fallback_status": _FALLBACK_STATUS,
    }
    source = c_templates("agvctl.sim").get_template("closed_loop.c.j2").render(values)
    lib = compile_generated_c(GeneratedC("", source, "agv_closed_loop"), "closed loop")
    run = lib.agv_loop_run
    run.restype = ctypes.c_int
    pointer = ctypes.c_void_p
    run.argtypes = [pointer, ctypes.c_long, ctypes.c_long, ctypes.c_long, *[pointer] * 5]
    return run


@dataclass(frozen=True)
class CompiledParts:
    """The compiled steps of a closed loop that runs in C.

    Parameters
    ----------
    plant : CFunctionAddress
        The plant's compiled sample step.
    pose : CStep
        The pose controller's step (after its reset).
    wheels : CStep
        The wheel loops' step (after their reset).
    """

    plant: CFunctionAddress
    pose: CStep
    wheels: CStep


def compiled_parts(
    plant: PlantStepper,
    estimator: PoseEstimator,
    speeds: WheelSpeedEstimator,
    pose_controller: PoseController,
    wheel_controller: WheelSpeedController,
) -> CompiledParts | None:
    """The compiled steps of the loop, where every part has one; None where the loop runs in Python.

    Parameters
    ----------
    plant : PlantStepper
        The true vehicle.
    estimator : PoseEstimator
        The pose estimator: only the truth (``"truth"``) has nothing to compute.
    speeds : WheelSpeedEstimator
        The motor-speed estimator: only the truth (``"exact"``) has nothing to compute.
    pose_controller : PoseController
        The pose controller, reset to the reference.
    wheel_controller : WheelSpeedController
        The wheel loops, reset.

    Returns
    -------
    CompiledParts or None
        The steps, or None: a part without a compiled step, or a plant in CasADi's virtual machine.
    """
    address = plant.plant.step_address()
    truth = type(estimator) is TruthEstimator and type(speeds) is ExactSpeed
    compiled = isinstance(pose_controller, CompiledStep) and isinstance(wheel_controller, CompiledStep)
    if address is None or not truth or not compiled:
        return None
    assert isinstance(pose_controller, CompiledStep) and isinstance(wheel_controller, CompiledStep)
    return CompiledParts(address, pose_controller.compiled_step(), wheel_controller.compiled_step())


def _address(array: NDArray[np.float64] | NDArray[np.int64]) -> int:
    return int(array.ctypes.data)


def _loop(parts: CompiledParts, plant: PlantStepper, rim_per_motor: NDArray[np.float64], delay: bool) -> _Loop:
    """The C's description of the loop; the arrays it points to are kept alive by the caller (``keep``)."""
    n_arg, n_res, n_iw, n_w = parts.plant.sizes
    actuator = plant.actuator
    dead_zone = plant.dead_zone_rad_s
    loop = _Loop(
        plant=parts.plant.address,
        substep_s=plant.sample_period_s / plant.splits,
        splits=plant.splits,
        friction=int(dead_zone is not None),
        dead_zone_rad_s=(ctypes.c_double * 2)(*(dead_zone or (0.0, 0.0))),
        mid_v=actuator.mid_v,
        volts_per_code=actuator.volts_per_code,
        code_min=float(actuator.code_min),
        code_max=float(actuator.code_max),
        amplifier_gain=actuator.gain,
        voltage_limit_v=actuator.voltage_limit_v,
        pose=parts.pose.function,
        pose_state=parts.pose.state,
        wheels=parts.wheels.function,
        wheels_state=parts.wheels.state,
        rim_per_motor_m=(ctypes.c_double * 2)(*rim_per_motor.tolist()),
        one_sample_delay=int(delay),
    )
    work = (
        (ctypes.c_void_p * max(1, n_arg))(),
        (ctypes.c_void_p * max(1, n_res))(),
        np.zeros(max(1, n_iw), dtype=np.int64),
        np.zeros(max(1, n_w)),
        np.ascontiguousarray(plant.parameters, dtype=np.float64),
    )
    loop.arg, loop.res = ctypes.addressof(work[0]), ctypes.addressof(work[1])
    loop.iw, loop.w, loop.parameters = _address(work[2]), _address(work[3]), _address(work[4])
    loop._keep = work  # the work arrays live as long as the loop
    return loop


def run_compiled(
    parts: CompiledParts,
    plant: PlantStepper,
    sensors: Sensors,
    rim_per_motor: NDArray[np.float64],
    n: int,
    one_sample_delay: bool,
    progress: Callable[[float], None] | None,
) -> tuple[NDArray[np.float64], int, float]:
    """Run the loop's n + 1 samples in C and record the plant's rows in ``plant``.

    Parameters
    ----------
    parts : CompiledParts
        The compiled steps (:func:`compiled_parts`).
    plant : PlantStepper
        The true vehicle, at its initial state: it records the plant's rows, as if it had been stepped.
    sensors : Sensors
        The true vehicle's sensors, fresh: they read the run's recorded motion, for the log.
    rim_per_motor : ndarray
        The controllers' r/N per side, m/rad.
    n : int
        The run's length in samples.
    one_sample_delay : bool
        Whether the setpoints computed at t_k act from t_k+1.
    progress : callable or None
        Called with the fraction done (0 … 1) about every second of simulated time.

    Returns
    -------
    tuple
        The control columns (:class:`~agvctl.sim.records._ControlRow`'s, (n + 1) × its fields), the pose
        controller's fallbacks and the loop's wall time in s.

    Raises
    ------
    RuntimeError
        The plant's compiled step failed.
    """
    splits = plant.splits
    states = np.zeros((n + 1, len(STATE_NAMES)))
    states[0] = plant.state
    aux = np.zeros((max(n, 1), len(AUX_NAMES)))
    stats = np.zeros((max(n, 1) * splits, len(STATS_NAMES)))
    control = np.zeros((n + 1, len(_CONTROL)))
    pending = np.zeros(2)
    loop = _loop(parts, plant, rim_per_motor, one_sample_delay)
    run = _loop_function()
    every = n + 1 if progress is None else max(1, int(round(1.0 / plant.sample_period_s)))
    arrays = [ctypes.addressof(loop), *(_address(a) for a in (states, aux, stats, control, pending))]
    t0 = time.perf_counter()
    for k_from in range(0, n + 1, every):
        status = run(arrays[0], k_from, min(n + 1, k_from + every), n, *arrays[1:])
        if status != 0:
            raise RuntimeError(f"the plant's compiled step returned {status} in the compiled closed loop")
        if progress is not None:
            progress(k_from / max(n, 1))
    wall = time.perf_counter() - t0
    if progress is not None:
        progress(1.0)
    da = control[:, 4:6]
    angles = plant.append(da[:n], states, aux[:n], merge_stats(stats[: n * splits], splits))
    plant.finish(da[n])
    fallbacks = int(np.count_nonzero(control[:, 7] == _FALLBACK_STATUS))
    if parts.pose.stepped is not None:
        parts.pose.stepped(fallbacks)
    failures = int(np.count_nonzero(control[:, 7] > 0))
    return _control_columns(control, states, angles, sensors, rim_per_motor), failures, wall


def _control_columns(
    control: NDArray[np.float64],
    states: NDArray[np.float64],
    angles: NDArray[np.float64],
    sensors: Sensors,
    rim_per_motor: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The control columns of the run's n + 1 samples, in :class:`_ControlRow`'s order: what the C recorded, the
    truth as the estimate, the encoder counts latched from the shaft angles and the sensors' readings (the truth's
    estimators have no consistency or calibration to read out)."""
    n1 = len(states)
    columns: dict[str, NDArray[np.float64]] = {name: control[:, j] for j, name in enumerate(_CONTROL)}
    for j, name in enumerate(("est_x_m", "est_y_m", "est_theta_rad")):
        columns[name] = states[:, 2 + j]
    counts = sensors.encoder_counts(angles)
    readings = np.full((n1, 5), math.nan)
    omega = control[:, 10:12]
    for k in range(n1):
        meas = sensors.read(k, counts[k], states[k, 2:5], omega[k] * rim_per_motor)
        readings[k, 0] = meas.gyro_rate_rad_s
        if meas.fixes:
            readings[k, 1:4] = meas.fixes[-1].pose
            readings[k, 4] = meas.fixes[-1].measured_t_s
    sides = ("left", "right")
    for j, side in enumerate(sides):
        columns[f"motor_angle_{side}_rad"] = angles[:, j]
        columns[f"encoder_count_{side}"] = counts[:, j].astype(np.float64)
    names = ("gyro_rate_rad_s", "fix_x_m", "fix_y_m", "fix_theta_rad", "fix_measured_t_s")
    columns.update({name: readings[:, j] for j, name in enumerate(names)})
    rest = _ControlRow._fields[_ControlRow._fields.index("est_sigma_x_m") :]
    none = (*_NO_CONSISTENCY, *_NO_CALIBRATION)
    assert len(rest) == len(none)
    columns.update({name: np.full(n1, value) for name, value in zip(rest, none, strict=True)})
    return np.column_stack([columns[name] for name in _ControlRow._fields])
