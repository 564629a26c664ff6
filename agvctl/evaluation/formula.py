"""Formulas of signal temporal logic as text and as a tree: the grammar, the parser and what a formula names.

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

:mod:`agvctl.evaluation.stl` evaluates a formula's robustness on a run.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from agvctl.config import document_fields

__all__ = [
    "Atom",
    "Comparison",
    "Formula",
    "FormulaError",
    "Junction",
    "Not",
    "Temporal",
    "Until",
    "atoms",
    "comparisons",
    "horizon_s",
    "parse_formula",
]


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
    """The formula's comparisons, left to right (a comparison's index is its witness's ``leaf``).

    Parameters
    ----------
    formula : Formula
        The formula's tree.

    Returns
    -------
    list of Comparison
        Every comparison, in the order they appear in the text.
    """
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
    """The formula's conditions, left to right.

    Parameters
    ----------
    formula : Formula
        The formula's tree.

    Returns
    -------
    list of Atom
        Every condition (a part of the run or a signal of flags), in the order of the text.
    """
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
    """The span of time, relative to where the formula is evaluated, its value depends on.

    Parameters
    ----------
    formula : Formula
        The formula's tree.

    Returns
    -------
    tuple of float
        (earliest, latest) offset, s; the latest may be inf.
    """
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
