"""A verdict on a run, of a limit or of a requirement: its value, bound and signed margin, the time of its worst
point and its window, and how it reads (:class:`LimitResult`; :mod:`agvctl.evaluation.limits` makes them).

A margin is in the unit of what it bounds, ≥ 0 kept. Margins are compared between verdicts over their scale
(:func:`margin_scale`): a run's smallest, :func:`smallest_normalised_margin`, is how close it came to failing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import Literal, Protocol

from agvctl.config import document_fields
from agvctl.evaluation.metrics import METRICS
from agvctl.evaluation.signals import Reduction

__all__ = [
    "COUNT_MARGIN_STEP",
    "LimitResult",
    "all_passed",
    "format_limit_message",
    "format_margin",
    "format_requirement_message",
    "margin_scale",
    "smallest_normalised_margin",
    "Verdict",
    "verdict_message",
]


def format_margin(margin: float, unit: str, worst_time_s: float | None, window_s: tuple[float, float] | None) -> str:
    """A verdict's margin, the time of its worst point and its window, as the messages end.

    Parameters
    ----------
    margin : float
        The signed margin (≥ 0: kept), in ``unit``.
    unit : str
        The unit as printed after a value (``" m"``).
    worst_time_s : float or None
        When it was decided, s.
    window_s : tuple of float or None
        The span of the run it looked at, s.

    Returns
    -------
    str
        ``"margin +0.0288 m at t = 12.40 s of [0.00, 30.00] s"``.

    Examples
    --------
    >>> format_margin(-0.012, " m", 12.4, (0.0, 30.0))
    'margin -0.012 m at t = 12.40 s of [0.00, 30.00] s'
    """
    text = f"margin {margin:+.6g}{unit}"
    if worst_time_s is not None:
        text += f" at t = {worst_time_s:.2f} s"
    if window_s is not None and all(math.isfinite(w) for w in window_s):
        text += f" of [{window_s[0]:.2f}, {window_s[1]:.2f}] s"
    return text


def format_limit_message(
    limit: str,
    value: float,
    bound: float,
    passed: bool,
    worst_time_s: float | None,
    first_time_s: float | None,
    margin: float | None = None,
    window_s: tuple[float, float] | None = None,
) -> str:
    """A limit's result as one readable line, as ``run`` and ``check`` print it.

    Parameters
    ----------
    limit : str
        The limit's name (a key of :data:`~agvctl.evaluation.limits.LIMITS`, whose unit is printed).
    value : float
        The run's value of its metric, in the limit's unit.
    bound : float
        The bound, in the same unit.
    passed : bool
        Whether the value is within the bound.
    worst_time_s : float or None
        When the signal was worst, s.
    first_time_s : float or None
        When it first went past the bound, s.
    margin : float or None
        The signed margin ``bound − value`` (None: not given).
    window_s : tuple of float or None
        The span of the run the limit looked at, s.

    Returns
    -------
    str
        ``"tracking_error_max_m: 0.0012 m against the limit 0.03 m — ok"``; a violated limit ends in
        ``— VIOLATED`` with the times; with a margin, it follows (:func:`format_margin`).

    Examples
    --------
    >>> print(format_limit_message("tracking_error_max_m", 0.042, 0.03, False, 12.4, 11.9))
    tracking_error_max_m: 0.042 m against the limit 0.03 m — VIOLATED, worst at t = 12.40 s,
    first exceeded at t = 11.90 s
    >>> print(format_limit_message("tracking_error_max_m", 0.012, 0.03, True, 12.4, None, 0.018, (0.0, 30.0)))
    tracking_error_max_m: 0.012 m against the limit 0.03 m — ok; margin +0.018 m at t = 12.40 s of [0.00, 30.00] s
    """
    unit = METRICS[limit].unit if limit in METRICS else ""
    text = f"{limit}: {value:.6g}{unit} against the limit {bound:.6g}{unit}"
    if passed:
        text += " — ok"
    else:
        text += " — VIOLATED"
        if worst_time_s is not None:
            text += f", worst at t = {worst_time_s:.2f} s"
        if first_time_s is not None:
            text += f", first exceeded at t = {first_time_s:.2f} s"
    if margin is not None and not math.isnan(margin):
        text += "; " + format_margin(margin, unit, worst_time_s, window_s)
    return text


def format_requirement_message(
    name: str,
    formula: str,
    passed: bool,
    margin: float,
    unit: str,
    worst_time_s: float | None,
    window_s: tuple[float, float] | None,
    note: str = "",
) -> str:
    """A requirement's verdict as one readable line.

    Parameters
    ----------
    name : str
        The requirement's name.
    formula : str
        Its formula.
    passed : bool
        Whether it was kept.
    margin : float
        Its signed margin, in ``unit``.
    unit : str
        The deciding signal's unit as printed.
    worst_time_s : float or None
        When it was decided, s.
    window_s : tuple of float or None
        The span of the run it looked at, s.
    note : str
        Why the margin is infinite or missing (empty: nothing to say).

    Returns
    -------
    str
        ``"dock_speed: always (...) — kept; margin +0.05 m/s at t = 9.12 s of [0.00, 20.00] s"``.

    Examples
    --------
    >>> print(format_requirement_message("slow", "always speed_m_s <= 0.2", False, -0.01, " m/s", 3.0, (0.0, 9.0)))
    slow: always speed_m_s <= 0.2 — BROKEN; margin -0.01 m/s at t = 3.00 s of [0.00, 9.00] s
    """
    text = f"{name}: {' '.join(formula.split())} — {'kept' if passed else 'BROKEN'}"
    if not math.isnan(margin):
        text += "; " + format_margin(margin, unit, worst_time_s, window_s)
    return text + (f" ({note})" if note else "")


class Verdict(Protocol):
    """What a verdict's line reads: a run's (:class:`LimitResult`) or the worst of an experiment's runs
    (``agvctl.checks.report.LimitVerdict``)."""

    @property
    def limit(self) -> str: ...
    @property
    def value(self) -> float: ...
    @property
    def bound(self) -> float: ...
    @property
    def passed(self) -> bool: ...
    @property
    def worst_time_s(self) -> float | None: ...
    @property
    def first_time_s(self) -> float | None: ...
    @property
    def default(self) -> bool: ...
    @property
    def reason(self) -> str: ...
    @property
    def margin(self) -> float: ...
    @property
    def window_s(self) -> tuple[float, float] | None: ...
    @property
    def kind(self) -> Literal["limit", "requirement"]: ...
    @property
    def formula(self) -> str: ...
    @property
    def unit(self) -> str: ...
    @property
    def note(self) -> str: ...


def verdict_message(verdict: Verdict) -> str:
    """A limit's or a requirement's verdict as the one line ``run``, ``check`` and ``fuzz`` print: the limit's
    (:func:`format_limit_message`) with a default's reason and its note, or the requirement's
    (:func:`format_requirement_message`).

    Parameters
    ----------
    verdict : Verdict
        The verdict.

    Returns
    -------
    str
        The line.
    """
    v = verdict
    if v.kind == "requirement":
        return format_requirement_message(
            v.limit, v.formula, v.passed, v.margin, v.unit, v.worst_time_s, v.window_s, v.note
        )
    text = format_limit_message(
        v.limit, v.value, v.bound, v.passed, v.worst_time_s, v.first_time_s, v.margin, v.window_s
    )
    text = f"{text} (default: {v.reason})" if v.default else text
    return f"{text}; {v.note}" if v.note else text


@document_fields
@dataclass(frozen=True)
class LimitResult:
    """One limit checked on one run."""

    limit: str
    """The limit's name, a key of :data:`~agvctl.evaluation.limits.LIMITS` (a requirement's name)."""
    bound: float
    """The bound, in the unit of the limit's name."""
    value: float
    """The run's value of the limit's metric, in the same unit."""
    passed: bool
    """Whether the value is within the bound."""
    worst_time_s: float | None
    """When the signal behind the limit was worst (None for counts that never happened), s."""
    first_time_s: float | None
    """When the signal first went past the bound (None if it never did), s."""
    default: bool = False
    """True when the bound is a default of :func:`~agvctl.evaluation.limits.default_limits`, not set in the file."""
    reason: str = ""
    """Why a default bound is what it is (one line; empty for a bound set in the file)."""
    margin: float = math.nan
    """The signed margin, in the unit of the limit's name or the requirement's signal: ``bound − value`` for a
    limit, the formula's robustness for a requirement (≥ 0: kept)."""
    window_s: tuple[float, float] | None = None
    """The span of the run the verdict looked at, s."""
    kind: Literal["limit", "requirement"] = "limit"
    """A ``[limits]`` key (or a default of the gate), or a requirement of ``[[requirements]]``."""
    formula: str = ""
    """The requirement's formula, or the limit's as one (``always abs(position_error_m) <= 0.03``) where it is
    judged as one; empty for a limit on a whole-run number (an RMS, a share, a count, a percentile)."""
    unit: str = ""
    """The margin's unit as printed (``" m"``)."""
    note: str = ""
    """Why a requirement's margin is infinite or missing; for a broken limit on the payload's readings, how the run
    fares where the wheels move freely (``wheel_held``); empty otherwise."""

    @property
    def normalised_margin(self) -> float:
        """The margin over its scale (:func:`margin_scale`: the bound's magnitude, a count's bound + ½), comparable
        between verdicts: −1 for a value twice its bound."""
        return self.margin / margin_scale(self.limit if self.kind == "limit" else "", self.bound)

    @property
    def message(self) -> str:
        """The verdict as one line (:func:`verdict_message`)."""
        return verdict_message(self)

    def as_dict(self) -> dict[str, object]:
        d = asdict(self)
        for key in ("margin", "value", "bound"):
            d[key] = _finite_or_none(d[key])
        d["window_s"] = None if self.window_s is None else [_finite_or_none(w) for w in self.window_s]
        d["normalised_margin"] = _finite_or_none(self.normalised_margin)
        d["message"] = self.message
        return d


