"""Signal temporal logic over a run's sampled signals, with quantitative robustness (its margin).

A formula is text (:func:`parse_formula`) over named signals and named parts of a run::

    always abs(cross_track_error_m) <= 0.05
    eventually[0, 3] always position_error_m <= 0.005
    always (turning_in_place -> position_error_m <= 0.02)
    always (not current_limited_left -> abs(wheel_speed_error_left_m_s) <= 0.02)
    speed_m_s >= 0.1 until[0, 5] on_segment(2)

The grammar, loosest binding first:

* ``a -> b`` (implication, to the right), ``a until[lo, hi] b``, ``a or b``, ``a and b``, ``not a``;
* ``always[lo, hi] a`` and ``eventually[lo, hi] a`` apply to everything after them (as a quantifier does):
  ``always a -> b`` is ``always (a -> b)``; parentheses end them sooner. A window is in seconds from the time the
  operator is evaluated at, ``hi`` may be ``inf``; without one it is ``[0, inf]``;
* a comparison ``signal <= c``, ``signal >= c``, ``abs(signal) <= c`` (``<`` and ``>`` mean the same on samples),
  ``c`` a number in the signal's unit;
* a bare name is a condition: a part of the run (``turning_in_place``, ``on_segment(-1)``, ...) or a signal of flags
  (true where it is not 0).

The robustness of a formula at a sample (Donzé and Maler's space robustness) is its signed margin: ``c − x`` for
``x <= c``, ``x − c`` for ``x >= c``, the minimum over ``and`` and ``always``, the maximum over ``or`` and
``eventually``, the negation over ``not``; a condition is +∞ where it holds and −∞ where it does not, so ``a -> b``
is judged only where ``a`` holds. A margin ≥ 0 keeps the formula. Each value carries its witness: the sample and the
comparison that decided it, so a verdict says when its worst point was and in which unit and against which constant
its margin is. Windows are on the samples of the run (a finite trace): a window that runs past the last sample is cut
there, one that is empty gives ``always`` +∞ and ``eventually`` −∞. A NaN sample (a run that diverged) breaks every
comparison on it.

``always`` and ``eventually`` cost O(n log w) for n samples and windows of w samples (a sparse table of minima);
``until`` costs O(n w).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields

__all__ = [
    "Atom",
    "Comparison",
    "Formula",
    "FormulaError",
    "Robustness",
    "Temporal",
    "Trace",
    "parse_formula",
    "robustness",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


class FormulaError(ValueError):
    """A formula that does not parse, or names a signal or part the run does not have (the message says where)."""


# ---------------------------------------------------------------------------------------------------------------
# The formula's tree


@document_fields
@dataclass(frozen=True)
class Comparison:
    """``signal <= constant``, ``signal >= constant`` or the same of ``abs(signal)``."""

    signal: str
    """The signal's name."""
    op: str
    """``"<="`` or ``">="``."""
    constant: float
    """The constant, in the signal's unit."""
    absolute: bool = False
    """Whether the signal's magnitude is compared."""

    def __str__(self) -> str:
        name = f"abs({self.signal})" if self.absolute else self.signal
        return f"{name} {self.op} {self.constant:g}"


@document_fields
@dataclass(frozen=True)
class Atom:
    """A condition: a named part of the run (with an integer argument for ``on_segment(i)``) or a signal of flags."""

    name: str
    """The part's or the signal's name."""
    argument: int | None = None
    """The argument of a part that takes one."""

    def __str__(self) -> str:
        return self.name if self.argument is None else f"{self.name}({self.argument})"


@document_fields
@dataclass(frozen=True)
class Not:
    """``not a``."""

    child: Formula
    """a."""


@document_fields
@dataclass(frozen=True)
class Junction:
    """``a and b ...`` (``op = "and"``) or ``a or b ...``."""

    op: str
    """``"and"`` or ``"or"``."""
    children: tuple[Formula, ...]
    """a, b, ..."""


@document_fields
@dataclass(frozen=True)
class Temporal:
    """``always[lo, hi] a`` or ``eventually[lo, hi] a``."""

    op: str
    """``"always"`` or ``"eventually"``."""
    window_s: tuple[float, float]
    """[lo, hi] relative to the time it is evaluated at, s (hi may be inf)."""
    child: Formula
    """a."""


@document_fields
@dataclass(frozen=True)
class Until:
    """``a until[lo, hi] b``: b holds at some time in the window and a holds from now until then."""

    left: Formula
    """a."""
    window_s: tuple[float, float]
    """[lo, hi] relative to the time it is evaluated at, s (hi may be inf)."""
    right: Formula
    """b."""


