"""Requirements a user writes: ``[[requirements]]`` of an experiment or a fuzz file, each a formula of signal
temporal logic (:mod:`agvctl.evaluation.formula`, evaluated by :mod:`agvctl.evaluation.stl`) over the run's named
signals and the named parts of its path, judged with a signed margin in the signal's unit.

::

    [[requirements]]
    name = "settles_at_the_dock"
    formula = "eventually[0, 3] always position_error_m <= 0.005"
    anchor = "reference_end"

A formula's signals are the log's columns and the derived signals of :data:`~agvctl.evaluation.metrics.SIGNALS`,
the same samples the metrics reduce. Its time windows count from its ``anchor``: the run's start (``"start"``, the
default), the reference's end (``"reference_end"``) or the run's last sample (``"run_end"``). Its conditions
(:data:`PARTS`) name parts of the run the reference marks: ``after_reference_end`` (the final dock, once the
reference is at rest), ``turning_in_place`` (the reference's turns in place) and ``on_segment(i)`` (the path file's
segment ``i``, counted from 0, negative from the end; a waypoint path's waypoint intervals).

The verdict (:func:`evaluate_requirement`) gives the margin at the anchor (≥ 0: kept), the time of the sample that
decided it, the comparison there (its constant is the verdict's bound, its signal's unit the margin's) and the window
of time the formula looked at. A requirement whose conditions never hold where it looks is kept vacuously (margin
+∞), and says so.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.config import check_fields, check_plain_name, did_you_mean, document_fields
from agvctl.errors import ConfigError
from agvctl.evaluation.formula import Atom, Formula, FormulaError, atoms, comparisons, horizon_s, parse_formula
from agvctl.evaluation.metrics import SIGNALS, signal_values
from agvctl.evaluation.stl import Trace, first_at_or_after, robustness
from agvctl.log import SimLog

__all__ = [
    "ANCHORS",
    "PARTS",
    "RequirementSpec",
    "Verdict",
    "check_requirement_names",
    "evaluate_requirement",
    "signal_unit",
]

Anchor = Literal["start", "reference_end", "run_end"]
ANCHORS: tuple[str, ...] = ("start", "reference_end", "run_end")
"""Where a requirement's time windows count from: the run's start, the reference's end, the run's last sample."""


class PathParts(Protocol):
    """What the parts of a run are read from (:class:`~agvctl.planning.reference.Reference` is one)."""

    @property
    def duration_s(self) -> float: ...

    @property
    def segment_count(self) -> int: ...

    @property
    def motions(self) -> Any: ...

    def segment_index(self, t_s: Any) -> NDArray[np.int64]: ...


def _after_end(reference: PathParts, t_s: NDArray[np.float64], argument: int | None) -> NDArray[np.bool_]:
    return np.asarray(t_s >= reference.duration_s - 1e-9)


def _turning(reference: PathParts, t_s: NDArray[np.float64], argument: int | None) -> NDArray[np.bool_]:
    out = np.zeros(len(t_s), dtype=bool)
    for m in reference.motions:
        if m.kind == "spin":
            out |= (t_s >= m.t_start_s - 1e-9) & (t_s < m.t_end_s - 1e-9)
    return out


def _on_segment(reference: PathParts, t_s: NDArray[np.float64], argument: int | None) -> NDArray[np.bool_]:
    assert argument is not None
    count = reference.segment_count
    index = argument + count if argument < 0 else argument
    if not 0 <= index < count:
        raise FormulaError(f"on_segment({argument}): the path has {count} segments")
    during = t_s < reference.duration_s - 1e-9
    return np.asarray(during & (reference.segment_index(np.minimum(t_s, reference.duration_s)) == index))


PARTS: dict[str, tuple[Callable[[PathParts, NDArray[np.float64], int | None], NDArray[np.bool_]], bool]] = {
    "after_reference_end": (_after_end, False),
    "turning_in_place": (_turning, False),
    "on_segment": (_on_segment, True),
}
"""The named parts of a run a formula may use as conditions: (where it holds at the given times, whether it takes
an integer argument). Each is read from the run's reference."""


