"""The LTV MPC's QP blocks whose matrices the strategies supply (:mod:`~agvctl.controllers.mpc.error_frames`,
:mod:`~agvctl.controllers.mpc.prediction`): the dynamics and the error states' cost (see
:mod:`~agvctl.controllers.mpc.ltv_qp` for the whole QP)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.error_frames import ErrorFrame
from agvctl.controllers.mpc.horizon import turning_in_place
from agvctl.controllers.mpc.ltv_qp import QpReference, QpStep, StepBlock, StepQp, window_versions
from agvctl.controllers.mpc.matrix_exponential import expm_batch
from agvctl.controllers.mpc.prediction import PredictionModel
from agvctl.controllers.mpc.qp_blocks import Pattern, VariableLayout

__all__ = ["Dynamics", "StateCost"]

FloatArray = NDArray[np.float64]


class Dynamics(StepBlock):
    """x_{k+1} − A_k x_k − B_k δs_k = 0, k = 0 … N − 1, x_0 data (A_0 x_0 in the first rows' bounds); A_k and B_k
    the exact discretisation (for held setpoints) of the prediction model's continuous system over each interval,
    written each step at the slots ``"A"`` (A_1 … A_{N−1}) and ``"B"`` (B_0 … B_{N−1}), ordered by k, row, column,
    with the model's heading coupling (the position rows × wheel-speed columns of A).

    Parameters
    ----------
    model : PredictionModel
        The prediction model.
    frame : ErrorFrame
        The error frame.
    horizon : int
        N.
    sample_period_s : float
        T_s, s.
    separation_m : float
        The wheel separation b, m.
    """

    name = "dynamics"
    c_step = "dynamics"
    c_tables_names = ("ad", "neg_ad", "neg_bd", "version")

    def __init__(
        self, model: PredictionModel, frame: ErrorFrame, horizon: int, sample_period_s: float, separation_m: float
    ) -> None:
        self._model, self._frame = model, frame
        self._horizon, self._nx = horizon, model.n_states
        self._period_s, self._separation_m = sample_period_s, separation_m
        self.n_rows = horizon * model.n_states

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """x_{k+1}'s identity; A_k (placeholder 0) and B_k (placeholder 1) at their slots."""
        N, nx, xs, us = self._horizon, self._nx, layout.start("states"), layout.start("setpoints")
        for k in range(N):
            for i in range(nx):
                pattern.add(k * nx + i, xs + k * nx + i, 1.0)
            if k >= 1:
                for i in range(nx):
                    for j in range(nx):
                        pattern.add(k * nx + i, xs + (k - 1) * nx + j, 0.0, "A")
            for i in range(nx):
                for j in range(2):
                    pattern.add(k * nx + i, us + 2 * k + j, 1.0, "B")

    def bind(self, qp: StepQp, rows: slice) -> None:
        """The first rows' bounds (A_0 x_0) and the slots, with where the coupling goes among A's."""
        N, nx = self._horizon, self._nx
        self._data = qp.a_data
        slots = qp.a_slots[self.name]
        self._pos_A, self._pos_B = slots.get("A", np.zeros(0, np.int64)), slots["B"]
        self._lower_first, self._upper_first = qp.lower[rows][:nx], qp.upper[rows][:nx]
        wheels = self._model.wheel_columns
        self._wheels = wheels
        # A_k's entries (first position row, second) × (the wheel-speed columns), k = 1 … N − 1, by k and column
        self._pos_coupled = (
            np.column_stack(
                [self._pos_A[[(k - 1) * nx * nx + i * nx + j for k in range(1, N) for j in wheels]] for i in (0, 1)]
            )
            if wheels is not None
            else None
        )
        self._held: tuple[int, float] | None = None

    def retarget(self, reference: QpReference) -> None:
        """A_j, B_j of every interval of the reference, and which windows share them
        (:func:`window_versions`)."""
        g, nx, N = reference.grid, self._nx, self._horizon
        n = g.n_points - 1
        E = expm_batch(self._model.continuous(g, self._frame, self._separation_m) * self._period_s)
        self._Ad = np.ascontiguousarray(E[:, :nx, :nx])
        self._Ad_rows: list[list[list[float]]] = self._Ad.tolist()  # per-step products as plain floats
        self._neg_Ad_flat = np.ascontiguousarray(-self._Ad).reshape(n * nx * nx)
        self._neg_Bd_flat = np.ascontiguousarray(-E[:, :nx, nx:]).reshape(n * nx * 2)
        # window k takes A_{k+1} … A_{k+N−1}, B_k … B_{k+N−1} and what else the frame's coupling depends on
        sources = [(self._Ad, 1, N - 1), (E[:, :nx, nx:], 0, N - 1), *self._frame.window_sources(g)]
        self._version: list[int] = window_versions(sources, g.last_start + 1).tolist()
        self._held = None

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """nx, the wheel-speed states and where −A_k, −B_k and the coupling's entries lie among A's varying ones."""
        wheels = self._wheels
        return {
            "nx": self._nx,
            "wheels": list(wheels) if wheels is not None else None,
            "a_index": qp.varying_index("A", self._pos_A),
            "b_index": qp.varying_index("A", self._pos_B),
            "coupled_index": (
                [qp.varying_index("A", self._pos_coupled[:, i]) for i in (0, 1)]
                if self._pos_coupled is not None
                else None
            ),
        }

    def c_tables(self) -> dict[str, FloatArray]:
        """A_j, −A_j and −B_j of every interval (row-major) and each window's version."""
        return {
            "ad": self._Ad.ravel(),
            "neg_ad": self._neg_Ad_flat,
            "neg_bd": self._neg_Bd_flat,
            "version": np.asarray(self._version, dtype=np.float64),
        }

    def write(self, step: QpStep) -> None:
        """A_0 x_0 (with the coupling of x_0's wheel speeds) as both bounds of the first rows: each row's products
        summed in index order (the same on every machine and in the generated C; a BLAS product's order is its
        own)."""
        e, first = step.errors, self._lower_first
        for i, row in enumerate(self._Ad_rows[step.k]):
            total = row[0] * e[0]
            for j in range(1, self._nx):
                total += row[j] * e[j]
            first[i] = total
        coupling = step.coupling
        if coupling is not None and self._wheels is not None:
            left, right = self._wheels
            first[0] += coupling[0, 0] * (e[left] + e[right])
            first[1] += coupling[0, 1] * (e[left] + e[right])
        self._upper_first[:] = first

    def write_matrices(self, step: QpStep) -> tuple[bool, bool]:
        """−A_{k+1} … −A_{k+N−1} (the coupling of x_1 … x_{N−1} subtracted, alike for both wheels) and −B_k …
        −B_{k+N−1}, only where the window's version or the coupling's heading changed since the solver last had
        them: unchanged, OSQP keeps its factorisation, which on a straight or a constant arc is most steps."""
        k, nx, N = step.k, self._nx, self._horizon
        key = (self._version[k], step.heading_rad)
        if key == self._held:
            return False, False
        data, nn = self._data, nx * nx
        data[self._pos_A] = self._neg_Ad_flat[(k + 1) * nn : (k + N) * nn]
        data[self._pos_B] = self._neg_Bd_flat[k * nx * 2 : (k + N) * nx * 2]
        coupling = step.coupling
        if coupling is not None and self._pos_coupled is not None:
            rows = self._pos_coupled
            data[rows[:, 0]] -= np.repeat(coupling[1:, 0], 2)
            data[rows[:, 1]] -= np.repeat(coupling[1:, 1], 2)
        self._held = key
        return True, False


class StateCost(StepBlock):
    """The error states' weights Σ_{k=1..N} ‖x_k‖²_Q (terminal scale at k = N): the heading's fixed, the position's
    (slot ``"position"``, by k then first, second) written for each window: where the reference turns in place,
    alike in every direction (``turn_in_place_position_scale``; "along the path" is only where a spinning frame
    points), elsewhere the frame's along-track share on the first.

    Parameters
    ----------
    config : MpcConfig
        The weights.
    frame : ErrorFrame
        The error frame.
    n_states : int
        nx.
    separation_m : float
        The wheel separation b, m (which turns are in place).
    """

    name = "state cost"
    c_step = "state_cost"
    c_tables_names = ("weights", "version")

    def __init__(self, config: MpcConfig, frame: ErrorFrame, n_states: int, separation_m: float) -> None:
        self._config, self._frame, self._nx, self._separation_m = config, frame, n_states, separation_m
        self._horizon_scale = np.ones((config.horizon, 1))
        self._horizon_scale[-1] = config.weight_terminal_scale

    def cost(self, layout: VariableLayout, pattern: Pattern) -> None:
        """2 Q on the diagonal (placeholder 2 for the position's)."""
        c, nx, xs = self._config, self._nx, layout.start("states")
        q_diag = np.zeros(nx)
        q_diag[2] = c.weight_heading
        p_state = np.tile(q_diag, c.horizon)
        p_state[-nx:] *= c.weight_terminal_scale
        p_state[::nx] = 1.0
        p_state[1::nx] = 1.0
        for i, value in enumerate((2.0 * p_state).tolist()):
            if i % nx < 2:
                pattern.add(xs + i, xs + i, value, "position")
            elif value != 0.0:
                pattern.add(xs + i, xs + i, value)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """The position weights' slot."""
        self._data, self._positions = qp.p_data, qp.p_slots[self.name]["position"]
        self._held: int | None = None

    def retarget(self, reference: QpReference) -> None:
        """The position weights (first, second) at each grid point, and which windows share them."""
        c, g = self._config, reference.grid
        share = self._frame.along_track_share(c)
        spinning = turning_in_place(g.yaw_rate_rad_s, g.speed_m_s, self._separation_m)
        weights = np.empty((g.n_points, 2))
        weights[:, 0] = np.where(spinning, c.turn_in_place_position_scale, share)
        weights[:, 1] = np.where(spinning, c.turn_in_place_position_scale, 1.0)
        self._weights = weights * 2.0 * c.weight_position
        self._version: list[int] = window_versions([(self._weights, 1, c.horizon)], g.last_start + 1).tolist()
        self._held = None

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """Where the position weights lie among P's varying entries, and each sample's horizon scale."""
        return {
            "index": qp.varying_index("P", self._positions),
            "scale": self._horizon_scale.ravel().tolist(),
        }

    def c_tables(self) -> dict[str, FloatArray]:
        """The position weights by grid point (first, second) and each window's version."""
        return {"weights": self._weights.ravel(), "version": np.asarray(self._version, dtype=np.float64)}

    def write_matrices(self, step: QpStep) -> tuple[bool, bool]:
        """The weights of points k + 1 … k + N, where the window's version changed."""
        k = step.k
        key = self._version[k]
        if key == self._held:
            return False, False
        self._data[self._positions] = (
            self._weights[k + 1 : k + self._config.horizon + 1] * self._horizon_scale
        ).ravel()
        self._held = key
        return False, True
