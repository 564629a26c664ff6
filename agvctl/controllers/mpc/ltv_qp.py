"""The QP of the LTV MPC (:mod:`agvctl.controllers.mpc.ltv`): where its variables and constraint rows lie, the
sparsity pattern of its constraint matrix and its cost matrix.

Variables z = [x_1 … x_N, δs_0 … δs_{N−1}, r_0 … r_{M−1}] (error states, then setpoints minus feed-forward, two per
sample, then, with a reversal weight, the reversal slacks of the first M samples, two per sample). Rows: the dynamics
x_{k+1} − A_k x_k − B_k δs_k = 0 (N·nx), the speed box on δs (2N), the rate δs_k − δs_{k−1} (2(N − 1)), the first
move from the previous command (2), with the wheel-loop model the setpoints' reachable lead over the predicted wheel
speeds s_k − v_k (2(N − 1)) and, with the reversal slacks, r_k + δs_k (2M), r_k − δs_k (2M) and r_k (2M): with
r_k ≥ 0 and r_k ≥ −d_k s_k (d_k the wheel's direction, one of the first two rows left open), r_k is at least the
setpoint's speed against its wheel's direction, and its linear cost makes it exactly that.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.controllers.mpc.config import MpcConfig

__all__ = ["REVERSAL_SAMPLES", "QpLayout", "constraint_pattern", "cost_matrix", "window_versions"]

REVERSAL_SAMPLES = 5
"""M, the samples at the head of the horizon whose setpoints pay the reversal weight: 0.2 s, two time constants of
the wheel loop. A reversal planned later is charged once it comes this close, so the start-up correction blends into
driving off as with slacks on the whole horizon, which cost OSQP far more iterations on a start off the path
(``docs/decisions/0028-reversal-weight.md``)."""


@document_fields
@dataclass(frozen=True)
class QpLayout:
    """Where the QP's variables and constraint rows lie (see the module notes)."""

    horizon: int
    """N, the horizon in samples."""
    n_states: int
    """nx, the error states per sample: 3 (the pose) or, with the wheel-loop model, 5."""
    wheel_loop: bool
    """Whether the states include the wheel-loop lag (then the reachable-lead rows exist)."""
    reversal_samples: int = 0
    """M, the samples whose reversal slacks r_k the QP holds, with their rows (0: none)."""

    @property
    def i_setpoints(self) -> int:
        """Index of δs_0 in z."""
        return self.horizon * self.n_states

    @property
    def i_slacks(self) -> int:
        """Index of r_0 in z, one past the setpoints."""
        return self.i_setpoints + 2 * self.horizon

    @property
    def n_variables(self) -> int:
        """The number of variables: N·nx error states, 2N setpoints and 2M reversal slacks."""
        return self.i_slacks + 2 * self.reversal_samples

    @property
    def r_box(self) -> int:
        """First row of the speed box."""
        return self.horizon * self.n_states

    @property
    def r_rate(self) -> int:
        """First row of the setpoints' rate δs_k − δs_{k−1}, k = 1 … N − 1."""
        return self.r_box + 2 * self.horizon

    @property
    def r_first(self) -> int:
        """First of the two rows of the first move from the previous command."""
        return self.r_rate + 2 * (self.horizon - 1)

    @property
    def r_reach(self) -> int:
        """First row of the setpoints' reachable lead over the predicted wheel speeds."""
        return self.r_first + 2

    @property
    def r_reversal(self) -> int:
        """First of the reversal rows: r_k + δs_k, then r_k − δs_k, then r_k (2M each)."""
        return self.r_reach + (2 * (self.horizon - 1) if self.wheel_loop else 0)

    @property
    def n_rows(self) -> int:
        """The number of constraint rows (the reachable-lead rows with the wheel-loop model only)."""
        return self.r_reversal + 6 * self.reversal_samples


def cost_matrix(config: MpcConfig, layout: QpLayout) -> sp.csc_matrix:
    """P of the QP's cost ½ zᵀPz + qᵀz, its upper triangle: the state weights (terminal scale at k = N), the input
    and input-rate weights (the reversal slacks' cost is linear: q only).

    The position weights are placeholders, kept in the sparsity pattern: the LTV MPC sets them for each reference (the
    path frame's along-track share, the turns in place) and loads each step's window of them.

    Parameters
    ----------
    config : MpcConfig
        The weights: heading, terminal scale, input and input rate.
    layout : QpLayout
        Where the variables lie.

    Returns
    -------
    scipy.sparse.csc_matrix
        The upper triangle of P, ``n_variables`` square.
    """
    c, N, nx = config, layout.horizon, layout.n_states
    q_diag = np.zeros(nx)
    q_diag[2] = c.weight_heading
    p_state = np.tile(q_diag, N)
    p_state[-nx:] *= c.weight_terminal_scale
    p_state[::nx] = 1.0
    p_state[1::nx] = 1.0
    diff = sp.eye(2 * N, format="csc") - sp.eye(2 * N, k=-2, format="csc")  # rows: δs_k − δs_{k−1}
    p_input = 2.0 * c.weight_input * sp.eye(2 * N) + 2.0 * c.weight_input_rate * (diff.T @ diff)
    blocks = [sp.diags(2.0 * p_state), p_input, sp.csc_matrix((2 * layout.reversal_samples,) * 2)]
    return sp.triu(sp.block_diag(blocks, format="csc"), format="csc")


