"""A metric as a signal and a reduction: the per-sample series of a run's log and the rule that makes it one number.

A limit on a metric reads the same samples for its value (the reduction) and for the times it reports (when the
signal was worst, when the run was first past the bound), so the two cannot disagree. This is the base of a limit as
a requirement over a signal in time.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.log import SimLog

__all__ = ["Metric", "Reduction", "Signal"]


class Reduction(enum.Enum):
    """How a metric's per-sample signal becomes its scalar, and when a run is first past a bound on that scalar."""

    MAX = "max"
    """The worst sample."""
    RMS = "rms"
    """The root mean square over the samples."""
    FINAL = "final"
    """The last sample."""
    MEAN = "mean"
    """The mean over the samples: the share of the run for a signal of flags or of fractions of an interval."""
    COUNT = "count"
    """The number of flagged (non-zero) samples."""
    P50 = "p50"
    """The median."""
    P99 = "p99"
    """The 99th percentile."""

    def reduce(self, values: NDArray[np.float64]) -> float:
        """The scalar of a signal's samples; NaN if a sample is NaN (a run that diverged), never a silently smaller
        number. A signal without samples gives 0.

        Parameters
        ----------
        values : ndarray
            The signal's samples.

        Returns
        -------
        float
            The scalar.
        """
        if len(values) == 0:
            return 0.0
        if self is Reduction.MAX:
            return float(np.max(values))
        if self is Reduction.RMS:
            return float(np.sqrt(np.mean(np.square(values))))
        if self is Reduction.FINAL:
            return float(values[-1])
        if self is Reduction.MEAN:
            return float(np.mean(values))
        if self is Reduction.COUNT:
            return float(np.count_nonzero(values)) if not np.any(np.isnan(values)) else math.nan
        return float(np.percentile(values, 50 if self is Reduction.P50 else 99))

    def first_past(self, values: NDArray[np.float64], bound: float) -> int | None:
        """The first sample at which the scalar is past ``bound`` whatever the samples after it are; for a
        percentile, the first sample above the bound (a percentile past a bound has one).

        A running maximum, count, sum or sum of squares over the whole run's length only grows, so a scalar past
        its bound has such a sample: a breach always has a first time.

        Parameters
        ----------
        values : ndarray
            The signal's samples.
        bound : float
            The bound on the scalar, in the signal's unit.

        Returns
        -------
        int or None
            The sample's index, None if the scalar is within the bound.
        """
        if len(values) == 0 or not self.reduce(values) > bound:
            return None
        n = len(values)
        if self is Reduction.FINAL:
            return n - 1
        if self is Reduction.RMS:
            running = np.cumsum(np.square(values)) / n > bound * bound
        elif self is Reduction.MEAN:
            running = np.cumsum(values) / n > bound
        elif self is Reduction.COUNT:
            running = np.cumsum(values != 0) > bound
        else:
            running = values > bound
        past = np.nonzero(running | np.isnan(values))[0]
        return int(past[0]) if past.size else n - 1

    def worst(self, values: NDArray[np.float64]) -> int | None:
        """The sample at which the signal is worst: the last for :attr:`FINAL`, the first flagged for a count or a
        share (None if none is), else the largest.

        Parameters
        ----------
        values : ndarray
            The signal's samples.

        Returns
        -------
        int or None
            The sample's index.
        """
        if len(values) == 0:
            return None
        if self is Reduction.FINAL:
            return len(values) - 1
        if self in (Reduction.COUNT, Reduction.MEAN) and not np.any(values != 0):
            return None
        return int(np.argmax(values))


Signal = Callable[[SimLog, float], NDArray[np.float64]]
"""A per-sample signal of a run: from its log and T_s (s), one value per row of the log."""


@document_fields
@dataclass(frozen=True)
class Metric:
    """A figure of merit of a run: a per-sample signal and the reduction that makes it one number.

    The scalar and the series a limit reports its times from are the same samples, so they cannot disagree.
    """

    name: str
    """The metric's name, its unit in it (the key of ``summary.json``'s ``metrics`` and of the limit it feeds)."""
    unit: str
    """The unit as printed after a value (``" m"``, ``"°"``; empty for shares and counts)."""
    signal: Signal
    """The per-sample signal, one value per row of the log, in the metric's unit."""
    reduction: Reduction
    """How the samples become the scalar."""
    over: Literal["samples", "intervals"] = "samples"
    """``samples``: every row of the log (the n + 1 controller steps and states); ``intervals``: the n hold
    intervals [t_k, t_k+1), the final row (the state at the end, held over no interval) left out."""
    signal_name: str = ""
    """The name of the run's signal it reduces (a log column or a derived signal,
    :data:`~agvctl.evaluation.metrics.SIGNALS`), as a requirement's formula names it."""
    absolute: bool = False
    """Whether it reduces that signal's magnitude (``abs(signal_name)`` in a formula)."""

    def series(self, log: SimLog, sample_period_s: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The samples the scalar is made of.

        Parameters
        ----------
        log : SimLog
            The run's log.
        sample_period_s : float
            T_s, s.

        Returns
        -------
        tuple of ndarray
            The samples' times (s) and values (in the metric's unit).
        """
        t = np.asarray(log["t_s"], dtype=np.float64)
        values = np.asarray(self.signal(log, sample_period_s), dtype=np.float64)
        if self.over == "intervals" and len(t) > 1:
            return t[:-1], values[:-1]
        return t, values

    def value(self, log: SimLog, sample_period_s: float) -> float:
        """The scalar: the reduction of :meth:`series`.

        Parameters
        ----------
        log : SimLog
            The run's log.
        sample_period_s : float
            T_s, s.

        Returns
        -------
        float
            The metric, in its unit.
        """
        return self.reduction.reduce(self.series(log, sample_period_s)[1])
