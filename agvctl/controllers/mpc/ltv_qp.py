"""The QP of the LTV MPC (:mod:`agvctl.controllers.mpc.ltv`) as named blocks (:mod:`~agvctl.controllers.mpc.qp_blocks`):
what they are written from, and the blocks on the setpoints.

Variables z = [x_1 … x_N, δs_0 … δs_{N−1}, r_0 … r_{M−1}]: the error states (``"states"``, nx per sample), the
setpoints minus feed-forward (``"setpoints"``, two per sample) and, with a reversal weight, the reversal slacks of the
first M samples (``"reversal slacks"``, two per sample). The blocks, in row order:

* :class:`~agvctl.controllers.mpc.ltv_qp_model.Dynamics`, x_{k+1} − A_k x_k − B_k δs_k = 0 (N·nx rows; A_0 x_0 in
  the bounds), A_k and B_k from the prediction model and error frame (:mod:`~agvctl.controllers.mpc.prediction`);
* :class:`SpeedBox`, the speed box on δs (2N);
* :class:`Rate`, the rate δs_k − δs_{k−1} (2(N − 1));
* :class:`FirstMove`, the first move from the previous command (2);
* the prediction model's own: with the wheel-loop model :class:`~agvctl.controllers.mpc.reach.Reach`, the
  setpoints' reachable lead over the predicted wheel speeds s_k − v_k (2(N − 1));
* :class:`Reversal`, with the reversal slacks: r_k + δs_k (2M), r_k − δs_k (2M) and r_k (2M). With r_k ≥ 0 and
  r_k ≥ −d_k s_k (d_k the wheel's direction, one of the first two rows left open), r_k is at least the setpoint's
  speed against its wheel's direction, and its linear cost makes it exactly that;
* the cost's blocks, without rows: :class:`~agvctl.controllers.mpc.ltv_qp_model.StateCost` (the error states'
  weights) and :class:`InputCost` (the setpoints' and their rate's).

Each precomputes its data for a reference (:class:`QpReference`) and writes its part of each step (:class:`QpStep`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.qp_blocks import BlockQp, Pattern, QpBlock, VariableBlock, VariableLayout
from agvctl.controllers.mpc.shaping import SetpointWindow
from agvctl.feasibility import WheelReach

__all__ = [
    "INF",
    "REVERSAL_SAMPLES",
    "FirstMove",
    "InputCost",
    "QpReference",
    "QpStep",
    "Rate",
    "Reversal",
    "SpeedBox",
    "reversal_samples",
    "window_versions",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

INF = 1.0e30
"""A bound that is no bound (OSQP's infinity)."""

REVERSAL_SAMPLES = 5
"""M, the samples at the head of the horizon whose setpoints pay the reversal weight: 0.2 s, two time constants of
the wheel loop. A reversal planned later is charged once it comes this close, so the start-up correction blends into
driving off as with slacks on the whole horizon, which cost OSQP far more iterations on a start off the path
(``docs/decisions/0028-reversal-weight.md``)."""


@document_fields
@dataclass(frozen=True)
class QpReference:
    """What the blocks precompute from, for one reference."""

    grid: HorizonReference
    """The reference on the horizon grid."""
    max_wheel_speed_m_s: float
    """v_max, the setpoints' speed limit, m/s."""
    max_step_m_s: float
    """a_lim·T_s, the setpoints' largest change in one sample, m/s."""
    feedforward_step_m_s: FloatArray
    """d_j = s_ff,j − s_ff,j−1 (d_0 = 0): the rate of the feed-forward itself (grid points × 2), m/s."""
    reach: WheelReach
    """What each wheel can reach from a speed."""
    lead_factor_s: float
    """The time over which a setpoint may lead its wheel by the wheel's reachable acceleration, s."""


@document_fields
@dataclass(slots=True)
class QpStep:
    """What the blocks write one step from."""

    k: int
    """The window's first grid point."""
    x0: FloatArray
    """x_0, the initial error (nx)."""
    errors: list[float]
    """x_0 as floats."""
    start_m_s: tuple[float, float]
    """s_{−1} − s_ff,0 (left, right), with s_{−1} the previous command brought into the speed box, m/s."""
    feedforward_m_s: tuple[float, float]
    """s_ff,0 (left, right), m/s."""
    heading_rad: float
    """The heading error the coupling is linearised about, rad (0: none)."""
    coupling: FloatArray | None
    """The heading coupling of x_0 … x_{N−1} (N × 2), or None (see
    :meth:`~agvctl.controllers.mpc.prediction.PredictionModel.coupling`)."""
    wheel_speed_m_s: FloatArray
    """The measured wheel speeds (left, right), m/s."""
    window: SetpointWindow | None
    """Where the setpoints can be reached (None for a broken measurement)."""


StepBlock = QpBlock[QpReference, QpStep]
StepQp = BlockQp[QpReference, QpStep]


class SpeedBox(StepBlock):
    """``|s_k| ≤ v_max``: δs_k ∈ [−v_max − s_ff,k, v_max − s_ff,k] (2N rows).

    Parameters
    ----------
    horizon : int
        N.
    """

    name = "speed box"
    c_step = "speed_box"
    c_tables_names = ("lower", "upper")

    def __init__(self, horizon: int) -> None:
        self._horizon = horizon
        self.n_rows = 2 * horizon

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """δs itself."""
        us = layout.start("setpoints")
        for i in range(2 * self._horizon):
            pattern.add(i, us + i, 1.0)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """Its bounds; :attr:`first` is the first sample's (lower, upper) × (left, right), which a later block may
        tighten."""
        self._bounds = qp.bounds[:, rows]
        self.first = self._bounds[:, :2]
        """The first sample's bounds, (lower, upper) × (left, right), m/s."""

    def retarget(self, reference: QpReference) -> None:
        """The box around the feed-forward at every grid point."""
        ff, v_max = reference.grid.feedforward_m_s, reference.max_wheel_speed_m_s
        self._box = np.stack([(-v_max - ff).ravel(), (v_max - ff).ravel()])  # (lower, upper) × flat samples

    def c_tables(self) -> dict[str, FloatArray]:
        """The box's lower and upper bounds, by grid point and wheel."""
        return {"lower": self._box[0], "upper": self._box[1]}

    def write(self, step: QpStep) -> None:
        """The window's box."""
        k = step.k
        self._bounds[:] = self._box[:, 2 * k : 2 * (k + self._horizon)]


class Rate(StepBlock):
    """``|s_k − s_{k−1}| ≤ a_lim·T_s``, k = 1 … N − 1: δs_k − δs_{k−1} ∈ ±a_lim·T_s − d_k (2(N − 1) rows).

    Parameters
    ----------
    horizon : int
        N.
    """

    name = "rate"
    c_step = "rate"
    c_tables_names = ("lower", "upper")

    def __init__(self, horizon: int) -> None:
        self._horizon = horizon
        self.n_rows = 2 * (horizon - 1)

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """δs_k − δs_{k−1}."""
        us = layout.start("setpoints")
        for k in range(1, self._horizon):
            for j in range(2):
                pattern.add(2 * (k - 1) + j, us + 2 * k + j, 1.0)
                pattern.add(2 * (k - 1) + j, us + 2 * (k - 1) + j, -1.0)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """Its bounds."""
        self._bounds = qp.bounds[:, rows]

    def retarget(self, reference: QpReference) -> None:
        """The bounds at every grid point."""
        d, a_step = reference.feedforward_step_m_s, reference.max_step_m_s
        self._rate = np.stack([(-a_step - d).ravel(), (a_step - d).ravel()])

    def c_tables(self) -> dict[str, FloatArray]:
        """The bounds' lower and upper values, by grid point and wheel."""
        return {"lower": self._rate[0], "upper": self._rate[1]}

    def write(self, step: QpStep) -> None:
        """The window's bounds."""
        k = step.k
        self._bounds[:] = self._rate[:, 2 * (k + 1) : 2 * (k + self._horizon)]


class FirstMove(StepBlock):
    """``|s_0 − s_{−1}| ≤ a_lim·T_s``, s_{−1} the previous command brought into the speed box (2 rows): the only case
    where the hard first move could be infeasible is ``|s_{−1}| > v_max + a_lim·T_s``, and there it is
    relaxed just enough."""

    name = "first move"
    c_step = "first_move"
    c_tables_names = ("step",)
    n_rows = 2

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """δs_0."""
        us = layout.start("setpoints")
        for j in range(2):
            pattern.add(j, us + j, 1.0)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """Its bounds."""
        self._lower, self._upper = qp.lower[rows], qp.upper[rows]

    def retarget(self, reference: QpReference) -> None:
        """a_lim·T_s."""
        self._step_m_s = reference.max_step_m_s

    def c_tables(self) -> dict[str, FloatArray]:
        """a_lim·T_s."""
        return {"step": np.array([self._step_m_s])}

    def write(self, step: QpStep) -> None:
        """s_{−1} − s_ff,0 ± a_lim·T_s."""
        (start_l, start_r), a_step, lo, hi = step.start_m_s, self._step_m_s, self._lower, self._upper
        lo[0], lo[1] = start_l - a_step, start_r - a_step
        hi[0], hi[1] = start_l + a_step, start_r + a_step


class Reversal(StepBlock):
    """The reversal slacks r_k of the first M samples (variables ``"reversal slacks"``) with their linear cost
    ``weight_reversal`` and rows r_k + δs_k ≥ −s_ff,k where the wheel heads forward, r_k − δs_k ≥ s_ff,k where it
    heads backward (each row open otherwise) and r_k ≥ 0 (6M rows).

    Parameters
    ----------
    samples : int
        M.
    weight : float
        The slacks' linear cost w_r, per m/s.
    """

    name = "reversal"
    c_step = "reversal"
    c_tables_names = ("forward", "backward")

    def __init__(self, samples: int, weight: float) -> None:
        self._samples, self._weight = samples, weight
        self.variables = (VariableBlock("reversal slacks", 2 * samples),)
        self.n_rows = 6 * samples

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """r_k ± δs_k, r_k."""
        n_r, i_r, us = 2 * self._samples, layout.start("reversal slacks"), layout.start("setpoints")
        for i in range(n_r):
            for block, sign in ((0, 1.0), (1, -1.0)):
                pattern.add(n_r * block + i, i_r + i, 1.0)
                pattern.add(n_r * block + i, us + i, sign)
            pattern.add(2 * n_r + i, i_r + i, 1.0)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """The slacks' cost, r_k ≥ 0 and no upper bounds: fixed; the first two rows' lower bounds are the steps'."""
        M, i_r = self._samples, qp.layout.start("reversal slacks")
        qp.q[i_r : i_r + 2 * M] = self._weight
        lower, upper = qp.lower[rows], qp.upper[rows]
        lower[4 * M :] = 0.0
        upper[:] = INF
        self._lower = lower[: 4 * M].reshape(2, 2 * M)

    def retarget(self, reference: QpReference) -> None:
        """The lower bounds at every grid point: −s_ff where the wheel heads forward, s_ff backward."""
        g = reference.grid
        ff, direction = g.feedforward_m_s, g.direction
        self._reversal_lower = np.stack(
            [np.where(direction > 0, -ff, -INF).ravel(), np.where(direction < 0, ff, -INF).ravel()]
        )

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """M."""
        return {"samples": self._samples}

    def c_tables(self) -> dict[str, FloatArray]:
        """The two rows' lower bounds by grid point and wheel."""
        return {"forward": self._reversal_lower[0], "backward": self._reversal_lower[1]}

    def write(self, step: QpStep) -> None:
        """The window's lower bounds."""
        k, M = step.k, self._samples
        self._lower[:] = self._reversal_lower[:, 2 * k : 2 * (k + M)]


class InputCost(StepBlock):
    """The setpoints' weights w_u Σ ‖δs_k‖² + w_Δ Σ_{k=0..N−1} ‖s_k − s_{k−1}‖² with s_{−1} the previous command: P's
    fixed entries, and the rate's linear term written each step, 2 w_Δ Dᵀ r with r_0 = −(s_{−1} − s_ff,0) and
    r_j = d_{k+j} (D the differences δs_j − δs_{j−1}), i.e. 2 w_Δ (r_j − r_{j+1}) and 2 w_Δ r_{N−1} for the last.

    Parameters
    ----------
    config : MpcConfig
        The weights.
    """

    name = "input cost"
    c_step = "input_cost"
    c_tables_names = ("d", "inner", "last")

    def __init__(self, config: MpcConfig) -> None:
        self._config = config
        self._w_rate = 2.0 * config.weight_input_rate

    def cost(self, layout: VariableLayout, pattern: Pattern) -> None:
        """2 w_u I + 2 w_Δ DᵀD."""
        c, us, n = self._config, layout.start("setpoints"), 2 * self._config.horizon
        diff = sp.eye(n, format="csc") - sp.eye(n, k=-2, format="csc")  # rows: δs_k − δs_{k−1}
        p_input = 2.0 * c.weight_input * sp.eye(n) + 2.0 * c.weight_input_rate * (diff.T @ diff)
        upper = sp.triu(p_input, format="coo")
        for r, col, value in zip(upper.row.tolist(), upper.col.tolist(), upper.data.tolist(), strict=True):
            pattern.add(us + r, us + col, value)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """The setpoints' part of q, by sample."""
        us = qp.layout.start("setpoints")
        self._q = qp.q[us : us + 2 * self._config.horizon].reshape(-1, 2)

    def retarget(self, reference: QpReference) -> None:
        """The linear term where it depends on the reference only: 2 w_Δ (d_j − d_j+1) for the inner samples,
        2 w_Δ d_j for the last."""
        d, w_rate = reference.feedforward_step_m_s, self._w_rate
        self._d = d
        self._d_pairs: list[list[float]] = d.tolist()  # per-step reads as plain floats
        self._inner = np.zeros_like(d)
        self._inner[:-1] = (d[:-1] - d[1:]) * w_rate
        self._last = (d - 0.0) * w_rate

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """The setpoints' first variable and 2 w_Δ."""
        return {"first_setpoint": qp.layout.start("setpoints"), "w_rate": self._w_rate}

    def c_tables(self) -> dict[str, FloatArray]:
        """d, the inner and the last samples' linear terms, by grid point and wheel."""
        return {"d": self._d.ravel(), "inner": self._inner.ravel(), "last": self._last.ravel()}

    def write(self, step: QpStep) -> None:
        """The window's linear term, its first sample's from the previous command."""
        qu, w_rate, N, k = self._q, self._w_rate, self._config.horizon, step.k
        start_l, start_r = step.start_m_s
        if N > 1:
            d_l, d_r = self._d_pairs[k + 1]
            qu[0, 0], qu[0, 1] = (-start_l - d_l) * w_rate, (-start_r - d_r) * w_rate
            qu[1 : N - 1] = self._inner[k + 1 : k + N - 1]
            qu[N - 1] = self._last[k + N - 1]
        else:
            qu[0, 0], qu[0, 1] = (-start_l - 0.0) * w_rate, (-start_r - 0.0) * w_rate


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


def reversal_samples(config: MpcConfig) -> int:
    """M, the samples whose setpoints pay the reversal weight.

    Parameters
    ----------
    config : MpcConfig
        The horizon and the reversal weight.

    Returns
    -------
    int
        :data:`REVERSAL_SAMPLES` within the horizon with a reversal weight, else 0.
    """
    return min(config.horizon, REVERSAL_SAMPLES) if config.weight_reversal > 0 else 0
