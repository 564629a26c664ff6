"""What ``agvctl fuzz`` reports: each run's outcome, per-controller statistics, comparisons, JSON and JUnit.

Plain data apart from the statistics: percentiles over the runs that completed (a crashed run has no metrics and
is counted apart), the worst scenarios (crashes first, then failures, by the largest cross-track error), and, with
two or more controllers, how the first compares with each other one on the same scenarios.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from agvctl.checks.junit import JUnitCase, JUnitSuite, junit_suites
from agvctl.config import document_fields
from agvctl.evaluation.limits import LimitResult, smallest_normalised_margin
from agvctl.fileio import json_safe
from agvctl.fuzz.spec import FuzzSpec

__all__ = ["COMPARISON_TOLERANCE_M", "FUZZ_METRICS", "PERCENTILES", "FuzzOutcome", "FuzzReport", "FuzzTask"]

FUZZ_METRICS = (
    "cross_track_error_max_m",
    "cross_track_error_rms_m",
    "final_position_error_m",
    "tracking_error_rms_m",
    "path_heading_error_max_deg",
    "along_track_lag_max_m",
)
"""The metrics whose distributions are reported per controller."""

PERCENTILES = (50, 90, 99)

COMPARISON_TOLERANCE_M = 0.001
"""Two runs' largest cross-track errors within a millimetre of each other are a tie: "no worse than" means at most
this much larger. Below it, differences come from stiction break-away and solver tolerances, not from tracking."""


@document_fields
@dataclass(frozen=True)
class FuzzTask:
    """One scenario with one pose controller: its files, the path file first, the experiment file last."""

    scenario: int
    """The scenario's number."""
    name: str
    """The scenario's name (``s<seed>_<index>``)."""
    controller: str
    """The pose controller's name."""
    files: tuple[tuple[str, str], ...]
    """``(file name, TOML text)`` pairs."""


@document_fields
@dataclass(frozen=True)
class FuzzOutcome:
    """What a run sends back (no log)."""

    scenario: int
    """The scenario's number."""
    controller: str
    """The pose controller's name."""
    passed: bool
    """Whether the run was completed and kept every limit."""
    metrics: dict[str, float]
    """:func:`~agvctl.evaluation.metrics.closed_loop_metrics`, each in the unit of its name (empty if the run
    crashed)."""
    limits: tuple[LimitResult, ...]
    """The configuration's limits and the default ``non_finite_commands`` check (not the default a_lim check)."""
    error: str | None
    """Why the run crashed or is numerically broken (one line), or None."""
    warnings: tuple[str, ...]
    """The warnings the run issued (one line each, deduplicated)."""
    wall_time_s: float
    """The run's wall time, s."""
    simulated_s: float
    """The simulated time, s."""

    @property
    def reasons(self) -> list[str]:
        """Why it failed: the error, or the messages of the violated limits."""
        if self.error is not None:
            return [self.error]
        return [r.message for r in self.limits if not r.passed or (r.kind == "limit" and math.isnan(r.value))]

    @property
    def min_normalised_margin(self) -> float:
        """The smallest margin over its bound of its verdicts
        (:func:`~agvctl.evaluation.limits.smallest_normalised_margin`; NaN if the run crashed)."""
        return math.nan if self.error is not None else smallest_normalised_margin(self.limits)

    def value(self, metric: str) -> float:
        """A metric, NaN if the run crashed."""
        return float(self.metrics.get(metric, math.nan))


def _percentiles(values: np.ndarray) -> dict[str, float | None]:
    values = values[np.isfinite(values)]
    if values.size == 0:
        return {**{f"p{p}": None for p in PERCENTILES}, "max": None}
    out: dict[str, float | None] = {f"p{p}": float(np.percentile(values, p)) for p in PERCENTILES}
    out["max"] = float(np.max(values))
    return out


