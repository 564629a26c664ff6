"""What every MPC command passes on its way out: the hard limits on one setpoint, and the fallback sequence for a
step whose solve failed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["SetpointFallback", "limit_command"]

FloatArray = NDArray[np.float64]


class SetpointFallback:
    """Remembers the last solved setpoint sequence, for the fallbacks when a solve fails: the shifted previous
    solution while it still covers the current sample, then the reference's feed-forward.

    Parameters
    ----------
    horizon : int
        N, the length of a solved sequence in samples.
    """

    def __init__(self, horizon: int) -> None:
        self.sequence_m_s = np.zeros((horizon, 2))
        self.start = -1
        """Grid index of the sequence's first sample; −1 when there is none."""

    def clear(self) -> None:
        """Forget the stored sequence (a new reference)."""
        self.start = -1

    def store(self, start: int, sequence_m_s: FloatArray) -> None:
        """Remember ``sequence_m_s`` (N×2, left/right, m/s), the setpoints solved for the window that starts at grid
        index ``start``.
        """
        self.sequence_m_s[:] = sequence_m_s
        self.start = start

    def shifted(self, start: int) -> tuple[float, float] | None:
        """The stored setpoint for grid index ``start``, if the stored sequence covers it."""
        j = start - self.start
        if self.start < 0 or j < 0 or j >= len(self.sequence_m_s):
            return None
        return float(self.sequence_m_s[j, 0]), float(self.sequence_m_s[j, 1])


def limit_command(setpoint_m_s: float, previous_m_s: float, max_speed_m_s: float, max_step_m_s: float) -> float:
    """A setpoint brought exactly within the hard limits on the speed and on its change per sample.

    The limits are ``|s|`` ≤ v_max and ``|s − s_prev|`` ≤ a_lim·T_s, with the previous command s_prev first clipped to
    ±v_max, so that the two always intersect. The solvers meet the limits only to their tolerance, and the fallbacks
    not at all; every command that leaves a controller goes through this.

    Parameters
    ----------
    setpoint_m_s : float
        s, the setpoint of one wheel, m/s.
    previous_m_s : float
        s_prev, the wheel's previous command, m/s.
    max_speed_m_s : float
        v_max, the largest speed either way, m/s.
    max_step_m_s : float
        a_lim·T_s, the largest change from the previous command, m/s.

    Returns
    -------
    float
        The setpoint nearest ``setpoint_m_s`` within both limits, m/s.
    """
    prev = min(max(float(previous_m_s), -max_speed_m_s), max_speed_m_s)
    lo = max(prev - max_step_m_s, -max_speed_m_s)
    hi = min(prev + max_step_m_s, max_speed_m_s)
    return float(min(max(setpoint_m_s, lo), hi))