def _finite_or_none(value: object) -> object:
    """JSON has no NaN nor infinity: None for them."""
    return None if isinstance(value, float) and not math.isfinite(value) else value


COUNT_MARGIN_STEP = 0.5
"""A count is judged against its bound + ½: its margin ``bound + ½ − count`` is +½ with no event to spare and −½ at
the first event over, never 0, so its sign is its verdict and a count at a bound of 0 ranks as far from failing."""


def margin_scale(limit: str, bound: float) -> float:
    """What a verdict's margin is normalised by: the bound's magnitude (1 for a bound of 0 or NaN), a count's
    bound + ½ (:data:`COUNT_MARGIN_STEP`).

    Parameters
    ----------
    limit : str
        The limit's or requirement's name.
    bound : float
        Its bound.

    Returns
    -------
    float
        The scale, > 0.
    """
    if limit in METRICS and METRICS[limit].reduction is Reduction.COUNT:
        return bound + COUNT_MARGIN_STEP
    return abs(bound) if math.isfinite(bound) and bound != 0 else 1.0


def smallest_normalised_margin(results: Sequence[LimitResult]) -> float:
    """The smallest margin over its bound's magnitude of a run's verdicts: how close the run came to failing
    (negative: it failed). A NaN margin counts as −∞.

    Parameters
    ----------
    results : sequence of LimitResult
        The run's verdicts.

    Returns
    -------
    float
        The smallest :attr:`LimitResult.normalised_margin` (+∞ with no verdict).
    """
    values = [r.normalised_margin for r in results]
    return min((-math.inf if math.isnan(v) else v for v in values), default=math.inf)


def all_passed(results: list[LimitResult]) -> bool:
    """Whether a run passes its limits and requirements: every one kept, and no limit of a metric that is NaN.

    Parameters
    ----------
    results : list of LimitResult
        The run's verdicts.

    Returns
    -------
    bool
        True if it passes (also with no verdict at all).
    """
    return all(r.passed for r in results) and not any(r.kind == "limit" and math.isnan(r.value) for r in results)
