"""Signal temporal logic over a run's sampled signals, with quantitative robustness (its margin).

The robustness of a formula (:mod:`agvctl.evaluation.formula`) at a sample (Donzé and Maler's space robustness) is
its signed margin: ``c − x`` for ``x <= c``, ``x − c`` for ``x >= c``, the minimum over ``and`` and ``always``, the
maximum over ``or`` and ``eventually``, the negation over ``not``; a condition is +∞ where it holds and −∞ where it
does not, so ``a -> b`` is judged only where ``a`` holds. A margin ≥ 0 keeps the formula. Each value carries its
witness: the sample and the comparison that decided it, so a verdict says when its worst point was and in which unit
and against which constant its margin is. Windows are on the samples of the run (a finite trace): a window that runs
past the last sample is cut there, one that is empty gives ``always`` +∞ and ``eventually`` −∞. A NaN sample (a run
that diverged) breaks every comparison on it.

``always`` and ``eventually`` cost O(n log w) for n samples and windows of w samples (a sparse table of minima);
``until`` costs O(n w).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.evaluation.formula import (
    Atom,
    Comparison,
    Formula,
    Junction,
    Not,
    Temporal,
    comparisons,
)

__all__ = [
    "Robustness",
    "Trace",
    "first_at_or_after",
    "robustness",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


# ---------------------------------------------------------------------------------------------------------------
# Robustness


@document_fields
@dataclass(frozen=True)
class Trace:
    """What a formula is evaluated on: the sample times, a signal by name and a condition by :class:`Atom`."""

    t_s: FloatArray
    """The samples' times, s (evenly spaced)."""
    signal: Callable[[str], FloatArray]
    """The samples of a named signal, in its unit (raises :class:`~agvctl.evaluation.formula.FormulaError` for an
    unknown one)."""
    condition: Callable[[Atom], NDArray[np.bool_]]
    """Where a condition holds, per sample (raises :class:`~agvctl.evaluation.formula.FormulaError` for an unknown
    or unavailable one)."""


@document_fields
@dataclass(frozen=True)
class Robustness:
    """A formula's robustness at every sample, with the witness of each value."""

    value: FloatArray
    """The signed margin per sample (≥ 0: kept)."""
    sample: IntArray
    """The sample whose comparison decided it."""
    leaf: IntArray
    """That comparison's index in :func:`~agvctl.evaluation.formula.comparisons` (−1: a condition decided it)."""


def _pick(better: NDArray[np.bool_], a: Robustness, b: Robustness) -> Robustness:
    """``b`` where ``better``, else ``a``."""
    return Robustness(
        np.where(better, b.value, a.value), np.where(better, b.sample, a.sample), np.where(better, b.leaf, a.leaf)
    )


def _negate(r: Robustness) -> Robustness:
    return Robustness(-r.value, r.sample, r.leaf)


def _suffix_min(r: Robustness, k_lo: int) -> Robustness:
    """:func:`_window_min` with no end, in one pass: at each sample k the minimum of ``r`` over samples
    [k + k_lo, last], the earliest of a tie as witness (as the doubling table picks it); +∞ past the last."""
    n = len(r.value)
    backwards = r.value[::-1]
    low = np.minimum.accumulate(backwards)
    # the latest position (backwards) at which the running minimum was reached: the earliest sample attaining it
    reached = np.maximum.accumulate(np.where(backwards == low, np.arange(n), 0))
    witness = (n - 1 - reached)[::-1]
    starts = np.arange(n) + k_lo
    empty = starts >= n
    at = np.minimum(starts, n - 1)
    j = witness[at]
    value = np.where(empty, np.inf, low[::-1][at])
    return Robustness(value, np.where(empty, np.arange(n), r.sample[j]), np.where(empty, -1, r.leaf[j]))


def _window_min(r: Robustness, k_lo: int, k_hi: int | None) -> Robustness:
    """At each sample k, the minimum of ``r`` over samples [k + k_lo, k + k_hi] cut at the last (None: no end);
    +∞ for an empty window. A doubling table of minima (its witness the earliest sample of a tie); a window with no
    end is a running minimum from the last sample (:func:`_suffix_min`)."""
    n = len(r.value)
    if k_hi is None and n and not np.isnan(r.value).any():
        return _suffix_min(r, k_lo)
    if k_hi is not None and k_hi < k_lo:
        return Robustness(np.full(n, np.inf), np.arange(n), np.full(n, -1))
    length = n if k_hi is None else min(k_hi - k_lo + 1, n)
    pad = k_lo + length + 1
    value = np.concatenate((r.value, np.full(pad, np.inf)))
    sample = np.concatenate((r.sample, np.full(pad, n - 1)))
    leaf = np.concatenate((r.leaf, np.full(pad, -1)))
    table = Robustness(value, sample, leaf)
    span = 1
    while span * 2 <= length:
        shifted = Robustness(
            np.concatenate((table.value[span:], np.full(span, np.inf))),
            np.concatenate((table.sample[span:], table.sample[-span:])),
            np.concatenate((table.leaf[span:], np.full(span, -1))),
        )
        table = _pick(shifted.value < table.value, table, shifted)
        span *= 2
    starts = np.arange(n) + k_lo
    first = Robustness(table.value[starts], table.sample[starts], table.leaf[starts])
    ends = starts + length - span
    second = Robustness(table.value[ends], table.sample[ends], table.leaf[ends])
    out = _pick(second.value < first.value, first, second)
    empty = starts >= n
    return Robustness(
        np.where(empty, np.inf, out.value), np.where(empty, np.arange(n), out.sample), np.where(empty, -1, out.leaf)
    )


