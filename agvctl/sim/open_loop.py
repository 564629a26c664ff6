"""Open-loop simulation of the full model from DA voltage commands, single or batched."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.actuator import Actuator
from agvctl.config import read_text
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams
from agvctl.planning.planner import MAX_DURATION_S
from agvctl.plant.full import AUX_NAMES, STATE_NAMES, PlantOptions, parameter_vector
from agvctl.sim.integrator import STATS_NAMES, compiled_plant, sample_splits
from agvctl.sim.log import SimLog

__all__ = ["OpenLoopResult", "load_input_profile", "sample_count", "simulate_batch", "simulate_open_loop"]


@dataclass
class OpenLoopResult:
    """A simulated run: the log, the time spent simulating, and any one-time preparation."""

    log: SimLog
    wall_time_s: float
    """Time spent integrating, measured in this process (excludes setup)."""
    setup_time_s: float
    """One-time preparation: model building, code generation and compilation, or loading the cached library."""


def sample_count(duration_s: float, sample_period_s: float) -> int:
    """Number of whole samples in ``duration_s`` (rounded to the nearest sample)."""
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise ConfigError("--duration", "", f"must be a positive number of seconds (got {duration_s})")
    if duration_s > MAX_DURATION_S:
        raise ConfigError("--duration", "", f"must be at most {MAX_DURATION_S:g} s (got {duration_s:g})")
    return max(1, int(round(duration_s / sample_period_s)))


def _log_from_arrays(
    vehicle: VehicleParams,
    actuator_out: dict[str, NDArray[np.float64]],
    X: NDArray[np.float64],
    A: NDArray[np.float64],
    S: NDArray[np.float64],
    aux_final: NDArray[np.float64],
) -> SimLog:
    n = A.shape[0]
    ts = vehicle.control.sample_period_s
    A_full = np.vstack([A, aux_final[None, :]])
    final_stats = np.array(
        [aux_final[4], aux_final[5], abs(aux_final[2]), abs(aux_final[3]), abs(aux_final[6]), abs(aux_final[7])]
    )
    S_full = np.vstack([S, final_stats[None, :]])
    aux = {name: A_full[:, i] for i, name in enumerate(AUX_NAMES)}
    stats = {name: S_full[:, i] for i, name in enumerate(STATS_NAMES)}
    cols: dict[str, NDArray[np.float64]] = {"t_s": np.arange(n + 1) * ts}
    for key, values in actuator_out.items():
        cols[key] = np.concatenate([values, values[-1:]])
    cols["current_left_a"], cols["current_right_a"] = aux["current_left_a"], aux["current_right_a"]
    cols["current_limited_left"] = (stats["current_limited_fraction_left"] > 0).astype(float)
    cols["current_limited_right"] = (stats["current_limited_fraction_right"] > 0).astype(float)
    for name in STATS_NAMES:
        cols[name] = stats[name]
    for name in (
        "omega_motor_left_rad_s",
        "omega_motor_right_rad_s",
        "wheel_accel_left_m_s2",
        "wheel_accel_right_m_s2",
    ):
        cols[name] = aux[name]
    for i, name in enumerate(STATE_NAMES[2:], start=2):
        cols[name] = X[:, i]
    cols["speed_m_s"], cols["yaw_rate_rad_s"] = aux["speed_m_s"], aux["yaw_rate_rad_s"]
    from agvctl.sim.log import PLANT_LOG_COLUMNS

    return SimLog({name: cols[name] for name in PLANT_LOG_COLUMNS})


def _actuate(
    vehicle: VehicleParams, da_voltage_v: NDArray[np.float64]
) -> tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]:
    out = Actuator(vehicle).apply(da_voltage_v)
    cols = {
        "da_code_left": out.da_code[..., 0].astype(float),
        "da_code_right": out.da_code[..., 1].astype(float),
        "da_voltage_left_v": out.da_voltage_v[..., 0],
        "da_voltage_right_v": out.da_voltage_v[..., 1],
        "da_clipped_left": out.da_clipped[..., 0].astype(float),
        "da_clipped_right": out.da_clipped[..., 1].astype(float),
        "motor_voltage_left_v": out.motor_voltage_v[..., 0],
        "motor_voltage_right_v": out.motor_voltage_v[..., 1],
    }
    return out.motor_voltage_v, cols


def _check_inputs(da_voltage_v: ArrayLike) -> NDArray[np.float64]:
    u = np.asarray(da_voltage_v, dtype=float)
    if u.ndim != 2 or u.shape[1] != 2 or u.shape[0] < 1:
        raise ValueError(f"da_voltage_v must have shape (n_samples, 2) (got {u.shape})")
    if not np.all(np.isfinite(u)):
        raise ValueError("da_voltage_v contains NaN or inf")
    return u


def simulate_open_loop(
    vehicle: VehicleParams,
    da_voltage_v: ArrayLike,
    *,
    initial_state: ArrayLike | None = None,
    options: PlantOptions | None = None,
) -> OpenLoopResult:
    """Simulate the full model from DA voltage commands held over each sample period.

    ``da_voltage_v`` is an (n, 2) array of requested DA voltages (left, right), one row per sample; each goes
    through the DA converter and amplifier (:class:`~agvctl.actuator.Actuator`). ``initial_state`` is the
    plant state (:data:`~agvctl.plant.full.STATE_NAMES`), default at rest at the origin. The log has n + 1 rows.
    """
    u_req = _check_inputs(da_voltage_v)
    t0 = time.perf_counter()
    plant = compiled_plant(options)
    splits = sample_splits(vehicle)
    setup = time.perf_counter() - t0
    x0 = np.zeros(len(STATE_NAMES)) if initial_state is None else np.asarray(initial_state, dtype=float)
    t1 = time.perf_counter()
    u_motor, act_cols = _actuate(vehicle, u_req)
    p = parameter_vector(vehicle)
    X, A, S = plant.run(x0, u_motor, p, vehicle.control.sample_period_s, splits)
    aux_final = plant.aux(X[-1], u_motor[-1], p)
    log = _log_from_arrays(vehicle, act_cols, X, A, S, aux_final)
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

    ``da_voltage_v`` is (n, 2) for the same commands to every vehicle or (B, n, 2) per vehicle. All vehicles
    must share the sample period.
    """
    vs = list(vehicles)
    if not vs:
        return []
    ts = vs[0].control.sample_period_s
    if any(v.control.sample_period_s != ts for v in vs):
        raise ValueError("simulate_batch: all vehicles must have the same control.sample_period_s")
    u = np.asarray(da_voltage_v, dtype=float)
    if u.ndim == 2:
        u = np.broadcast_to(u, (len(vs), *u.shape))
    if u.shape[0] != len(vs):
        raise ValueError(f"da_voltage_v has {u.shape[0]} rows of commands for {len(vs)} vehicles")
    for b in range(len(vs)):
        _check_inputs(u[b])
    plant = compiled_plant(options)
    splits = sample_splits(vs)
    motor_v, act = [], []
    for b, v in enumerate(vs):
        mv, cols = _actuate(v, u[b])
        motor_v.append(mv)
        act.append(cols)
    P = np.stack([parameter_vector(v) for v in vs])
    x0 = np.zeros((len(vs), len(STATE_NAMES))) if initial_states is None else np.asarray(initial_states, dtype=float)
    X, A, S = plant.run_batch(x0, np.stack(motor_v), P, ts, splits)
    logs = []
    for b, v in enumerate(vs):
        aux_final = plant.aux(X[b, -1], motor_v[b][-1], P[b])
        logs.append(_log_from_arrays(v, act[b], X[b], A[b], S[b], aux_final))
    return logs


