"""The closed loop run in C where the pose and the motor speeds are the truth: the same samples, the same log.

Where the pose and the motor speeds are the truth (``localization = "truth"``, ``wheel_speed = "exact"``, the
defaults) and the plant is compiled, :func:`agvctl.sim.loop.run_closed_loop` hands the run to :func:`run_compiled`.
A small C loop (``templates/closed_loop.c.j2``) then runs the samples: it computes the motor speeds from the plant's
state, calls the pose controller and the wheel loops, applies the DA converter and the amplifier, and calls the
plant's compiled sample step. A controller with a compiled step (:class:`~agvctl.controllers.base.CompiledStep`:
the generated laws ``ramsete_c`` and ``ltv_lqr_c``, the generated loops ``pi_c``, or a user's own C) is called
there directly; one in Python (the MPC, ``pi``, a user's class) is called back from the C with what the loop in
Python would hand it, and what it raises is raised again as the loop in Python raises it. With both controllers
compiled, a run never comes back to Python until it ends. Python makes the log once at the end from what the C
recorded: the plant's columns through :meth:`~agvctl.sim.stepper.PlantStepper.append`, the shaft angles and the
encoder counts, and the sensors' readings (the gyro, the fixes), which nothing in such a loop reads and which are
drawn from the same seeded streams in the same order.

The C mirrors the Python loop's arithmetic operation by operation, so the two logs agree to the last bit, the
pose controller's measured computing time (``solve_time_s``; a compiled step's is the C step's alone) excepted; the
tests hold it to that. The Python loop is the specification; this is the same loop, compiled.
"""

from __future__ import annotations

import ctypes
import functools
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import CompiledStep, CStep, LimitReporting, PoseController, WheelSpeedController
from agvctl.controllers.pi.c_loops import GeneratedC, compile_generated_c
from agvctl.errors import AgvctlError
from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator
from agvctl.estimation.odometry import TruthEstimator
from agvctl.estimation.wheel_speed import ExactSpeed
from agvctl.evaluation.metrics import NON_FINITE_COMMAND_STATUS
from agvctl.plant.codegen import CFunctionAddress, c_templates
from agvctl.plant.full import AUX_NAMES, STATE_NAMES
from agvctl.plant.integrator import STATS_NAMES, merge_stats
from agvctl.sensing import Sensors
from agvctl.sim.records import _NO_CALIBRATION, _NO_CONSISTENCY, _STATUS_CODE, _checked_command, _ControlRow
from agvctl.sim.stepper import PlantStepper

__all__ = ["CompiledParts", "LoopPlan", "compiled_parts", "run_compiled"]

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
_FALLBACK_STATUS = _STATUS_CODE["fallback_feedforward"]
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
        ("pose_call", ctypes.c_void_p),
        ("wheels", ctypes.c_void_p),
        ("wheels_state", ctypes.c_void_p),
        ("wheels_report_limits", ctypes.c_long),
        ("rim_per_motor_m", ctypes.c_double * 2),
        ("one_sample_delay", ctypes.c_long),
    ]


_Doubles = ctypes.POINTER(ctypes.c_double)
_POSE_CALL = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_long, _Doubles, _Doubles, _Doubles)
"""A pose controller in Python, called from the C loop: k, the pose, the wheel speeds in; out[0..4] (the checked
setpoints, the status, the step's time, the run's length); nonzero when it raised."""
_WHEEL_STEP = ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.c_void_p, _Doubles, _Doubles, _Doubles)
"""A wheel controller's step (:class:`~agvctl.controllers.base.CStep`'s signature), here one in Python."""
_WHEELS_RAISED = 0xFFFFFFFF
"""The mask a wheel step in Python returns when the controller raised: the C loop stops."""
_STOPPED_BY_PYTHON, _STOPPED_BY_PLANT = -1, -2
_CHUNK_SUBSAMPLES = 1 << 16
"""Sub-samples per call of the C loop at most (their statistics, 4 MiB, are merged after each call)."""


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
    run.restype = ctypes.c_long
    pointer = ctypes.c_void_p
    run.argtypes = [pointer, ctypes.c_long, ctypes.c_long, *[pointer] * 6]
    return run


@dataclass(frozen=True)
class CompiledParts:
    """What the closed loop in C calls: the plant's compiled step, and each controller's compiled step or None
    (called in Python from the C loop).

    Parameters
    ----------
    plant : CFunctionAddress
        The plant's compiled sample step.
    pose : CStep or None
        The pose controller's compiled step (after its reset), or None for one in Python.
    wheels : CStep or None
        The wheel loops' compiled step (after their reset), or None for ones in Python.
    """

    plant: CFunctionAddress
    pose: CStep | None
    wheels: CStep | None