Formula = Comparison | Atom | Not | Junction | Temporal | Until
"""A parsed formula (:func:`parse_formula`)."""


def comparisons(formula: Formula) -> list[Comparison]:
    """The formula's comparisons, left to right (a comparison's index is its witness's ``leaf``)."""
    if isinstance(formula, Comparison):
        return [formula]
    if isinstance(formula, Atom):
        return []
    if isinstance(formula, (Not, Temporal)):
        return comparisons(formula.child)
    if isinstance(formula, Junction):
        return [c for child in formula.children for c in comparisons(child)]
    return comparisons(formula.left) + comparisons(formula.right)


def atoms(formula: Formula) -> list[Atom]:
    """The formula's conditions, left to right."""
    if isinstance(formula, Atom):
        return [formula]
    if isinstance(formula, Comparison):
        return []
    if isinstance(formula, (Not, Temporal)):
        return atoms(formula.child)
    if isinstance(formula, Junction):
        return [a for child in formula.children for a in atoms(child)]
    return atoms(formula.left) + atoms(formula.right)


def horizon_s(formula: Formula) -> tuple[float, float]:
    """The span of time, relative to where the formula is evaluated, its value depends on, s."""
    if isinstance(formula, (Comparison, Atom)):
        return 0.0, 0.0
    if isinstance(formula, Not):
        return horizon_s(formula.child)
    if isinstance(formula, Junction):
        spans = [horizon_s(c) for c in formula.children]
        return min(s[0] for s in spans), max(s[1] for s in spans)
    if isinstance(formula, Temporal):
        lo, hi = horizon_s(formula.child)
        return formula.window_s[0] + lo, formula.window_s[1] + hi
    lo_l, hi_l = horizon_s(formula.left)
    lo_r, hi_r = horizon_s(formula.right)
    return min(lo_l, formula.window_s[0] + lo_r), formula.window_s[1] + max(hi_l, hi_r)


# ---------------------------------------------------------------------------------------------------------------
# Parsing

_TOKEN = re.compile(
    r"\s*(?:(?P<number>[-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?|inf\b))"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op><=|>=|->|[<>()\[\],]))"
)
_KEYWORDS = {"always", "eventually", "until", "and", "or", "not", "abs", "inf"}


def _tokens(text: str) -> list[tuple[str, str, int]]:
    out = []
    pos = 0
    while pos < len(text):
        if text[pos:].strip() == "":
            break
        m = _TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            raise FormulaError(f"unexpected {text[pos:].strip()[:12]!r} at character {pos + 1}")
        kind = m.lastgroup or ""
        out.append((kind, m.group(kind), m.start(kind) + 1))
        pos = m.end()
    return out


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = _tokens(text)
        self.i = 0

    def peek(self) -> str | None:
        return self.tokens[self.i][1] if self.i < len(self.tokens) else None

    def where(self) -> str:
        return f"at character {self.tokens[self.i][2]}" if self.i < len(self.tokens) else "at the end"

    def take(self, expected: str | None = None, what: str = "more") -> tuple[str, str]:
        """The next token, which must be ``expected`` if given (``what`` names it at the end of the text)."""
        if self.i >= len(self.tokens):
            raise FormulaError(f"expected {repr(expected) if expected else what} at the end")
        kind, value, _ = self.tokens[self.i]
        if expected is not None and value != expected:
            raise FormulaError(f"expected {expected!r} {self.where()} (got {value!r})")
        self.i += 1
        return kind, value

    def formula(self) -> Formula:
        left = self.until()
        if self.peek() == "->":
            self.take()
            return Junction("or", (Not(left), self.formula()))
        return left

    def until(self) -> Formula:
        left = self.disjunction()
        if self.peek() == "until":
            self.take()
            window = self.window()
            return Until(left, window, self.disjunction())
        return left

    def disjunction(self) -> Formula:
        parts = [self.conjunction()]
        while self.peek() == "or":
            self.take()
            parts.append(self.conjunction())
        return parts[0] if len(parts) == 1 else Junction("or", tuple(parts))

    def conjunction(self) -> Formula:
        parts = [self.unary()]
        while self.peek() == "and":
            self.take()
            parts.append(self.unary())
        return parts[0] if len(parts) == 1 else Junction("and", tuple(parts))

    def unary(self) -> Formula:
        token = self.peek()
        if token == "not":
            self.take()
            return Not(self.unary())
        if token in ("always", "eventually"):
            self.take()
            return Temporal(token, self.window(), self.formula())
        return self.primary()

    def number(self) -> float:
        where = self.where()
        kind, value = self.take(what="a number")
        if kind != "number":
            raise FormulaError(f"expected a number {where} (got {value!r})")
        return float(value)

    def window(self) -> tuple[float, float]:
        if self.peek() != "[":
            return 0.0, math.inf
        self.take("[")
        lo = self.number()
        self.take(",")
        hi = self.number()
        self.take("]")
        if not (math.isfinite(lo) and lo >= 0 and hi >= lo):
            raise FormulaError(f"a window [lo, hi] needs 0 <= lo <= hi, lo finite (got [{lo:g}, {hi:g}])")
        return lo, hi

    def name(self) -> str:
        where = self.where()
        kind, value = self.take(what="a name")
        if kind != "name" or value in _KEYWORDS:
            raise FormulaError(f"expected a signal's or a part's name {where} (got {value!r})")
        return value

    def primary(self) -> Formula:
        token = self.peek()
        if token == "(":
            self.take()
            inner = self.formula()
            self.take(")")
            return inner
        absolute = token == "abs"
        if absolute:
            self.take()
            self.take("(")
        name = self.name()
        if absolute:
            self.take(")")
        op = self.peek()
        if op in ("<=", "<", ">=", ">"):
            self.take()
            return Comparison(name, "<=" if op in ("<=", "<") else ">=", self.number(), absolute)
        if absolute:
            raise FormulaError(f"expected <= or >= after abs({name}) {self.where()}")
        if op == "(":
            self.take()
            kind, value = self.take(what="an integer")
            if kind != "number" or not re.fullmatch(r"[-+]?\d+", value):
                raise FormulaError(f"expected an integer in {name}(...) (got {value!r})")
            self.take(")")
            return Atom(name, int(value))
        return Atom(name)