def load_input_profile(path: str | Path, sample_period_s: float, duration_s: float) -> NDArray[np.float64]:
    """Read a CSV profile with columns ``t_s,da_left_v,da_right_v`` and hold each row until the next one.

    Returns the (n, 2) DA voltages on the sample grid for ``duration_s``. Before the first row's time the
    command is zero.
    """
    path = Path(path)
    text = read_text(path)
    lines = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise ConfigError(str(path), "", "empty file; expected a header t_s,da_left_v,da_right_v")
    header = [h.strip() for h in lines[0].split(",")]
    needed = ("t_s", "da_left_v", "da_right_v")
    for name in needed:
        if name not in header:
            raise ConfigError(str(path), name, f"missing column (header is {','.join(header)})")
    idx = [header.index(n) for n in needed]
    rows = []
    for line_no, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        try:
            values = [float(cells[i]) for i in idx]
        except (ValueError, IndexError):
            raise ConfigError(str(path), f"line {line_no}", f"expected three numbers (got {line.strip()!r})") from None
        if not all(np.isfinite(values)):
            raise ConfigError(str(path), f"line {line_no}", "NaN or inf")
        rows.append(values)
    if not rows:
        raise ConfigError(str(path), "", "no data rows")
    data = np.array(rows)
    if np.any(np.diff(data[:, 0]) <= 0):
        bad = int(np.argmax(np.diff(data[:, 0]) <= 0)) + 3
        raise ConfigError(str(path), f"line {bad}", "t_s must increase strictly")
    n = sample_count(duration_s, sample_period_s)
    t = np.arange(n) * sample_period_s
    which = np.searchsorted(data[:, 0], t + 1e-9 * sample_period_s, side="right") - 1
    out = np.zeros((n, 2))
    valid = which >= 0
    out[valid] = data[which[valid], 1:3]
    return out
