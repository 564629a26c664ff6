"""Fast, accurate integration of the full model over zero-order-hold samples.

The scheme (``docs/decisions/0014-plant-integrator.md``, ``experiments/benchmarks/plant.py``): classical RK4 with a
fixed number of substeps per sample period, the input held over the sample and every sample boundary a step
boundary, so no step straddles an input jump. The friction (eqs 2-4) and the current limit are continuous,
piecewise-smooth functions of the state, which fixed steps handle well; an adaptive solver at rtol 1e-10 is the
reference in the tests. The number of substeps is set per vehicle from its fastest time constant (the stiction
spring P/J̃ is the stiffest loop), at least 8 per 40 ms sample. One kernel of 8 substeps is compiled; a stiffer
vehicle splits each sample into 2^k sub-samples with the input held, so every vehicle shares one library.

The sample step is built in CasADi, accumulated over chunks of samples (``mapaccum``) and over vehicles
(``map``); :mod:`agvctl.plant.codegen` turns it into C, compiles it once and caches the library on disk (or,
without a C compiler, runs it in CasADi's virtual machine).
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Iterable
from dataclasses import dataclass

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from agvctl.errors import ConfigError
from agvctl.params import VehicleParams
from agvctl.params.schema import MAX_PLANT_SUBSTEPS, PLANT_STIFFNESS_STEP
from agvctl.plant.codegen import CFunctionAddress, NumericFunction, cache_dir, native_functions
from agvctl.plant.full import AUX_NAMES, INPUT_NAMES, PARAMETER_NAMES, STATE_NAMES, FullModel, PlantOptions

__all__ = [
    "KERNEL_SUBSTEPS",
    "STATS_NAMES",
    "CompiledPlant",
    "cache_dir",
    "choose_substeps",
    "compiled_plant",
    "merge_stats",
    "sample_splits",
]

STATS_NAMES = (
    "current_limited_fraction_left",
    "current_limited_fraction_right",
    "current_peak_left_a",
    "current_peak_right_a",
    "wheel_accel_peak_left_m_s2",
    "wheel_accel_peak_right_m_s2",
    "motor_angle_increment_left_rad",
    "motor_angle_increment_right_rad",
)
"""Per-sample statistics over the substeps of the interval (fractions of substeps; peaks of absolute values;
the motor-shaft angle turned, ∫ω_mot dt by the RK4 quadrature of the same stages, which the encoders count)."""

CHUNK_SAMPLES = 250
"""Samples per compiled accumulation call (10 s at 40 ms); longer runs loop over chunks."""
BATCH_VEHICLES = 50
"""Vehicles per compiled batch call."""
MIN_SUBSTEPS_PER_SAMPLE_S = 1.0 / 0.005
"""At least one substep per 5 ms (8 per 40 ms sample): errors ~50x below the accuracy goal on the default AGV."""
KERNEL_SUBSTEPS = 8
"""RK4 substeps in the compiled sample kernel."""
STIFFNESS_STEP = PLANT_STIFFNESS_STEP
"""Largest h·λ allowed for the stiffest mode (RK4's real-axis stability limit is 2.78)."""


def choose_substeps(vehicle: VehicleParams) -> int:
    """RK4 substeps per sample for a vehicle: at least one per 5 ms, and h·λ_max ≤ 0.4, rounded up to 2^k.

    λ_max is :meth:`~agvctl.params.VehicleParams.stiffest_rate_1_s`: the stiction spring of eqs 2-3 (or the
    back-EMF damping, if P is set below it) against the inertia.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its sample period and its stiffest mode.

    Returns
    -------
    int
        The substeps, a power of two.

    Raises
    ------
    ConfigError
        Naming ``friction_model.p_factor`` when more than :data:`~agvctl.params.schema.MAX_PLANT_SUBSTEPS` would be
        needed (a vehicle loaded from a file is refused so when it is loaded).
    """
    ts = vehicle.control.sample_period_s
    needed = max(ts * MIN_SUBSTEPS_PER_SAMPLE_S, ts * vehicle.stiffest_rate_1_s() / STIFFNESS_STEP, 1.0)
    if not needed <= MAX_PLANT_SUBSTEPS:
        raise ConfigError(
            f"vehicle {vehicle.name}",
            "friction_model.p_factor",
            f"the plant would need {needed:.3g} RK4 substeps per control sample, above the maximum "
            f"{MAX_PLANT_SUBSTEPS}",
        )
    return int(2 ** math.ceil(math.log2(needed - 1e-9)))


def sample_splits(vehicles: VehicleParams | Iterable[VehicleParams]) -> int:
    """Sub-samples per sample so that the kernel's 8 substeps give :func:`choose_substeps`.

    Parameters
    ----------
    vehicles : VehicleParams or iterable of VehicleParams
        The vehicle, or the vehicles simulated together in one batch.

    Returns
    -------
    int
        The sub-samples the kernel runs per control sample, for the vehicle that needs the most.
    """
    vs = [vehicles] if isinstance(vehicles, VehicleParams) else list(vehicles)
    return max(1, max(choose_substeps(v) for v in vs) // KERNEL_SUBSTEPS)


def merge_stats(stats: NDArray[np.float64], splits: int) -> NDArray[np.float64]:
    """Combine the statistics of sub-samples into the samples': fractions averaged, peaks maxed, angle increments
    summed.

    Parameters
    ----------
    stats : ndarray
        :data:`STATS_NAMES` over each sub-sample, … × (n·splits) × 8.
    splits : int
        Sub-samples per sample.

    Returns
    -------
    ndarray
        The statistics over each sample, … × n × 8.
    """
    if splits == 1:
        return stats
    s = stats.reshape(*stats.shape[:-2], -1, splits, stats.shape[-1])
    return np.concatenate([s[..., :2].mean(axis=-2), s[..., 2:6].max(axis=-2), s[..., 6:].sum(axis=-2)], axis=-1)


def _rk4_sample_step(model: FullModel, substeps: int) -> ca.Function:
    """One sample: ``(x, u, p, dt) -> (x_next, aux at the start, STATS over the substeps)``."""
    f = model.rhs
    x = ca.SX.sym("x", len(STATE_NAMES))
    u = ca.SX.sym("u", len(INPUT_NAMES))
    p = ca.SX.sym("p", len(PARAMETER_NAMES))
    dt = ca.SX.sym("dt")
    h = dt / substeps
    xk = x
    aux0 = None
    limited = [ca.SX(0), ca.SX(0)]
    i_peak = [ca.SX(0), ca.SX(0)]
    a_peak = [ca.SX(0), ca.SX(0)]
    angle = [ca.SX(0), ca.SX(0)]
    i_omega = AUX_NAMES.index("omega_motor_left_rad_s")
    i_cur, i_lim, i_acc = (
        AUX_NAMES.index("current_left_a"),
        AUX_NAMES.index("current_limited_left"),
        AUX_NAMES.index("wheel_accel_left_m_s2"),
    )
    for _ in range(substeps):
        k1, aux = f(xk, u, p)
        if aux0 is None:
            aux0 = aux
        for s in range(2):
            limited[s] = limited[s] + aux[i_lim + s]
            i_peak[s] = ca.fmax(i_peak[s], ca.fabs(aux[i_cur + s]))
            a_peak[s] = ca.fmax(a_peak[s], ca.fabs(aux[i_acc + s]))
        k2, aux2 = f(xk + h / 2 * k1, u, p)
        k3, aux3 = f(xk + h / 2 * k2, u, p)
        k4, aux4 = f(xk + h * k3, u, p)
        for s in range(2):  # the motor angle as an RK4 quadrature of ω_mot (eq 2) over the same stages
            j = i_omega + s
            angle[s] = angle[s] + h / 6 * (aux[j] + 2 * aux2[j] + 2 * aux3[j] + aux4[j])
        xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert aux0 is not None
    stats = ca.vertcat(
        limited[0] / substeps, limited[1] / substeps, i_peak[0], i_peak[1], a_peak[0], a_peak[1], angle[0], angle[1]
    )
    return ca.Function("agv_step", [x, u, p, dt], [xk, aux0, stats], ["x", "u", "p", "dt"], ["x_next", "aux", "stats"])


@dataclass
class _Functions:
    step: NumericFunction
    chunk: NumericFunction
    batch: NumericFunction
    aux: NumericFunction


class CompiledPlant:
    """The full model's sample step, chunk accumulation and batch map, compiled (or in CasADi's VM).

    Use :func:`compiled_plant` to get a shared, cached instance.

    Parameters
    ----------
    options : PlantOptions
        The nonlinear effects the model includes.
    """

    def __init__(self, options: PlantOptions) -> None:
        model = FullModel(options)
        step = _rk4_sample_step(model, KERNEL_SUBSTEPS)
        acc = step.mapaccum("agv_acc", CHUNK_SAMPLES, [0], [0], {})
        # parameters and dt are the same for every sample of a chunk: repeat them inside the generated code
        cx, cu, cp, cdt = (
            ca.MX.sym("x0", len(STATE_NAMES)),
            ca.MX.sym("u", 2, CHUNK_SAMPLES),
            ca.MX.sym("p", len(PARAMETER_NAMES)),
            ca.MX.sym("dt"),
        )
        chunk = ca.Function(  # type: ignore[call-overload]
            "agv_chunk",
            [cx, cu, cp, cdt],
            acc(cx, cu, ca.repmat(cp, 1, CHUNK_SAMPLES), ca.repmat(cdt, 1, CHUNK_SAMPLES)),
            ["x0", "u", "p", "dt"],
            ["x", "aux", "stats"],
        )
        n_threads = max(1, min(os.cpu_count() or 1, 8))
        batch = chunk.map(BATCH_VEHICLES, "thread", n_threads)
        args = batch.mx_in()
        batch = ca.Function("agv_batch", args, batch.call(args), ["x0", "u", "p", "dt"], ["x", "aux", "stats"])
        aux = ca.Function("agv_aux", [model.x, model.u, model.p], [model.aux])
        self._fns = _Functions(*native_functions((step, chunk, batch, aux), "agv_plant"))

    # -- evaluation -------------------------------------------------------------------------------------------

    def step(
        self, x: NDArray[np.float64], u: NDArray[np.float64], p: NDArray[np.float64], dt: float, splits: int = 1
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Advance one sample of length ``dt``: returns ``(x_next, aux at the start, stats over the interval)``."""
        x_next, aux, stats = self._fns.step(x, u, p, dt / splits)
        aux0 = aux.ravel()
        if splits == 1:
            return x_next.ravel(), aux0, stats.ravel()
        all_stats = [stats.ravel()]
        for _ in range(splits - 1):
            x_next, _aux, stats = self._fns.step(x_next, u, p, dt / splits)
            all_stats.append(stats.ravel())
        return x_next.ravel(), aux0, merge_stats(np.array(all_stats), splits)[0]

    def step_address(self) -> CFunctionAddress | None:
        """The compiled sample step (``x, u, p, dt -> x_next, aux at the start, stats``), for C that calls it
        directly; None where the model runs in CasADi's virtual machine."""
        return self._fns.step.address

    def aux(self, x: NDArray[np.float64], u: NDArray[np.float64], p: NDArray[np.float64]) -> NDArray[np.float64]:
        """The instantaneous outputs (:data:`AUX_NAMES`) at state ``x`` with input ``u``."""
        return self._fns.aux(x, u, p)[0].ravel()

    def run(
        self, x0: NDArray[np.float64], u: NDArray[np.float64], p: NDArray[np.float64], dt: float, splits: int = 1
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Integrate ``u`` (n×2, held per sample of length ``dt``) from ``x0``.

        Returns ``(X, AUX, STATS)``: X (n+1)×5 states at the sample times, AUX n×10 outputs at the start of each
        sample, STATS n×8 interval statistics.
        """
        n = u.shape[0]
        u = np.repeat(u, splits, axis=0)
        m = u.shape[0]
        n_chunks = max(1, -(-m // CHUNK_SAMPLES))
        padded = np.zeros((n_chunks * CHUNK_SAMPLES, 2))
        padded[:m] = u
        xs, auxs, stats = [], [], []
        x = np.asarray(x0, dtype=float)
        for c in range(n_chunks):
            uc = padded[c * CHUNK_SAMPLES : (c + 1) * CHUNK_SAMPLES].T
            X, A, S = self._fns.chunk(x, uc, p, dt / splits)
            xs.append(X.T)
            auxs.append(A.T)
            stats.append(S.T)
            x = X[:, -1].copy()
        X_all = np.vstack([np.asarray(x0, dtype=float)[None, :], *xs])[: m + 1 : splits]
        A_all = np.vstack(auxs)[:m:splits]
        S_all = merge_stats(np.vstack(stats)[:m], splits)
        assert X_all.shape[0] == n + 1
        return X_all, A_all, S_all

    def run_batch(
        self, x0: NDArray[np.float64], u: NDArray[np.float64], p: NDArray[np.float64], dt: float, splits: int = 1
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Integrate many vehicles at once: ``x0`` B×5, ``u`` B×n×2, ``p`` B×n_p.

        Returns ``(X, AUX, STATS)`` with shapes B×(n+1)×5, B×n×10, B×n×8.
        """
        n_vehicles = u.shape[0]
        u = np.repeat(u, splits, axis=1)
        m = u.shape[1]
        n_chunks = max(1, -(-m // CHUNK_SAMPLES))
        n_groups = max(1, -(-n_vehicles // BATCH_VEHICLES))
        nb = n_groups * BATCH_VEHICLES
        U = np.zeros((nb, n_chunks * CHUNK_SAMPLES, 2))
        U[:n_vehicles, :m] = u
        P = np.repeat(np.asarray(p, dtype=float)[:1], nb, axis=0)
        P[:n_vehicles] = p
        X0 = np.zeros((nb, len(STATE_NAMES)))
        X0[:n_vehicles] = x0
        X_out = np.empty((nb, n_chunks * CHUNK_SAMPLES + 1, len(STATE_NAMES)))
        A_out = np.empty((nb, n_chunks * CHUNK_SAMPLES, len(AUX_NAMES)))
        S_out = np.empty((nb, n_chunks * CHUNK_SAMPLES, len(STATS_NAMES)))
        X_out[:, 0] = X0
        dt_row = np.full((1, BATCH_VEHICLES), dt / splits)
        for g in range(n_groups):
            sl = slice(g * BATCH_VEHICLES, (g + 1) * BATCH_VEHICLES)
            x = X0[sl].T.copy()
            for c in range(n_chunks):
                cs = slice(c * CHUNK_SAMPLES, (c + 1) * CHUNK_SAMPLES)
                # the batch function takes the vehicles' chunks side by side: u is 2 × (CHUNK · B)
                uc = U[sl, cs].transpose(2, 0, 1).reshape(2, -1)
                X, A, S = self._fns.batch(x, uc, P[sl].T, dt_row)
                X = X.reshape(len(STATE_NAMES), BATCH_VEHICLES, CHUNK_SAMPLES)
                A = A.reshape(len(AUX_NAMES), BATCH_VEHICLES, CHUNK_SAMPLES)
                S = S.reshape(len(STATS_NAMES), BATCH_VEHICLES, CHUNK_SAMPLES)
                X_out[sl, c * CHUNK_SAMPLES + 1 : (c + 1) * CHUNK_SAMPLES + 1] = X.transpose(1, 2, 0)
                A_out[sl, cs] = A.transpose(1, 2, 0)
                S_out[sl, cs] = S.transpose(1, 2, 0)
                x = X[:, :, -1]
        X_all = X_out[:n_vehicles, : m + 1 : splits]
        A_all = A_out[:n_vehicles, :m:splits]
        S_all = merge_stats(S_out[:n_vehicles, :m], splits)
        return X_all, A_all, S_all


_CACHE: dict[PlantOptions, CompiledPlant] = {}
_LOCK = threading.Lock()


def compiled_plant(options: PlantOptions | None = None) -> CompiledPlant:
    """The shared :class:`CompiledPlant` for a set of model options.

    Parameters
    ----------
    options : PlantOptions or None
        The nonlinear effects the model includes (None: all of them).

    Returns
    -------
    CompiledPlant
        Built, or loaded from the disk cache, on first use; the same instance afterwards.
    """
    key = options or PlantOptions()
    with _LOCK:
        plant = _CACHE.get(key)
        if plant is None:
            plant = CompiledPlant(key)
            _CACHE[key] = plant
        return plant
