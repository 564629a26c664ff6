"""What ``agvctl check`` reports: each run's outcome, each limit's verdict over an experiment's runs, the whole check.

These are plain data, apart from how they are computed (:mod:`agvctl.checks.runner`) and written
(:mod:`agvctl.checks.junit`, ``as_dict`` for JSON). A verdict over several runs (the nominal run, or every Monte
Carlo sample) is decided by the worst run: the one with the smallest margin (for a limit, an upper bound, the largest
value).
A run that raised has no metrics: it is recorded with its error, its experiment fails as an error (not a limit
violation), and the verdicts are those of the experiment's other runs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from agvctl.config import document_fields
from agvctl.evaluation.limits import LimitResult, margin_scale, smallest_normalised_margin
from agvctl.evaluation.verdicts import verdict_message
from agvctl.fileio import json_safe
from agvctl.scenario.experiment import Experiment

__all__ = [
    "TIMING_METRICS",
    "CheckReport",
    "ExperimentReport",
    "LimitVerdict",
    "Overrides",
    "RunOutcome",
    "RunTask",
    "closest_to_failing",
    "worst_run_verdicts",
]

Overrides = tuple[tuple[str, float], ...]
"""A Monte Carlo sample's plant: ``(dotted vehicle key, value)`` pairs."""

TIMING_METRICS = ("solve_time_p50_ms", "solve_time_p99_ms", "deadline_misses")
"""Metrics measured on the wall clock: they vary between runs and executors."""


@document_fields
@dataclass(frozen=True)
class RunTask:
    """One closed-loop run: an experiment file, and for a Monte Carlo sample its plant overrides."""

    experiment_path: str
    """The experiment file."""
    sample: int | None
    """The Monte Carlo sample's index (None: the nominal run)."""
    overrides: Overrides = ()
    """The sample's plant: ``(dotted vehicle key, value)`` pairs, each value in the unit of its key."""


@document_fields
@dataclass(frozen=True)
class RunOutcome:
    """What a run sends back: metrics and limit verdicts (no log), or why it could not be completed."""

    task: RunTask
    """The run."""
    metrics: dict[str, float]
    """Its :func:`~agvctl.evaluation.metrics.closed_loop_metrics`, each in the unit of its name."""
    limits: tuple[LimitResult, ...]
    """Each limit checked on it."""
    wall_time_s: float
    """Its wall time, s."""
    error: str | None = None
    """Why the run could not be completed: the exception's type, message and innermost frame, on one line (no
    metrics nor limits then); None for a completed run."""
    figures: dict[str, bytes] = field(default_factory=dict, repr=False)
    """The run's figures drawn where it ran (PNG bytes by name), when the check was asked to draw them
    (:func:`~agvctl.checks.runner.check_experiments`'s ``render``); empty otherwise."""


@document_fields
@dataclass(frozen=True)
class LimitVerdict:
    """One limit of one experiment over all its runs: the worst run decides."""

    limit: str
    """The limit's name."""
    bound: float
    """The bound, in the unit of the limit's name."""
    passed: bool
    """Whether every run kept it."""
    value: float
    """The worst value over the runs, in the same unit."""
    worst_time_s: float | None
    """When the worst run's signal was worst, s."""
    first_time_s: float | None
    """When the worst run's signal first went past the bound (None if it never did), s."""
    sample: int | None
    """The Monte Carlo sample that gave the worst value (None: the nominal run)."""
    parameters: dict[str, float]
    """That sample's plant parameters (the dotted keys that were varied)."""
    runs: int
    """How many runs were completed."""
    failed_runs: int
    """How many of them broke the limit."""
    default: bool = False
    """Whether the bound is the default gate's (:func:`~agvctl.evaluation.limits.default_limits`)."""
    reason: str = ""
    """Why a default bound is what it is."""
    margin: float = math.nan
    """The worst run's signed margin (≥ 0: kept), in :attr:`unit`
    (:attr:`~agvctl.evaluation.limits.LimitResult.margin`)."""
    window_s: tuple[float, float] | None = None
    """The span of the worst run the verdict looked at, s."""
    kind: Literal["limit", "requirement"] = "limit"
    """A limit or a requirement of ``[[requirements]]``."""
    formula: str = ""
    """The formula it is judged by (empty for a limit on a whole-run number)."""
    unit: str = ""
    """The margin's unit as printed."""
    note: str = ""
    """Why a requirement's margin is infinite or missing; for a broken limit on the payload's readings, how the run
    fares where the wheels move freely."""

    @property
    def normalised_margin(self) -> float:
        """The margin over its scale (:func:`~agvctl.evaluation.limits.margin_scale`)."""
        return self.margin / margin_scale(self.limit if self.kind == "limit" else "", self.bound)

    @property
    def message(self) -> str:
        """The limit's or requirement's message with its margin (and a default's reason); when violated on a Monte
        Carlo sample, that sample and its parameters too."""
        text = verdict_message(self)
        if self.passed:
            return text
        if self.sample is not None:
            params = ", ".join(f"{k} = {v:.6g}" for k, v in self.parameters.items())
            text += f"; sample {self.sample} of {self.runs} ({self.failed_runs} failed): {params}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d.update(json_safe({k: d[k] for k in ("margin", "value", "bound")}))
        d["window_s"] = None if self.window_s is None else [w if math.isfinite(w) else None for w in self.window_s]
        d["normalised_margin"] = json_safe({"m": self.normalised_margin})["m"]
        d["message"] = self.message
        return d