def constraint_pattern(layout: QpLayout) -> tuple[sp.csc_matrix, NDArray[np.int64], NDArray[np.int64]]:
    """The QP's constraint matrix with every entry that can ever be nonzero, and where its time-varying entries lie.

    The time-varying entries, the dynamics' A_k and B_k, are zero or one here; each step writes its window's values
    (negated) at the returned positions of the CSC data array, so the sparsity pattern OSQP is set up with never
    changes.

    Parameters
    ----------
    layout : QpLayout
        Where the variables and the rows lie.

    Returns
    -------
    matrix : scipy.sparse.csc_matrix
        The constraint matrix, ``n_rows`` × ``n_variables``, its indices sorted.
    positions_a : ndarray of int
        The positions in ``matrix.data`` of the entries of A_1 … A_{N−1}, ordered by k, row, column.
    positions_b : ndarray of int
        The positions in ``matrix.data`` of the entries of B_0 … B_{N−1}, ordered by k, row, column.
    """
    N, nx, iU, n_z, n_rows = layout.horizon, layout.n_states, layout.i_setpoints, layout.n_variables, layout.n_rows
    r_box, r_rate, r_first, r_reach = layout.r_box, layout.r_rate, layout.r_first, layout.r_reach
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []

    def add(r: int, col: int, v: float) -> int:
        rows.append(r)
        cols.append(col)
        vals.append(v)
        return len(rows) - 1

    # dynamics x_{k+1} − A_k x_k − B_k δs_k = 0; x_0 is data, so A_0 x_0 goes into the bounds
    a_entries: list[int] = []
    b_entries: list[int] = []
    for k in range(N):
        for i in range(nx):
            add(k * nx + i, k * nx + i, 1.0)
        if k >= 1:
            for i in range(nx):
                for j in range(nx):
                    a_entries.append(add(k * nx + i, (k - 1) * nx + j, 0.0))
        for i in range(nx):
            for j in range(2):
                b_entries.append(add(k * nx + i, iU + 2 * k + j, 1.0))
    for k in range(2 * N):  # speed box on δs
        add(r_box + k, iU + k, 1.0)
    for k in range(1, N):  # rate δs_k − δs_{k−1}
        for j in range(2):
            add(r_rate + 2 * (k - 1) + j, iU + 2 * k + j, 1.0)
            add(r_rate + 2 * (k - 1) + j, iU + 2 * (k - 1) + j, -1.0)
    for j in range(2):  # first move from the previous command s_{−1}
        add(r_first + j, iU + j, 1.0)
    if layout.wheel_loop:  # reachable lead of the setpoint over the wheel: s_k − v_k (v_0 is data, in the bounds)
        for k in range(1, N):
            for j in range(2):
                add(r_reach + 2 * (k - 1) + j, iU + 2 * k + j, 1.0)
                add(r_reach + 2 * (k - 1) + j, (k - 1) * nx + 3 + j, -1.0)
    # r_k + δs_k ≥ −s_ff,k (headed forward), r_k − δs_k ≥ s_ff,k (backward), r_k ≥ 0
    r_rev, i_r, n_r = layout.r_reversal, layout.i_slacks, 2 * layout.reversal_samples
    for i in range(n_r):
        for block, sign in ((0, 1.0), (1, -1.0)):
            add(r_rev + n_r * block + i, i_r + i, 1.0)
            add(r_rev + n_r * block + i, iU + i, sign)
        add(r_rev + 2 * n_r + i, i_r + i, 1.0)

    ids = np.arange(1, len(rows) + 1, dtype=np.float64)
    A = sp.csc_matrix((ids, (rows, cols)), shape=(n_rows, n_z))
    A.sort_indices()
    order = A.data.astype(np.int64) - 1  # CSC position p holds entry order[p]
    position = np.empty_like(order)
    position[order] = np.arange(len(order))
    A.data = np.asarray(vals, dtype=np.float64)[order]
    pos_A = position[np.asarray(a_entries, dtype=np.int64)]
    pos_B = position[np.asarray(b_entries, dtype=np.int64)]
    return A, pos_A, pos_B


def window_versions(sources: list[tuple[NDArray[np.float64], int, int]], n_windows: int) -> NDArray[np.int64]:
    """A version number for each window start that changes exactly where the window's data does.

    Windows k − 1 and k have the same number if and only if their data are equal (NaN counts as a change), so a
    solver holding the data of one window needs no update for the next while the number stays.

    Parameters
    ----------
    sources : list of (ndarray, int, int)
        The window's data: each an array indexed along its first axis by grid point or interval j, with the offsets
        (first, last) of the entries window k takes, j = k + first … k + last (none when first > last).
    n_windows : int
        The number of window starts, k = 0 … ``n_windows`` − 1.

    Returns
    -------
    ndarray of int
        The version of each window start, 0 for the first, rising by one at each change.
    """
    changes = np.zeros(n_windows, dtype=np.int64)
    k = np.arange(1, n_windows)
    for values, first, last in sources:
        if first > last:
            continue
        flat = values.reshape(len(values), -1)
        # differs[j]: entry j differs from entry j − 1 (NaN differs from everything: at worst an update too many)
        differs = np.zeros(len(values) + 1, dtype=np.int64)
        differs[1 : len(values)] = np.any(flat[1:] != flat[:-1], axis=1)
        cumulative = np.concatenate(([0], np.cumsum(differs)))
        # window k against window k − 1: entries j = k + first … k + last against j − 1
        changes[1:] += cumulative[k + last + 1] - cumulative[k + first]
    return np.cumsum(changes > 0)