_UNITS = (
    ("_m_s2", " m/s²"),
    ("_m_s3", " m/s³"),
    ("_rad_s", " rad/s"),
    ("_m_s", " m/s"),
    ("_deg", "°"),
    ("_rad", " rad"),
    ("_ms", " ms"),
    ("_m", " m"),
    ("_s", " s"),
    ("_a", " A"),
    ("_v", " V"),
)


def signal_unit(name: str) -> str:
    """A signal's unit as printed after a value, from the end of its name (``" m/s"``; empty for a flag or a share).

    Parameters
    ----------
    name : str
        The signal's name.

    Returns
    -------
    str
        The unit.

    Examples
    --------
    >>> signal_unit("wheel_speed_error_left_m_s"), signal_unit("heading_error_deg"), signal_unit("da_clipped")
    (' m/s', '°', '')
    """
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return ""


@document_fields
@dataclass(frozen=True)
class RequirementSpec:
    """One ``[[requirements]]`` table: a named formula and where its windows count from.

    Raises
    ------
    ConfigError
        ``RequirementSpec: formula: <problem>``: a formula that does not parse, a part it names that does not
        exist; ``name``: not a plain name.
    """

    name: str
    """Its name, as the reports and JUnit's test cases give it (a plain name)."""
    formula: str
    """The formula (:mod:`agvctl.evaluation.formula`), e.g. ``"always abs(cross_track_error_m) <= 0.05"``."""
    anchor: Anchor = "start"
    """Where its time windows count from: ``"start"`` (the run's start), ``"reference_end"``, ``"run_end"``."""

    def __post_init__(self) -> None:
        check_fields(self)
        check_plain_name(self.name, type(self).__name__, "name", "its test case")
        try:
            parsed = parse_formula(self.formula)
        except FormulaError as exc:
            raise ConfigError(type(self).__name__, "formula", str(exc)) from None
        for atom in atoms(parsed):
            if atom.name in PARTS and PARTS[atom.name][1] != (atom.argument is not None):
                needs = "an integer argument, e.g. on_segment(-1)" if PARTS[atom.name][1] else "no argument"
                raise ConfigError(type(self).__name__, "formula", f"{atom.name} takes {needs}")
            if atom.name not in PARTS and atom.argument is not None:
                hint = did_you_mean(atom.name, PARTS, [])
                raise ConfigError(type(self).__name__, "formula", f"{atom} is not a part of a run{hint}")

    @property
    def parsed(self) -> Formula:
        """The formula's tree."""
        return parse_formula(self.formula)


def check_requirement_names(
    requirements: tuple[RequirementSpec, ...], columns: Collection[str], *, source: str, prefix: str
) -> None:
    """Refuse requirements whose formulas name a signal the run has not (a log column nor a derived signal) or
    share a name.

    Parameters
    ----------
    requirements : tuple of RequirementSpec
        The file's ``[[requirements]]``.
    columns : collection of str
        The columns of a closed-loop run's log.
    source : str
        The file, as errors name it.
    prefix : str
        The dotted key of the requirements' list (``requirements``).

    Raises
    ------
    ConfigError
        ``<source>: requirements[i].formula: unknown signal 'x' (did you mean ...)``, or a repeated name.
    """
    known = set(columns) | set(SIGNALS)
    seen: set[str] = set()
    for i, req in enumerate(requirements):
        where = f"{prefix}[{i}]"
        if req.name in seen:
            raise ConfigError(source, f"{where}.name", f"{req.name!r} names another requirement too")
        seen.add(req.name)
        parsed = req.parsed
        for c in comparisons(parsed):
            if c.signal not in known:
                hint = did_you_mean(c.signal, sorted(known), [])
                raise ConfigError(source, f"{where}.formula", f"unknown signal {c.signal!r}{hint}")
        for atom in atoms(parsed):
            if atom.name not in PARTS and atom.name not in known:
                hint = did_you_mean(atom.name, sorted(known | set(PARTS)), [])
                raise ConfigError(source, f"{where}.formula", f"unknown signal or part {atom.name!r}{hint}")