def _ranked_margin(r: LimitResult) -> float:
    """A run's margin as runs are ranked by it: a limit given without one by ``bound − value``; NaN as −∞."""
    margin = r.margin
    if math.isnan(margin) and r.kind == "limit":
        margin = r.bound - r.value
    return -math.inf if math.isnan(margin) else margin


def worst_run_verdicts(outcomes: Sequence[RunOutcome]) -> list[LimitVerdict]:
    """One verdict per limit and requirement over the runs of one experiment, each naming the run with the smallest
    (worst) margin: for a limit, the largest value.

    The verdict fails when any run fails; among failed runs the worst is also one that broke it (a NaN margin
    counts as the worst), so the verdict's value, margin, times and sample are those of a failing run.

    Parameters
    ----------
    outcomes : sequence of RunOutcome
        The experiment's runs; those that could not be completed have no values and are left out.

    Returns
    -------
    list of LimitVerdict
        In the order of the runs' limits; empty when no run was completed.
    """
    completed = [o for o in outcomes if o.error is None]
    if not completed:
        return []
    verdicts = []
    for idx, first in enumerate(completed[0].limits):
        per_run = [o.limits[idx] for o in completed]
        worst_i = int(np.argmin([_ranked_margin(r) for r in per_run]))
        if first.kind == "limit" and any(math.isnan(r.value) for r in per_run):
            worst_i = int(np.argmax([r.value for r in per_run]))  # a metric that is NaN: that run
        worst = per_run[worst_i]
        failed = sum(not r.passed for r in per_run)
        task = completed[worst_i].task
        verdicts.append(
            LimitVerdict(
                limit=first.limit,
                bound=worst.bound,
                passed=not failed,
                value=worst.value,
                worst_time_s=worst.worst_time_s,
                first_time_s=worst.first_time_s,
                sample=task.sample,
                parameters=dict(task.overrides),
                runs=len(per_run),
                failed_runs=failed,
                default=worst.default,
                reason=worst.reason,
                margin=worst.margin,
                window_s=worst.window_s,
                kind=worst.kind,
                formula=worst.formula,
                unit=worst.unit,
                note=worst.note,
            )
        )
    return verdicts


