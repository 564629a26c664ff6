"""What ``agvctl check`` reports: each run's outcome, each limit's verdict over an experiment's runs, the whole check.

These are plain data, apart from how they are computed (:mod:`agvctl.checks.runner`) and written
(:mod:`agvctl.checks.junit`, ``as_dict`` for JSON). A limit's verdict over several runs (the nominal run, or every
Monte Carlo sample) is decided by the worst run: the one with the largest value, since every limit is an upper bound.
A run that raised has no metrics: it is recorded with its error, its experiment fails as an error (not a limit
violation), and the verdicts are those of the experiment's other runs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from agvctl.config import document_fields
from agvctl.evaluation.limits import LimitResult, format_limit_message
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

    @property
    def message(self) -> str:
        """The limit message (with a default's reason); when violated on a Monte Carlo sample, that sample and its
        parameters too."""
        text = format_limit_message(
            self.limit, self.value, self.bound, self.passed, self.worst_time_s, self.first_time_s
        )
        if self.default:
            text += f" (default: {self.reason})"
        if self.passed:
            return text
        if self.sample is not None:
            params = ", ".join(f"{k} = {v:.6g}" for k, v in self.parameters.items())
            text += f"; sample {self.sample} of {self.runs} ({self.failed_runs} failed): {params}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["message"] = self.message
        return d


def worst_run_verdicts(outcomes: Sequence[RunOutcome]) -> list[LimitVerdict]:
    """One verdict per limit over the runs of one experiment, each naming the run with the largest (worst) value.

    The limit fails when any run fails; among failed runs the worst is also one that exceeded the bound, so the
    verdict's value, times and sample are those of a violating run.

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
        worst_i = int(np.argmax([r.value for r in per_run]))
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