def compiled_parts(
    plant: PlantStepper,
    estimator: PoseEstimator,
    speeds: WheelSpeedEstimator,
    pose_controller: PoseController,
    wheel_controller: WheelSpeedController,
) -> CompiledParts | None:
    """What the loop in C calls, where it can run in C; None where it runs in Python.

    Parameters
    ----------
    plant : PlantStepper
        The true vehicle.
    estimator : PoseEstimator
        The pose estimator: only the truth (``"truth"``) has nothing to compute.
    speeds : WheelSpeedEstimator
        The motor-speed estimator: only the truth (``"exact"``) has nothing to compute.
    pose_controller : PoseController
        The pose controller, reset to the reference: its compiled step, or called in Python.
    wheel_controller : WheelSpeedController
        The wheel loops, reset: their compiled step, or called in Python.

    Returns
    -------
    CompiledParts or None
        What the C calls, or None: an estimator that computes, a plant in CasADi's virtual machine, or a loop
        that does not compile (with a warning).
    """
    address = plant.plant.step_address()
    if address is None or not (type(estimator) is TruthEstimator and type(speeds) is ExactSpeed):
        return None
    try:
        _loop_function()
    except AgvctlError as exc:  # the plant compiled, so this is unlikely; the loop in Python gives the same log
        warnings.warn(f"agvctl: {exc}; the closed loop runs in Python", RuntimeWarning, stacklevel=2)
        return None
    pose = pose_controller.compiled_step() if isinstance(pose_controller, CompiledStep) else None
    wheels = wheel_controller.compiled_step() if isinstance(wheel_controller, CompiledStep) else None
    return CompiledParts(address, pose, wheels)


def _address(array: NDArray[np.float64] | NDArray[np.int64]) -> int:
    return int(array.ctypes.data)


@dataclass(frozen=True)
class LoopPlan:
    """The run the C loop runs: its controllers, its length and its options.

    Parameters
    ----------
    pose_controller : PoseController
        The pose controller (called in Python where :attr:`CompiledParts.pose` is None).
    wheel_controller : WheelSpeedController
        The wheel loops (called in Python where :attr:`CompiledParts.wheels` is None).
    rim_per_motor : ndarray
        The controllers' r/N per side, m/rad.
    samples : int
        The run's length in samples, as planned.
    longest : int
        The most samples it may take (a pose controller that keeps its own clock).
    length_after : callable
        ``(k, reference_done) -> samples``: the run's length after the pose controller's command at sample k.
    one_sample_delay : bool
        Whether the setpoints computed at t_k act from t_k+1.
    """

    pose_controller: PoseController
    wheel_controller: WheelSpeedController
    rim_per_motor: NDArray[np.float64]
    samples: int
    longest: int
    length_after: Callable[[int, bool | None], int]
    one_sample_delay: bool


def _python_calls(plan: LoopPlan, sample_period_s: float, raised: list[BaseException]) -> tuple[Any, Any, bool]:
    """The calls into Python for the controllers in Python (the pose controller's, the wheel loops'), each doing
    what the loop in Python does at its place, an exception kept in ``raised``; and whether the wheel loops report
    their clamping."""
    pose_controller, wheel_controller = plan.pose_controller, plan.wheel_controller

    def pose_call(k: int, pose: Any, wheel_speed_m_s: Any, out: Any) -> int:
        try:
            est, wheels = np.array([pose[0], pose[1], pose[2]]), np.array([wheel_speed_m_s[0], wheel_speed_m_s[1]])
            start = time.perf_counter()
            cmd = pose_controller.update(k * sample_period_s, est, wheels)
            out[3] = time.perf_counter() - start
            out[4] = plan.length_after(k, cmd.reference_done)
            status, commanded = _checked_command(cmd)
            out[0], out[1] = commanded.tolist()
            out[2] = status
            return 0
        except BaseException as exc:  # a controller's error (or an interrupt) is raised again outside the C
            raised.append(exc)
            return 1

    reporting = wheel_controller if isinstance(wheel_controller, LimitReporting) else None  # checked once

    def wheel_step(state: Any, setpoint_rad_s: Any, measured_rad_s: Any, da_v: Any) -> int:
        del state
        try:
            setpoint = np.array([setpoint_rad_s[0], setpoint_rad_s[1]])
            da = wheel_controller.update(setpoint, np.array([measured_rad_s[0], measured_rad_s[1]]))
            left, right = da.tolist()
            da_v[0], da_v[1] = float(left), float(right)
            if reporting is None:
                return 0
            limited = reporting.limited
            return int(bool(limited[0])) | 2 * int(bool(limited[1]))
        except BaseException as exc:
            raised.append(exc)
            return _WHEELS_RAISED

    return _POSE_CALL(pose_call), _WHEEL_STEP(wheel_step), reporting is not None