@document_fields
@dataclass
class FuzzReport:
    """A fuzz run: the configuration, every task and its outcome (same order), and the wall time."""

    spec: FuzzSpec
    """The configuration."""
    tasks: list[FuzzTask]
    """Every task."""
    outcomes: list[FuzzOutcome]
    """Every task's outcome, in the order of the tasks."""
    wall_time_s: float
    """The whole run's wall time, s."""

    @property
    def passed(self) -> bool:
        return all(o.passed for o in self.outcomes)

    def runs(self, controller: str) -> list[FuzzOutcome]:
        """The outcomes of one controller, in scenario order."""
        return [o for o in self.outcomes if o.controller == controller]

    def statistics(self) -> dict[str, dict[str, Any]]:
        """Per controller: ``runs``, ``passed``, ``failed``, ``crashed`` and, per metric of :data:`FUZZ_METRICS`,
        ``{"p50", "p90", "p99", "max"}`` over the runs that completed (None if none did)."""
        stats: dict[str, dict[str, Any]] = {}
        for c in self.spec.controllers:
            runs = self.runs(c)
            entry: dict[str, Any] = {
                "runs": len(runs),
                "passed": sum(o.passed for o in runs),
                "failed": sum(not o.passed for o in runs),
                "crashed": sum(o.error is not None for o in runs),
            }
            for m in FUZZ_METRICS:
                entry[m] = _percentiles(np.array([o.value(m) for o in runs], dtype=float))
            stats[c] = entry
        return stats

    def comparisons(self) -> list[dict[str, Any]]:
        """The first controller (A) against each other one (B), scenario by scenario: the share of scenarios where
        A's maximum cross-track error is no worse than B's (at most :data:`COMPARISON_TOLERANCE_M` larger; a crashed
        run counts as infinitely far off; scenarios where both crashed are left out), and A's median cross-track RMS
        over B's (being on the path, not keeping time: the time-indexed RMS is decided by how fast a start offset is
        removed). ``a_cross_track_max_above_b`` lists the scenarios where A's maximum is worse by more than the
        tolerance."""
        if len(self.spec.controllers) < 2:
            return []
        a = self.spec.controllers[0]

        def by_scenario(c: str, metric: str) -> dict[int, float]:
            return {o.scenario: o.value(metric) for o in self.runs(c)}

        out = []
        for b in self.spec.controllers[1:]:
            xa, xb = by_scenario(a, "cross_track_error_max_m"), by_scenario(b, "cross_track_error_max_m")
            pairs = {
                s: (math.inf if math.isnan(xa[s]) else xa[s], math.inf if math.isnan(xb[s]) else xb[s])
                for s in xa
                if s in xb and not (math.isnan(xa[s]) and math.isnan(xb[s]))
            }
            ra, rb = by_scenario(a, "cross_track_error_rms_m"), by_scenario(b, "cross_track_error_rms_m")
            med_a = float(np.nanmedian(list(ra.values()))) if any(np.isfinite(list(ra.values()))) else math.nan
            med_b = float(np.nanmedian(list(rb.values()))) if any(np.isfinite(list(rb.values()))) else math.nan
            out.append(
                {
                    "a": a,
                    "b": b,
                    "scenarios": len(pairs),
                    "tolerance_m": COMPARISON_TOLERANCE_M,
                    "a_cross_track_max_le_b_fraction": (
                        sum(pa <= pb + COMPARISON_TOLERANCE_M for pa, pb in pairs.values()) / len(pairs)
                    )
                    if pairs
                    else None,
                    "a_cross_track_max_above_b": sorted(
                        s for s, (pa, pb) in pairs.items() if pa > pb + COMPARISON_TOLERANCE_M
                    ),
                    "median_rms_a_m": med_a,
                    "median_rms_b_m": med_b,
                    "median_rms_ratio": med_a / med_b if med_b > 0 else None,
                }
            )
        return out

    def worst(self, controller: str, n: int = 5) -> list[FuzzOutcome]:
        """The ``n`` worst runs of a controller: crashes first, then failures, by the largest cross-track error."""

        def key(o: FuzzOutcome) -> tuple[bool, bool, float]:
            x = o.value("cross_track_error_max_m")
            return (o.error is None, o.passed, -(math.inf if math.isnan(x) else x))

        return sorted(self.runs(controller), key=key)[:n]

    def failure_files(self) -> dict[str, str]:
        """``{file name: TOML text}`` of every failing run: its experiment file and its scenario's path file."""
        files: dict[str, str] = {}
        for task, outcome in zip(self.tasks, self.outcomes, strict=True):
            if not outcome.passed:
                files.update(task.files)
        return files

    def as_dict(self) -> dict[str, Any]:
        """The JSON summary: configuration, statistics, comparisons and one row per run."""
        runs = []
        for task, o in zip(self.tasks, self.outcomes, strict=True):
            runs.append(
                {
                    "scenario": o.scenario,
                    "name": task.name,
                    "controller": o.controller,
                    "passed": o.passed,
                    "error": o.error,
                    "reasons": o.reasons,
                    "min_normalised_margin": json_safe({"m": o.min_normalised_margin})["m"],
                    "experiment_file": None if o.passed else task.files[-1][0],
                    "metrics": json_safe(o.metrics),
                    "warnings": list(o.warnings),
                    "wall_time_s": o.wall_time_s,
                    "simulated_s": o.simulated_s,
                }
            )
        return {
            "config": self.spec.source,
            "name": self.spec.name,
            "seed": self.spec.seed,
            "scenarios": len({t.scenario for t in self.tasks}),
            "controllers": list(self.spec.controllers),
            "limits": self.spec.limits.to_file(),
            "requirements": [
                {"name": r.name, "formula": r.formula, "anchor": r.anchor} for r in self.spec.requirements
            ],
            "passed": self.passed,
            "wall_time_s": self.wall_time_s,
            "statistics": self.statistics(),
            "comparisons": [json_safe(c) for c in self.comparisons()],
            "runs": runs,
        }

    def junit(self) -> str:
        """JUnit XML: one test suite per controller, one test case per scenario (a crash is an ``<error>``)."""
        suites = []
        for c in self.spec.controllers:
            cases = []
            for task, o in zip(self.tasks, self.outcomes, strict=True):
                if o.controller != c:
                    continue
                text = "; ".join(o.reasons)
                cases.append(
                    JUnitCase(
                        f"agvctl.fuzz.{self.spec.name}.{c}",
                        task.name,
                        o.wall_time_s,
                        output="" if o.reasons else "ok",
                        failure=text if (not o.passed and o.error is None) else None,
                        error=o.error,
                    )
                )
            suites.append(JUnitSuite(c, self.spec.source, cases, sum(x.time_s for x in cases)))
        return junit_suites(f"agvctl fuzz {self.spec.name}", suites, self.wall_time_s)
