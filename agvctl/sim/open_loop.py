"""Open-loop simulation of the full model from DA voltage commands, single or batched.

A single run is :meth:`PlantStepper.run <agvctl.sim.stepper.PlantStepper.run>` (compiled chunks of samples). A
batch integrates many vehicles in one compiled call (:meth:`~agvctl.plant.integrator.CompiledPlant.run_batch`,
vehicles in parallel threads), which a per-vehicle stepper cannot; its rows are recorded by the stepper's
:func:`~agvctl.sim.stepper.plant_log_rows`, so the logs are the same either way."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.actuator import Actuator
from agvctl.config import MAX_LOG_BYTES, document_fields, read_text
from agvctl.errors import ConfigError
from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.params import VehicleParams
from agvctl.params.schema import check_sample_count
from agvctl.planning.planner import MAX_DURATION_S
from agvctl.plant.full import STATE_NAMES, PlantOptions, parameter_vector
from agvctl.plant.integrator import compiled_plant, sample_splits
from agvctl.sim.stepper import PlantStepper, instant_stats, plant_log_rows

__all__ = ["OpenLoopResult", "load_input_profile", "sample_count", "simulate_batch", "simulate_open_loop"]


@document_fields
@dataclass
class OpenLoopResult:
    """A simulated run: the log, the time spent simulating, and any one-time preparation."""

    log: SimLog
    """The run's log, :data:`~agvctl.log.PLANT_LOG_COLUMNS`, one row per sample and the final state."""
    wall_time_s: float
    """Time spent integrating, measured in this process (excludes setup), s."""
    setup_time_s: float
    """One-time preparation: model building, code generation and compilation, or loading the cached library, s."""


def sample_count(duration_s: float, sample_period_s: float) -> int:
    """The number of whole samples in a duration (rounded to the nearest sample), as ``--duration`` asks.

    Parameters
    ----------
    duration_s : float
        The duration, s.
    sample_period_s : float
        The sample period, s.

    Returns
    -------
    int
        The samples, at least 1.

    Raises
    ------
    ConfigError
        Naming ``--duration``: not a positive number, above :data:`MAX_DURATION_S`, or more samples than
        :data:`~agvctl.params.schema.MAX_SAMPLES_PER_RUN`.
    """
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ConfigError("--duration", "", f"must be a positive number of seconds (got {duration_s})")
    if duration_s > MAX_DURATION_S:
        raise ConfigError("--duration", "", f"must be at most {MAX_DURATION_S:g} s (got {duration_s:g})")
    what = f"{duration_s:g} s at control.sample_period_s = {sample_period_s:g} s"
    check_sample_count(duration_s / sample_period_s, "--duration", "", what)
    return max(1, int(round(duration_s / sample_period_s)))


def _batch_log(
    vehicle: VehicleParams,
    da_voltage_v: NDArray[np.float64],
    X: NDArray[np.float64],
    A: NDArray[np.float64],
    S: NDArray[np.float64],
    aux_final: NDArray[np.float64],
) -> SimLog:
    """One vehicle's log of a batch run, recorded as :class:`~agvctl.sim.stepper.PlantStepper` records (the
    final row: the end state, the last input still applied)."""
    n = A.shape[0]
    ts = vehicle.control.sample_period_s
    actuator = Actuator(vehicle)
    rows = plant_log_rows(np.arange(n) * ts, actuator.apply(da_voltage_v), A, S, X[:-1])
    final = plant_log_rows(
        np.array([n * ts]), actuator.apply(da_voltage_v[-1]), aux_final[None, :], instant_stats(aux_final)[None, :],
        X[-1:],
    )  # fmt: skip
    both = np.vstack([rows, final])
    return SimLog({name: both[:, j] for j, name in enumerate(PLANT_LOG_COLUMNS)})


MAX_INITIAL_STATE = (1e4, 1e4, 1e6, 1e6, 1e6)
"""The largest magnitude of each initial state (:data:`~agvctl.plant.full.STATE_NAMES`): 10^4 rad/s on a motor's
pre-velocity (some 95,000 rpm, far past any motor), 10^6 m (a thousand kilometres) and 10^6 rad."""


