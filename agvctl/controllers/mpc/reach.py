"""The LTV MPC's block of the setpoints' reachable leads over their wheels (with the wheel-loop prediction model,
whose wheel speeds are states; see :mod:`~agvctl.controllers.mpc.ltv_qp` for the whole QP)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.ltv_qp import INF, QpReference, QpStep, SpeedBox, StepBlock, StepQp
from agvctl.controllers.mpc.qp_blocks import Pattern, VariableLayout

__all__ = ["Reach"]

FloatArray = NDArray[np.float64]


class Reach(StepBlock):
    """The setpoints' reachable leads over their wheels: s_k − v_k ∈ [−D↓, D↑], k = 1 … N − 1 (2(N − 1) rows, the
    wheel speeds being states), and the first sample's from the measured speed within the speed box, tightening its
    rows. Later samples' leads are the reference's speeds', never tighter than the first's (so that holding the first
    setpoint stays feasible as the wheel converges).

    Parameters
    ----------
    horizon : int
        N.
    n_states : int
        nx.
    wheel_columns : tuple of int
        The states of the wheel-speed errors (left, right).
    box : SpeedBox
        The speed box, whose first sample this block tightens (it comes after it).
    """

    name = "reach"
    c_step = "reach"
    c_tables_names = ("base", "down", "up", "max_speed")

    def __init__(self, horizon: int, n_states: int, wheel_columns: tuple[int, int], box: SpeedBox) -> None:
        self._horizon, self._nx, self._wheels, self._box = horizon, n_states, wheel_columns, box
        self.n_rows = 2 * (horizon - 1)

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """δs_k − δv_k (δv_0 is data, in the first sample's bounds)."""
        xs, us, nx = layout.start("states"), layout.start("setpoints"), self._nx
        for k in range(1, self._horizon):
            for j in range(2):
                pattern.add(2 * (k - 1) + j, us + 2 * k + j, 1.0)
                pattern.add(2 * (k - 1) + j, xs + (k - 1) * nx + self._wheels[j], -1.0)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """Its bounds, by sample and wheel."""
        self._lower, self._upper = qp.lower[rows].reshape(-1, 2), qp.upper[rows].reshape(-1, 2)

    def retarget(self, reference: QpReference) -> None:
        """The leads at the reference's wheel speeds: δs_k − δv_k ∈ v_ref − s_ff + [−D↓, D↑]."""
        g = reference.grid
        up, down = reference.reach.accel_m_s2(g.wheel_m_s[:-1])
        self._base = g.wheel_m_s[:-1] - g.feedforward_m_s
        self._down = down * reference.lead_factor_s
        self._up = up * reference.lead_factor_s
        self._max_wheel_speed_m_s = reference.max_wheel_speed_m_s

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """The speed box's first row."""
        return {"box_row": qp.rows[self._box.name].start}

    def c_tables(self) -> dict[str, FloatArray]:
        """The leads' base, down and up values by grid point and wheel, and v_max."""
        return {
            "base": self._base.ravel(),
            "down": self._down.ravel(),
            "up": self._up.ravel(),
            "max_speed": np.array([self._max_wheel_speed_m_s]),
        }

    def write(self, step: QpStep) -> None:
        """The first sample's box within the window, the later samples' leads."""
        assert step.window is not None  # finite wheel speeds: x_0 holds them
        N, k, (ff_l, ff_r), window = self._horizon, step.k, step.feedforward_m_s, step.window
        first = self._box.first
        (box_lo_l, box_lo_r), (box_hi_l, box_hi_r) = first.tolist()
        (lower_l, lower_r), (upper_l, upper_r) = window.lower_m_s, window.upper_m_s
        first[0, 0], first[0, 1] = max(box_lo_l, lower_l - ff_l), max(box_lo_r, lower_r - ff_r)
        first[1, 0], first[1, 1] = min(box_hi_l, upper_l - ff_l), min(box_hi_r, upper_r - ff_r)
        lo, hi = self._lower, self._upper
        v_l, v_r = step.wheel_speed_m_s.tolist()
        if max(abs(v_l), abs(v_r)) <= self._max_wheel_speed_m_s:
            base = self._base[k + 1 : k + N]
            np.maximum(self._down[k + 1 : k + N], window.lead_down_m_s, out=lo)
            np.subtract(base, lo, out=lo)
            np.maximum(self._up[k + 1 : k + N], window.lead_up_m_s, out=hi)
            np.add(base, hi, out=hi)
        else:  # a wheel beyond the speed box (a reset at speed): only the first sample is bounded
            lo[:] = -INF
            hi[:] = INF