def _loop(parts: CompiledParts, plant: PlantStepper, plan: LoopPlan, raised: list[BaseException]) -> _Loop:
    """The C's description of the loop; what it points to lives as long as it does (``_keep``)."""
    n_arg, n_res, n_iw, n_w = parts.plant.sizes
    actuator = plant.actuator
    dead_zone = plant.dead_zone_rad_s
    pose_call, wheel_step, reports = _python_calls(plan, plant.sample_period_s, raised)
    wheels = parts.wheels or CStep(ctypes.cast(wheel_step, ctypes.c_void_p).value or 0, 0)
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
        pose=parts.pose.function if parts.pose else None,
        pose_state=parts.pose.state if parts.pose else None,
        pose_call=ctypes.cast(pose_call, ctypes.c_void_p).value,
        wheels=wheels.function,
        wheels_state=wheels.state,
        wheels_report_limits=int(parts.wheels is not None or reports),
        rim_per_motor_m=(ctypes.c_double * 2)(*plan.rim_per_motor.tolist()),
        one_sample_delay=int(plan.one_sample_delay),
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
    loop._keep = (work, pose_call, wheel_step)  # the work arrays and the calls live as long as the loop
    return loop


def run_compiled(
    parts: CompiledParts,
    plant: PlantStepper,
    sensors: Sensors,
    plan: LoopPlan,
    progress: Callable[[float], None] | None,
) -> tuple[NDArray[np.float64], int, int, float]:
    """Run the loop in C and record the plant's rows in ``plant``.

    Parameters
    ----------
    parts : CompiledParts
        What the C calls (:func:`compiled_parts`).
    plant : PlantStepper
        The true vehicle, at its initial state: it records the plant's rows, as if it had been stepped.
    sensors : Sensors
        The true vehicle's sensors, fresh: they read the run's recorded motion, for the log.
    plan : LoopPlan
        The controllers, the run's length and its options.
    progress : callable or None
        Called with the fraction done (0 … 1) about every second of simulated time.

    Returns
    -------
    tuple
        The control columns (:class:`~agvctl.sim.records._ControlRow`'s, (n + 1) × its fields), the samples at
        which the pose controller fell back or commanded a non-finite setpoint, the run's length n in samples, and
        the loop's wall time in s.

    Raises
    ------
    RuntimeError
        The plant's compiled step failed.
    Exception
        Whatever a controller in Python raised, as the loop in Python raises it.
    """
    splits, rows = plant.splits, plan.longest + 1
    states = np.zeros((rows, len(STATE_NAMES)))
    states[0] = plant.state
    aux, merged = np.zeros((rows, len(AUX_NAMES))), np.zeros((rows, len(STATS_NAMES)))
    control, pending, n = np.zeros((rows, len(_CONTROL))), np.zeros(2), ctypes.c_long(plan.samples)
    raised: list[BaseException] = []
    loop = _loop(parts, plant, plan, raised)
    # the sub-samples' statistics of one call at a time, merged after it: memory bounded whatever the splits
    every = min(rows, max(1, _CHUNK_SUBSAMPLES // splits))
    if progress is not None:
        every = min(every, max(1, int(round(1.0 / plant.sample_period_s))))
    stats = np.zeros((every * splits, len(STATS_NAMES)))
    arrays = [ctypes.addressof(n), *(_address(a) for a in (states, aux, stats, control, pending))]
    run, k = _loop_function(), 0
    t0 = time.perf_counter()
    while k <= n.value:
        k_from = k
        k = run(ctypes.addressof(loop), k, k + every, *arrays)
        if k == _STOPPED_BY_PYTHON:
            raise raised[0]
        if k == _STOPPED_BY_PLANT:
            raise RuntimeError("the plant's compiled step failed in the compiled closed loop")
        integrated = min(k, n.value) - k_from  # the last sample, n, is not integrated
        merged[k_from : k_from + integrated] = merge_stats(stats[: integrated * splits], splits)
        if progress is not None:
            progress(min(k, n.value) / max(n.value, 1))
    wall = time.perf_counter() - t0
    n_samples = n.value
    da = control[:, 4:6]
    angles = plant.append(da[:n_samples], states[: n_samples + 1], aux[:n_samples], merged[:n_samples])
    plant.finish(da[n_samples])
    control = control[: n_samples + 1]
    if parts.pose is not None and parts.pose.stepped is not None:
        parts.pose.stepped(int(np.count_nonzero(control[:, 7] == _FALLBACK_STATUS)))
    failures = int(np.count_nonzero(control[:, 7] > 0))
    columns = _control_columns(control, states[: n_samples + 1], angles, sensors, plan.rim_per_motor)
    return columns, failures, n_samples, wall


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