def _check_inputs(da_voltage_v: ArrayLike) -> NDArray[np.float64]:
    try:
        u = np.asarray(da_voltage_v, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError("simulate_open_loop", "da_voltage_v", "expected an (n, 2) array of numbers") from None
    if u.ndim != 2 or u.shape[1] != 2 or u.shape[0] < 1:
        raise ConfigError("simulate_open_loop", "da_voltage_v", f"must have shape (n_samples, 2) (got {u.shape})")
    check_sample_count(u.shape[0], "simulate_open_loop", "da_voltage_v", "the commands")
    if not np.all(np.isfinite(u)):
        raise ConfigError("simulate_open_loop", "da_voltage_v", "contains NaN or inf")
    return u


def _check_state(initial_state: ArrayLike | None) -> NDArray[np.float64] | None:
    if initial_state is None:
        return None
    try:
        x0 = np.asarray(initial_state, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError("simulate_open_loop", "initial_state", "expected 5 numbers") from None
    if x0.shape != (len(STATE_NAMES),):
        raise ConfigError(
            "simulate_open_loop", "initial_state", f"must have shape ({len(STATE_NAMES)},) (got {x0.shape})"
        )
    for name, value, bound in zip(STATE_NAMES, x0, MAX_INITIAL_STATE, strict=True):
        if not (math.isfinite(value) and abs(value) <= bound):
            raise ConfigError(
                "simulate_open_loop", f"initial_state[{name}]", f"must be finite and within ±{bound:g} (got {value})"
            )
    return x0


def simulate_open_loop(
    vehicle: VehicleParams,
    da_voltage_v: ArrayLike,
    *,
    initial_state: ArrayLike | None = None,
    options: PlantOptions | None = None,
) -> OpenLoopResult:
    """Simulate the full model from DA voltage commands held over each sample period.

    Parameters
    ----------
    vehicle : VehicleParams
        The simulated vehicle, from :func:`~agvctl.params.load_vehicle`.
    da_voltage_v : array_like
        An (n, 2) array of requested DA voltages in V (left, right), one row per sample period; each goes through
        the DA converter and amplifier (:class:`~agvctl.actuator.Actuator`) and is held over its sample.
    initial_state : array_like or None
        The plant state (:data:`~agvctl.plant.full.STATE_NAMES`, SI units); None: at rest at the origin.
    options : PlantOptions or None
        Which nonlinear effects the model includes (:class:`~agvctl.plant.full.PlantOptions`); None: all.

    Returns
    -------
    OpenLoopResult
        The log (:class:`~agvctl.log.SimLog`, n + 1 rows from t = 0), the wall time spent integrating and the
        one-time setup time (compiling or loading the plant), both in s.

    Raises
    ------
    ConfigError
        ``simulate_open_loop: <argument>: <problem>``: ``da_voltage_v`` not an (n, 2) array of finite numbers or
        of more than :data:`~agvctl.params.schema.MAX_SAMPLES_PER_RUN` rows; ``initial_state`` not 5 finite numbers
        within :data:`MAX_INITIAL_STATE`; or naming ``friction_model.p_factor`` for a vehicle whose plant would need
        too many substeps (:func:`~agvctl.plant.integrator.choose_substeps`).
    """
    u_req = _check_inputs(da_voltage_v)
    x0 = _check_state(initial_state)
    t0 = time.perf_counter()
    plant = PlantStepper(vehicle, initial_state=x0, options=options)
    setup = time.perf_counter() - t0
    t1 = time.perf_counter()
    plant.run(u_req)
    plant.finish()
    log = plant.log()
    wall = time.perf_counter() - t1
    return OpenLoopResult(log=log, wall_time_s=wall, setup_time_s=setup)


def simulate_batch(
    vehicles: Sequence[VehicleParams],
    da_voltage_v: ArrayLike,
    *,
    initial_states: ArrayLike | None = None,
    options: PlantOptions | None = None,
) -> list[SimLog]:
    """Simulate many vehicles (parameter variants) at once, in parallel threads of compiled code.

    Parameters
    ----------
    vehicles : sequence of VehicleParams
        The B simulated vehicles; all must share the sample period.
    da_voltage_v : array_like
        Requested DA voltages in V (left, right): (n, 2) for the same commands to every vehicle, or (B, n, 2) per
        vehicle.
    initial_states : array_like or None
        Plant states, one row per vehicle (B, n_states; SI units); None: at rest at the origin.
    options : PlantOptions or None
        Which nonlinear effects the model includes (:class:`~agvctl.plant.full.PlantOptions`); None: all.

    Returns
    -------
    list of SimLog
        One log per vehicle, in order, each of n + 1 rows.

    Raises
    ------
    ConfigError
        ``simulate_batch: <argument>: <problem>``, or as :func:`simulate_open_loop` for each vehicle's commands
        and initial state.
    """
    vs = list(vehicles)
    if not vs:
        return []
    if not all(isinstance(v, VehicleParams) for v in vs):
        raise ConfigError("simulate_batch", "vehicles", "expected VehicleParams (from load_vehicle)")
    ts = vs[0].control.sample_period_s
    if any(v.control.sample_period_s != ts for v in vs):
        raise ConfigError("simulate_batch", "vehicles", "must all have the same control.sample_period_s")
    try:
        u = np.asarray(da_voltage_v, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError("simulate_batch", "da_voltage_v", "expected an array of numbers") from None
    if u.ndim == 2:
        u = np.broadcast_to(u, (len(vs), *u.shape))
    if u.ndim != 3 or u.shape[0] != len(vs):
        raise ConfigError("simulate_batch", "da_voltage_v", f"must be (n, 2) or ({len(vs)}, n, 2) (got {u.shape})")
    for b in range(len(vs)):
        _check_inputs(u[b])
    if initial_states is not None:
        rows = np.asarray(initial_states, dtype=object)
        if rows.ndim < 1 or len(rows) != len(vs):
            raise ConfigError("simulate_batch", "initial_states", f"expected one state per vehicle ({len(vs)})")
        states = [None if row is None else _check_state(row) for row in rows]
        if any(state is None for state in states):
            raise ConfigError("simulate_batch", "initial_states", "expected one state of 5 numbers per vehicle")
        initial_states = np.array(states)
    plant = compiled_plant(options)
    splits = sample_splits(vs)
    motor_v = np.stack([Actuator(v).apply(u[b]).motor_voltage_v for b, v in enumerate(vs)])
    P = np.stack([parameter_vector(v) for v in vs])
    x0 = np.zeros((len(vs), len(STATE_NAMES))) if initial_states is None else np.asarray(initial_states, dtype=float)
    X, A, S = plant.run_batch(x0, motor_v, P, ts, splits)
    logs = []
    for b, v in enumerate(vs):
        aux_final = plant.aux(X[b, -1], motor_v[b][-1], P[b])
        logs.append(_batch_log(v, u[b], X[b], A[b], S[b], aux_final))
    return logs


def _comment(line: str) -> bool:
    return line.lstrip().startswith("#")


def load_input_profile(path: str | Path, sample_period_s: float, duration_s: float) -> NDArray[np.float64]:
    """Read a CSV profile with columns ``t_s,da_left_v,da_right_v`` and hold each row until the next one.

    Before the first row's time the command is zero. Blank lines and lines starting with ``#`` are skipped; a
    byte-order mark is dropped.

    Parameters
    ----------
    path : str or Path
        The CSV file: times in s, DA voltages in V.
    sample_period_s : float
        The sample grid's period, s.
    duration_s : float
        How long the profile is played, s (:func:`sample_count` samples).

    Returns
    -------
    ndarray
        (n, 2): the DA voltages (left, right) on the sample grid, V.

    Raises
    ------
    ConfigError
        Naming the file and the line (counted in the file, comment lines included) or the column: an empty file, a
        missing column, a cell that is not a finite number, times that do not increase strictly; or naming
        ``--duration`` (:func:`sample_count`).
    """
    path = Path(path)
    text = read_text(path, MAX_LOG_BYTES)
    numbered = [(no, line) for no, line in enumerate(text.splitlines(), start=1) if line.strip() and not _comment(line)]
    if not numbered:
        raise ConfigError(str(path), "", "empty file; expected a header t_s,da_left_v,da_right_v")
    header = [h.strip() for h in numbered[0][1].split(",")]
    needed = ("t_s", "da_left_v", "da_right_v")
    for name in needed:
        if name not in header:
            raise ConfigError(str(path), name, f"missing column (header is {','.join(header)})")
    idx = [header.index(n) for n in needed]
    rows, line_nos = [], []
    for line_no, line in numbered[1:]:
        cells = line.split(",")
        try:
            values = [float(cells[i]) for i in idx]
        except (ValueError, IndexError):
            raise ConfigError(str(path), f"line {line_no}", f"expected three numbers (got {line.strip()!r})") from None
        if not all(np.isfinite(values)):
            raise ConfigError(str(path), f"line {line_no}", "NaN or inf")
        rows.append(values)
        line_nos.append(line_no)
    if not rows:
        raise ConfigError(str(path), "", "no data rows")
    data = np.array(rows)
    if np.any(np.diff(data[:, 0]) <= 0):
        bad = line_nos[int(np.argmax(np.diff(data[:, 0]) <= 0)) + 1]
        raise ConfigError(str(path), f"line {bad}", "t_s must increase strictly")
    n = sample_count(duration_s, sample_period_s)
    t = np.arange(n) * sample_period_s
    which = np.searchsorted(data[:, 0], t + 1e-9 * sample_period_s, side="right") - 1
    out = np.zeros((n, 2))
    valid = which >= 0
    out[valid] = data[which[valid], 1:3]
    return out