@document_fields
@dataclass(frozen=True)
class Verdict:
    """What a requirement's formula gave on a run: its margin and where it was decided."""

    margin: float
    """The signed margin at the anchor, in the unit of the deciding comparison's signal (≥ 0: kept; +∞ when kept
    vacuously, −∞ when a condition alone broke it, NaN when it could not be judged)."""
    worst_time_s: float | None
    """When the deciding sample was, s (None when it could not be judged)."""
    window_s: tuple[float, float]
    """The span of the run the formula looked at, s."""
    bound: float
    """The deciding comparison's constant, in its signal's unit (NaN when a condition decided)."""
    value: float
    """Its signal's value at the deciding sample (NaN when a condition decided)."""
    unit: str
    """Its signal's unit as printed (``" m"``)."""
    note: str = ""
    """Why the margin is infinite or missing (a part the run does not have, a condition that never holds)."""


def _anchor_time(anchor: str, t_s: NDArray[np.float64], reference: PathParts | None) -> float | None:
    if anchor == "start":
        return float(t_s[0])
    if anchor == "run_end":
        return float(t_s[-1])
    return None if reference is None else float(reference.duration_s)


def evaluate_requirement(
    requirement: RequirementSpec | Formula,
    log: SimLog,
    sample_period_s: float,
    reference: PathParts | None,
    *,
    anchor: str | None = None,
) -> Verdict:
    """Judge a requirement on a run: its margin at the anchor, the deciding sample's time and the window.

    Parameters
    ----------
    requirement : RequirementSpec or Formula
        The requirement (or a parsed formula, with ``anchor``).
    log : SimLog
        The run's log.
    sample_period_s : float
        T_s, s.
    reference : Reference or None
        The run's reference, which marks the parts of the path (None: a run without one; its parts are then not
        available).
    anchor : str or None
        Where the windows count from (a key of :data:`ANCHORS`), for a parsed formula; a spec's own otherwise.

    Returns
    -------
    Verdict
        The margin (NaN with a note when a part or the anchor is not available), its time and window.
    """
    formula = requirement.parsed if isinstance(requirement, RequirementSpec) else requirement
    where = anchor if anchor is not None else getattr(requirement, "anchor", "start")
    t = np.asarray(log["t_s"], dtype=np.float64)
    nan = Verdict(math.nan, None, (math.nan, math.nan), math.nan, math.nan, "")
    if len(t) == 0:
        return Verdict(math.nan, None, (0.0, 0.0), math.nan, math.nan, "", "the run has no samples")
    start = _anchor_time(where, t, reference)
    if start is None:
        return Verdict(**{**nan.__dict__, "note": "not judged: the run has no reference, so no reference end"})
    leaves = comparisons(formula)

    def signal(name: str) -> NDArray[np.float64]:
        return signal_values(log, name, sample_period_s)

    def condition(atom: Atom) -> NDArray[np.bool_]:
        if atom.name in PARTS:
            if reference is None:
                raise FormulaError(f"{atom} is not available: the run has no reference")
            return PARTS[atom.name][0](reference, t, atom.argument)
        values = signal(atom.name)
        return np.asarray((values != 0) & ~np.isnan(values))

    try:
        rho = robustness(formula, Trace(t, signal, condition))
    except FormulaError as exc:
        return Verdict(**{**nan.__dict__, "note": f"not judged: {exc}"})
    k = first_at_or_after(t, start)
    lo, hi = horizon_s(formula)
    window = (max(float(t[0]), float(t[k]) + lo), min(float(t[-1]), float(t[k]) + hi))
    margin = float(rho.value[k])
    sample = int(rho.sample[k])
    leaf = int(rho.leaf[k])
    if leaf < 0:
        names = ", ".join(sorted({str(a) for a in atoms(formula)}))
        unit = signal_unit(leaves[0].signal) if leaves else ""
        if margin == math.inf:
            note = f"kept vacuously: {names} never holds where it looks"
        else:
            note = f"broken by its conditions alone ({names})"
        return Verdict(margin, float(t[sample]), window, math.nan, math.nan, unit, note)
    comparison = leaves[leaf]
    x = float(signal(comparison.signal)[sample])
    value = abs(x) if comparison.absolute else x
    return Verdict(margin, float(t[sample]), window, comparison.constant, value, signal_unit(comparison.signal))
