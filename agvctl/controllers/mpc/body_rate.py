"""The LTV MPC's block of the body's rate bounds (:mod:`~agvctl.controllers.mpc.body_bounds`): the setpoints' mean
and difference change by at most the path's body limits' share per sample, as the command shaper keeps them."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.body_bounds import NEAR_REST_SPEED_M_S, BodyBounds
from agvctl.controllers.mpc.fallback import clamp
from agvctl.controllers.mpc.ltv_qp import INF, QpReference, QpStep, SpeedBox, StepBlock, StepQp
from agvctl.controllers.mpc.qp_blocks import Pattern, VariableLayout

__all__ = ["BodyRate"]

FloatArray = NDArray[np.float64]


def _bounded(step_m_s: float) -> float:
    return INF if math.isinf(step_m_s) else step_m_s


class BodyRate(StepBlock):
    """The change of the setpoints' mean (s_l + s_r)/2 and of their difference s_r − s_l from sample to sample (2N
    rows: the N means, then the N differences).

    The first sample's change is from the previous command brought into the first sample's box (as tightened by the
    blocks before, so that holding it is feasible), within
    :meth:`~agvctl.controllers.mpc.body_bounds.BodyBounds.first_steps`; a later sample's is the setpoints' change
    less the feed-forward's own, widened to admit holding the deviation from the feed-forward (where the plan changes
    faster than the bound, the bound gives way to the plan).

    Parameters
    ----------
    horizon : int
        N.
    bounds : BodyBounds
        The bounds (reset to each path's limits before the QP is retargeted).
    box : SpeedBox
        The speed box, whose first sample bounds where the first change starts from.
    """

    name = "body rate"
    c_step = "body_rate"
    c_tables_names = ("mean_lower", "mean_upper", "difference_lower", "difference_upper", "steps")

    def __init__(self, horizon: int, bounds: BodyBounds, box: SpeedBox) -> None:
        self._horizon, self._bounds, self._box = horizon, bounds, box
        self.n_rows = 2 * horizon

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        """(δs_k,l + δs_k,r)/2 and δs_k,r − δs_k,l, less those of sample k − 1 for k ≥ 1."""
        us, N = layout.start("setpoints"), self._horizon
        for k in range(N):
            for back, sign in ((0, 1.0), (1, -1.0)):
                if k - back < 0:
                    continue
                j = us + 2 * (k - back)
                pattern.add(k, j, 0.5 * sign)
                pattern.add(k, j + 1, 0.5 * sign)
                pattern.add(N + k, j, -sign)
                pattern.add(N + k, j + 1, sign)

    def bind(self, qp: StepQp, rows: slice) -> None:
        """Its bounds, by kind (mean, difference) and sample."""
        N = self._horizon
        self._lower, self._upper = qp.lower[rows].reshape(2, N), qp.upper[rows].reshape(2, N)

    def retarget(self, reference: QpReference) -> None:
        """The later samples' bounds at every grid point: ± the step less the feed-forward's own change of the mean
        and the difference, widened to admit 0."""
        d = reference.feedforward_step_m_s
        steps = np.array([[_bounded(self._bounds.mean_step_m_s)], [_bounded(self._bounds.difference_step_m_s)]])
        change = np.stack([0.5 * (d[:, 0] + d[:, 1]), d[:, 1] - d[:, 0]])
        self._later_lower = np.minimum(-steps - change, 0.0)
        self._later_upper = np.maximum(steps - change, 0.0)

    def c_values(self, qp: StepQp) -> dict[str, object]:
        """The speed box's first row, and the speed below which a wheel is near rest."""
        return {"box_row": qp.rows[self._box.name].start, "near_rest": NEAR_REST_SPEED_M_S}

    def c_tables(self) -> dict[str, FloatArray]:
        """The later samples' bounds of the mean and the difference by grid point, and the path's steps (mean,
        difference, the share near rest)."""
        b = self._bounds
        return {
            "mean_lower": self._later_lower[0],
            "mean_upper": self._later_upper[0],
            "difference_lower": self._later_lower[1],
            "difference_upper": self._later_upper[1],
            "steps": np.array([b.mean_step_m_s, b.difference_step_m_s, b.breakaway_share]),
        }

    def write(self, step: QpStep) -> None:
        """The first change from the previous command within the first sample's box; the window's later ones."""
        k, N, lo, hi = step.k, self._horizon, self._lower, self._upper
        (box_lo_l, box_lo_r), (box_hi_l, box_hi_r) = self._box.first.tolist()
        start_l = clamp(step.start_m_s[0], box_lo_l, box_hi_l)
        start_r = clamp(step.start_m_s[1], box_lo_r, box_hi_r)
        v_l, v_r = step.wheel_speed_m_s.tolist()
        step_mean, step_difference = self._bounds.first_steps(v_l, v_r)
        mean, difference = 0.5 * (start_l + start_r), start_r - start_l
        lo[0, 0], hi[0, 0] = mean - _bounded(step_mean), mean + _bounded(step_mean)
        lo[1, 0], hi[1, 0] = difference - _bounded(step_difference), difference + _bounded(step_difference)
        lo[:, 1:] = self._later_lower[:, k + 1 : k + N]
        hi[:, 1:] = self._later_upper[:, k + 1 : k + N]
