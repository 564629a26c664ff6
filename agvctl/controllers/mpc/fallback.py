"""What every MPC command passes on its way out: the hard limits on one setpoint, and the fallback sequence for a
step whose solve failed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["SetpointFallback", "limit_command"]

FloatArray = NDArray[np.float64]


class SetpointFallback:
    """Remembers the last solved setpoint sequence, for the fallbacks when a solve fails: the shifted previous
    solution while it still covers the current sample, then the reference's feed-forward."""

    def __init__(self, horizon: int) -> None:
        self.sequence_m_s = np.zeros((horizon, 2))
        self.start = -1
        """Grid index of the sequence's first sample; −1 when there is none."""

    def clear(self) -> None:
        self.start = -1

    def store(self, start: int, sequence_m_s: FloatArray) -> None:
        self.sequence_m_s[:] = sequence_m_s
        self.start = start

    def shifted(self, start: int) -> tuple[float, float] | None:
        """The stored setpoint for grid index ``start``, if the stored sequence covers it."""
        j = start - self.start
        if self.start < 0 or j < 0 or j >= len(self.sequence_m_s):
            return None
        return float(self.sequence_m_s[j, 0]), float(self.sequence_m_s[j, 1])


def limit_command(setpoint_m_s: float, previous_m_s: float, max_speed_m_s: float, max_step_m_s: float) -> float:
    """``setpoint_m_s`` brought exactly within the hard limits: |s| ≤ v_max and |s − s_prev| ≤ a_lim·T_s, with
    s_prev first clipped to ±v_max (so the two always intersect). The solvers meet the limits only to their
    tolerance, and the fallbacks not at all; every command that leaves a controller goes through this."""
    prev = min(max(float(previous_m_s), -max_speed_m_s), max_speed_m_s)
    lo = max(prev - max_step_m_s, -max_speed_m_s)
    hi = min(prev + max_step_m_s, max_speed_m_s)
    return float(min(max(setpoint_m_s, lo), hi))
