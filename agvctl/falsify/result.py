"""What a search found: each run (:class:`SearchRun`), the whole search (:class:`FalsifyResult`), and the margin
it minimises (:func:`searched_margin`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agvctl.checks.report import TIMING_METRICS
from agvctl.config import document_fields
from agvctl.evaluation.limits import LimitResult, smallest_normalised_margin
from agvctl.fuzz.generate import Scenario, scenario_files
from agvctl.fuzz.spec import FuzzSpec

__all__ = ["FalsifyResult", "SearchRun", "searched_margin"]


def searched_margin(limits: Sequence[LimitResult], requirement: str | None = None) -> float:
    """The smallest normalised margin of a run's verdicts, the measured solve times excepted, or that of one
    limit or requirement: what the search minimises (negative: falsified).

    Parameters
    ----------
    limits : sequence of LimitResult
        The run's verdicts.
    requirement : str or None
        Only the verdict of this limit or requirement (None: every one).

    Returns
    -------
    float
        The smallest :attr:`~agvctl.evaluation.verdicts.LimitResult.normalised_margin` (+∞ with none).
    """
    if requirement is not None:
        return smallest_normalised_margin([r for r in limits if r.limit == requirement])
    return smallest_normalised_margin([r for r in limits if r.limit not in TIMING_METRICS])


@document_fields
@dataclass(frozen=True)
class SearchRun:
    """One run of a search: the scenario proposed, its verdicts and its margin."""

    run: int
    """Its number in the search, from 0."""
    params: dict[str, Any]
    """The optimiser's values, by parameter name (``segments``, ``plant.body.mass_kg``, ``start.heading_deg``, …)."""
    scenario: Scenario
    """The scenario they make."""
    margin: float
    """:func:`searched_margin` of the run (NaN if it crashed)."""
    verdicts: tuple[dict[str, Any], ...]
    """Per limit and requirement: ``name``, ``kind``, ``margin``, ``normalised_margin``, ``passed``, ``message``."""
    error: str | None
    """Why the run crashed (one line), or None."""
    wall_time_s: float
    """The run's own wall time, s."""
    requirement: str | None = None
    """The one limit or requirement searched (None: every one)."""

    @property
    def falsified(self) -> bool:
        """Whether the run crashed or a searched verdict's margin is below zero."""
        return self.error is not None or self.margin < 0.0

    @property
    def binding(self) -> str:
        """The verdict with the smallest normalised margin (``""`` if the run crashed or had none)."""
        searched = [v for v in self.verdicts if v["name"] not in TIMING_METRICS]
        if self.requirement is not None:
            return self.requirement
        if self.error is not None or not searched:
            return ""
        return str(min(searched, key=lambda v: _ordered_margin(v["normalised_margin"]))["name"])


def _ordered_margin(value: float | None) -> float:
    return -math.inf if value is None or math.isnan(value) else float(value)


@document_fields
@dataclass(frozen=True)
class FalsifyResult:
    """What :func:`falsify` found: every run in order, the parameters' importances, the random baseline."""

    spec: FuzzSpec
    """The fuzz configuration searched (its one controller)."""
    controller: str
    """The pose controller."""
    seed: int
    """The search's seed."""
    batch: int
    """Trials proposed together."""
    sampler: str
    """The optimiser (:data:`SAMPLERS`)."""
    runs: tuple[SearchRun, ...]
    """Every run, those of a resumed journal first."""
    resumed: int
    """How many of them the journal held already."""
    importances: dict[str, float]
    """How much each parameter sets the runs with the smallest margins apart (Optuna's PED-ANOVA over the
    lowest tenth of the margins, normalised to sum 1), largest first; empty below :data:`IMPORTANCE_MIN_RUNS` runs."""
    baseline_margins: tuple[float, ...]
    """The margins of random scenarios 0, 1, … of the configuration's seed (empty unless asked for)."""
    wall_time_s: float
    """This call's wall time, s."""
    run_time_s: float
    """The wall time of this call's runs and of its baseline, each measured in its worker, summed, s."""

    @property
    def worst(self) -> SearchRun | None:
        """The run closest to failing: a crash first, then the smallest margin (the earliest of equals)."""
        if not self.runs:
            return None
        return min(self.runs, key=lambda r: (r.error is None, _ordered_margin(r.margin), r.run))

    @property
    def falsifying(self) -> list[SearchRun]:
        """The runs that crashed or falsified a limit or requirement."""
        return [r for r in self.runs if r.falsified]

    @property
    def falsified(self) -> bool:
        """Whether any run did."""
        return bool(self.falsifying)

    def files(self, run: SearchRun) -> dict[str, str]:
        """A run's path file and experiment file (``{name: TOML text}``, path first), ready for ``agvctl check``.

        Parameters
        ----------
        run : SearchRun
            One of :attr:`runs`.

        Returns
        -------
        dict of str to str
            The files.
        """
        return scenario_files(self.spec, run.scenario, self.controller)

    def margins_so_far(self) -> list[float]:
        """The smallest margin after each run (a crash counts as −∞)."""
        return list(np.minimum.accumulate([_ordered_margin(r.margin) for r in self.runs]))