def _samples(window_s: tuple[float, float], period_s: float) -> tuple[int, int | None]:
    lo = int(math.ceil(window_s[0] / period_s - 1e-9))
    hi = None if math.isinf(window_s[1]) else int(math.floor(window_s[1] / period_s + 1e-9))
    return lo, hi


def _until(left: Robustness, right: Robustness, k_lo: int, k_hi: int | None) -> Robustness:
    """max over j in [k + k_lo, k + k_hi] of min(right(j), min of left over [k, j])."""
    n = len(left.value)
    last = n - 1 if k_hi is None else min(k_hi, n - 1)  # an empty window (k_hi < k_lo) leaves every value −∞
    best = Robustness(np.full(n, -np.inf), np.arange(n), np.full(n, -1))
    running = left
    for offset in range(last + 1):
        if offset > 0:
            shifted = Robustness(
                np.concatenate((left.value[offset:], np.full(offset, np.inf))),
                np.concatenate((left.sample[offset:], np.full(offset, n - 1))),
                np.concatenate((left.leaf[offset:], np.full(offset, -1))),
            )
            running = _pick(shifted.value < running.value, running, shifted)
        if offset < k_lo:
            continue
        target = Robustness(
            np.concatenate((right.value[offset:], np.full(offset, -np.inf))),
            np.concatenate((right.sample[offset:], np.full(offset, n - 1))),
            np.concatenate((right.leaf[offset:], np.full(offset, -1))),
        )
        candidate = _pick(running.value < target.value, target, running)
        best = _pick(candidate.value > best.value, best, candidate)
    return best


def _evaluate(formula: Formula, trace: Trace, leaves: dict[int, int], period_s: float) -> Robustness:
    n = len(trace.t_s)
    index = np.arange(n)
    if isinstance(formula, Comparison):
        x = np.asarray(trace.signal(formula.signal), dtype=np.float64)
        if formula.absolute:
            x = np.abs(x)
        margin = formula.constant - x if formula.op == "<=" else x - formula.constant
        margin = np.where(np.isnan(margin), -np.inf, margin)
        return Robustness(margin, index, np.full(n, leaves[id(formula)]))
    if isinstance(formula, Atom):
        holds = np.asarray(trace.condition(formula), dtype=bool)
        return Robustness(np.where(holds, np.inf, -np.inf), index, np.full(n, -1))
    if isinstance(formula, Not):
        return _negate(_evaluate(formula.child, trace, leaves, period_s))
    if isinstance(formula, Junction):
        results = [_evaluate(c, trace, leaves, period_s) for c in formula.children]
        out = results[0]
        for r in results[1:]:
            out = _pick(r.value < out.value if formula.op == "and" else r.value > out.value, out, r)
        return out
    if isinstance(formula, Temporal):
        child = _evaluate(formula.child, trace, leaves, period_s)
        lo, hi = _samples(formula.window_s, period_s)
        if formula.op == "always":
            return _window_min(child, lo, hi)
        return _negate(_window_min(_negate(child), lo, hi))
    left = _evaluate(formula.left, trace, leaves, period_s)
    right = _evaluate(formula.right, trace, leaves, period_s)
    lo, hi = _samples(formula.window_s, period_s)
    return _until(left, right, lo, hi)


def robustness(formula: Formula, trace: Trace) -> Robustness:
    """The robustness of ``formula`` at every sample of ``trace``.

    Parameters
    ----------
    formula : Formula
        The formula (:func:`~agvctl.evaluation.formula.parse_formula`).
    trace : Trace
        The samples.

    Returns
    -------
    Robustness
        The margin at each sample (≥ 0: the formula holds from there), the sample and the comparison
        (its index in :func:`~agvctl.evaluation.formula.comparisons`) that decided it.

    Raises
    ------
    FormulaError
        A signal or a part the trace does not have.

    Examples
    --------
    >>> from agvctl.evaluation.formula import parse_formula
    >>> t = np.arange(5) * 0.5
    >>> x = np.array([0.0, 0.2, 0.4, 0.1, 0.0])
    >>> trace = Trace(t, lambda name: x, lambda atom: np.ones(5, dtype=bool))
    >>> r = robustness(parse_formula("always x_m <= 0.5"), trace)
    >>> round(float(r.value[0]), 3), float(t[r.sample[0]])
    (0.1, 1.0)
    """
    n = len(trace.t_s)
    if n == 0:
        return Robustness(np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    period_s = float(trace.t_s[1] - trace.t_s[0]) if n > 1 else 1.0
    leaves = {id(c): i for i, c in enumerate(comparisons(formula))}
    return _evaluate(formula, trace, leaves, period_s)


def first_at_or_after(t_s: Sequence[float] | FloatArray, time_s: float) -> int:
    """The first sample at or after ``time_s`` (the last sample if none is).

    Parameters
    ----------
    t_s : array_like
        The samples' times, s, increasing.
    time_s : float
        The time, s.

    Returns
    -------
    int
        The sample's index.
    """
    t = np.asarray(t_s, dtype=np.float64)
    k = int(np.searchsorted(t, time_s - 1e-9, side="left"))
    return min(k, len(t) - 1)