def parse_formula(text: str) -> Formula:
    """Parse a formula (the grammar is in the module notes).

    Parameters
    ----------
    text : str
        The formula.

    Returns
    -------
    Formula
        Its tree.

    Raises
    ------
    FormulaError
        Text that does not parse; the message names the character where.

    Examples
    --------
    >>> print(parse_formula("always[0, 2] abs(x_m) <= 0.5").child)
    abs(x_m) <= 0.5
    """
    if not isinstance(text, str) or not text.strip():
        raise FormulaError("expected a formula (got an empty text)")
    parser = _Parser(text)
    formula = parser.formula()
    if parser.i < len(parser.tokens):
        raise FormulaError(f"unexpected {parser.tokens[parser.i][1]!r} {parser.where()}")
    return formula


# ---------------------------------------------------------------------------------------------------------------
# Robustness


@document_fields
@dataclass(frozen=True)
class Trace:
    """What a formula is evaluated on: the sample times, a signal by name and a condition by :class:`Atom`."""

    t_s: FloatArray
    """The samples' times, s (evenly spaced)."""
    signal: Callable[[str], FloatArray]
    """The samples of a named signal, in its unit (raises :class:`FormulaError` for an unknown one)."""
    condition: Callable[[Atom], NDArray[np.bool_]]
    """Where a condition holds, per sample (raises :class:`FormulaError` for an unknown or unavailable one)."""


@document_fields
@dataclass(frozen=True)
class Robustness:
    """A formula's robustness at every sample, with the witness of each value."""

    value: FloatArray
    """The signed margin per sample (≥ 0: kept)."""
    sample: IntArray
    """The sample whose comparison decided it."""
    leaf: IntArray
    """That comparison's index in :func:`comparisons` (−1: a condition decided it)."""


def _pick(better: NDArray[np.bool_], a: Robustness, b: Robustness) -> Robustness:
    """``b`` where ``better``, else ``a``."""
    return Robustness(
        np.where(better, b.value, a.value), np.where(better, b.sample, a.sample), np.where(better, b.leaf, a.leaf)
    )


def _negate(r: Robustness) -> Robustness:
    return Robustness(-r.value, r.sample, r.leaf)


def _window_min(r: Robustness, k_lo: int, k_hi: int | None) -> Robustness:
    """At each sample k, the minimum of ``r`` over samples [k + k_lo, k + k_hi] cut at the last (None: no end);
    +∞ for an empty window."""
    n = len(r.value)
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
        The formula (:func:`parse_formula`).
    trace : Trace
        The samples.

    Returns
    -------
    Robustness
        The margin at each sample (≥ 0: the formula holds from there), the sample and the comparison
        (its index in :func:`comparisons`) that decided it.

    Raises
    ------
    FormulaError
        A signal or a part the trace does not have.

    Examples
    --------
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
    """The first sample at or after ``time_s`` (the last sample if none is)."""
    t = np.asarray(t_s, dtype=np.float64)
    k = int(np.searchsorted(t, time_s - 1e-9, side="left"))
    return min(k, len(t) - 1)