@document_fields
@dataclass
class ExperimentReport:
    """One experiment's verdicts, with the raw outcomes of its runs."""

    name: str
    """The experiment's name."""
    path: str
    """Its file."""
    verdicts: list[LimitVerdict]
    """Each limit's verdict over its runs."""
    outcomes: list[RunOutcome]
    """Each run's outcome."""
    wall_time_s: float
    """The runs' summed wall time (they may have run in parallel), s."""
    experiment: Experiment | None = field(default=None, repr=False, compare=False)
    """The experiment as loaded and validated for the check (None: only its file's path is known)."""

    @property
    def errors(self) -> list[RunOutcome]:
        """The runs that could not be completed."""
        return [o for o in self.outcomes if o.error is not None]

    @property
    def completed(self) -> bool:
        """Whether every run was completed."""
        return not self.errors

    @property
    def passed(self) -> bool:
        """Every run completed and every limit held."""
        return self.completed and all(v.passed for v in self.verdicts)

    @property
    def monte_carlo(self) -> bool:
        return any(o.task.sample is not None for o in self.outcomes)

    @property
    def min_normalised_margin(self) -> float:
        """The smallest margin over its bound of any verdict of any run (negative: a run failed; NaN: no run was
        completed)."""
        runs = [o for o in self.outcomes if o.error is None]
        if not runs:
            return math.nan
        return min(smallest_normalised_margin(o.limits) for o in runs)

    def consistency(self) -> dict[str, Any] | None:
        """The estimator's NEES and NIS (3 dof each) averaged over the runs, with the 95 % chi-square interval of
        an average over that many runs at one instant: [χ²₀.₀₂₅(3n)/n, χ²₀.₉₇₅(3n)/n]. Averaging over time as well
        only narrows the spread, so a mean outside the interval is inconsistent for certain. None for runs
        without an estimator that has a covariance."""
        from scipy.stats import chi2

        stats: dict[str, Any] = {}
        for name in ("nees_mean", "nis_mean"):
            values = [o.metrics[name] for o in self.outcomes if math.isfinite(o.metrics.get(name, math.nan))]
            if values:
                n = len(values)
                lo, hi = (float(v) for v in chi2.ppf([0.025, 0.975], 3 * n) / n)
                mean = float(sum(values) / n)
                stats[name] = {"value": mean, "runs": n, "interval_95": [lo, hi], "inside": lo <= mean <= hi}
        return stats or None

    def as_dict(self) -> dict[str, Any]:
        metrics = [{"sample": o.task.sample, **json_safe(o.metrics)} for o in self.outcomes]
        out = {
            "experiment": self.name,
            "path": self.path,
            "passed": self.passed,
            "completed": self.completed,
            "runs": len(self.outcomes),
            "errors": [{"sample": o.task.sample, "error": o.error} for o in self.errors],
            "wall_time_s": self.wall_time_s,
            "limits": [v.as_dict() for v in self.verdicts],
            "min_normalised_margin": json_safe({"m": self.min_normalised_margin})["m"],
            "metrics": metrics if self.monte_carlo else metrics[0],
        }
        consistency = self.consistency()
        if consistency is not None:
            out["consistency"] = consistency
        return out


@document_fields
@dataclass
class CheckReport:
    """Every experiment's report."""

    experiments: list[ExperimentReport] = field(default_factory=list)
    """The experiments' reports, in the order they were given."""
    wall_time_s: float = 0.0
    """The whole check's wall time, s."""

    @property
    def passed(self) -> bool:
        return all(e.passed for e in self.experiments)

    @property
    def completed(self) -> bool:
        """Whether every run of every experiment was completed (none raised)."""
        return all(e.completed for e in self.experiments)

    @property
    def monte_carlo(self) -> bool:
        """Whether any experiment has Monte Carlo samples."""
        return any(e.monte_carlo for e in self.experiments)

    @property
    def runs_errored(self) -> int:
        """How many runs could not be completed."""
        return sum(len(e.errors) for e in self.experiments)

    def as_dict(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "completed": self.completed,
            "runs_errored": self.runs_errored,
            "wall_time_s": self.wall_time_s,
            "experiments": [e.as_dict() for e in self.experiments],
        }


def closest_to_failing(report: CheckReport, count: int = 10) -> list[tuple[str, LimitVerdict]]:
    """The verdicts of a check closest to failing: the smallest margins over their bounds first.

    A margin is compared over its bound's magnitude (:attr:`LimitVerdict.normalised_margin`), so a limit in metres
    and a requirement in metres per second rank together: −0.5 is a value half again its bound, 0.1 one a tenth
    below it. A verdict that could not be judged (NaN) ranks first; one kept vacuously (+∞) last.

    Parameters
    ----------
    report : CheckReport
        The check's report.
    count : int
        How many to give (at most).

    Returns
    -------
    list of tuple
        (experiment name, verdict), the closest to failing first.
    """
    rows = [(exp.name, v) for exp in report.experiments for v in exp.verdicts]
    rows.sort(key=lambda row: -math.inf if math.isnan(row[1].normalised_margin) else row[1].normalised_margin)
    return rows[: max(0, count)]
