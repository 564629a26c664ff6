"""What every MPC command passes on its way out: the hard limits on one setpoint, and the fallback sequence for a
step whose solve failed."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["SetpointFallback", "clamp", "limit_command"]

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
        self._sequence = np.zeros((horizon, 2))
        self._solution: tuple[FloatArray, FloatArray, float] | None = None
        """A solution stored by :meth:`store_solution` and not yet made into the sequence: (feed-forward,
        correction, v_max)."""
        self.start = -1
        """Grid index of the sequence's first sample; −1 when there is none."""

    @property
    def sequence_m_s(self) -> FloatArray:
        """The stored setpoint sequence (N×2, left/right, m/s), made from a stored solution when first asked for
        (only a failed solve and the plots ask)."""
        if self._solution is not None:
            feedforward, correction, max_speed = self._solution
            sequence = self._sequence
            np.add(feedforward, correction, out=sequence)
            np.minimum(sequence, max_speed, out=sequence)
            np.maximum(sequence, -max_speed, out=sequence)
            self._solution = None
        return self._sequence

    def clear(self) -> None:
        """Forget the stored sequence (a new reference)."""
        self.start = -1

    def store(self, start: int, sequence_m_s: FloatArray) -> None:
        """Remember ``sequence_m_s`` (N×2, left/right, m/s), the setpoints solved for the window that starts at grid
        index ``start``.
        """
        self._sequence[:] = sequence_m_s
        self._solution = None
        self.start = start

    def store_solution(
        self, start: int, feedforward_m_s: FloatArray, correction_m_s: FloatArray, max_speed_m_s: float
    ) -> tuple[float, float]:
        """Remember the setpoints solved for the window that starts at grid index ``start``: the feed-forward plus
        the solved correction (N×2 each, left/right, m/s), brought within ±``max_speed_m_s``.

        The arrays are kept, not copied (the caller leaves them as they are: a solve returns a new solution); the
        sequence is made from them when asked for, and only the first setpoints now, with the same arithmetic.

        Returns
        -------
        tuple of float
            The first setpoints (left, right), m/s.
        """
        self._solution = (feedforward_m_s, correction_m_s, max_speed_m_s)
        self.start = start
        (ff_l, ff_r), (c_l, c_r) = feedforward_m_s[0].tolist(), correction_m_s[0].tolist()
        v = max_speed_m_s
        left, right = ff_l + c_l, ff_r + c_r
        left, right = (v if v < left else left), (v if v < right else right)  # np.minimum(·, v_max) as a comparison
        return (-v if -v > left else left), (-v if -v > right else right)  # then np.maximum(·, −v_max)

    def shifted(self, start: int) -> tuple[float, float] | None:
        """The stored setpoint for grid index ``start``, if the stored sequence covers it."""
        j = start - self.start
        if self.start < 0 or j < 0 or j >= len(self._sequence):
            return None
        sequence = self.sequence_m_s
        return float(sequence[j, 0]), float(sequence[j, 1])


def clamp(value: float, low: float, high: float) -> float:
    """``min(max(value, low), high)``, written as the comparisons those builtins make.

    The same result for any floats (NaN and signed zeros included) without the builtins' per-call cost: an MPC step
    clamps a dozen values.

    Parameters
    ----------
    value : float
        The value.
    low : float
        The lower limit, applied first.
    high : float
        The upper limit, applied last (it wins where ``low`` > ``high``).

    Returns
    -------
    float
        ``value`` within the limits.
    """
    value = low if low > value else value
    return high if high < value else value


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
    prev = clamp(float(previous_m_s), -max_speed_m_s, max_speed_m_s)
    lo = prev - max_step_m_s
    lo = -max_speed_m_s if -max_speed_m_s > lo else lo  # max(lo, −v_max), as clamp writes it
    hi = prev + max_step_m_s
    hi = max_speed_m_s if max_speed_m_s < hi else hi  # min(hi, v_max)
    return float(clamp(setpoint_m_s, lo, hi))
