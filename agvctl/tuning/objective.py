"""What a pose controller's settings are judged by over a set of scenarios: one number to minimise.

The objective puts the default gate first, then staying on the path, then the time taken:

    J = gate · (1 − pass share)
      + cross_track_p90 · p90 of the runs' largest cross-track errors once on the path / 1 cm
      + cross_track_rms · RMS of the runs' cross-track errors / 1 cm
      + time · (mean of completion time / reference duration − 1)

With the default weights (:class:`ObjectiveWeights`) one failed run in 40 costs 2.5, as much as 2.5 cm of p90
cross-track error: a setting that breaks the gate on a scenario is not bought back by tracking better on the others.
A millimetre of p90 costs 0.1; finishing 10 % later costs 0.1. A fuzz file's ``[objective]`` table sets the weights.
The largest cross-track error of a run is ``cross_track_error_max_joined_m``: after the vehicle first comes within
2 cm of the path, so that the start's own offset, which no setting changes, does not mask what follows. A run that
crashed counts as failed; its metrics are missing and left out of the percentiles. The completion time is
``completion_time_s`` (:func:`~agvctl.evaluation.metrics.closed_loop_metrics`): when the vehicle stays within 2 cm
of the path's end; a run that never does counts as taking :data:`NEVER_DONE_RATIO` times the reference's duration.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from agvctl.config import check_fields, document_fields, number
from agvctl.errors import ConfigError
from agvctl.fuzz.report import FuzzOutcome

__all__ = ["NEVER_DONE_RATIO", "ObjectiveValue", "ObjectiveWeights", "evaluate_objective"]

NEVER_DONE_RATIO = 3.0
"""The completion-time ratio of a run that never settles at the path's end (the loop stops it by about twice the
reference's duration plus its settling time)."""


@document_fields
@dataclass(frozen=True)
class ObjectiveWeights:
    """The weights of the objective (a fuzz file's ``[objective]`` table)."""

    gate: float = number(
        ge=0, default=100.0, doc="Per unit of the share of runs that fail the gate (crashes included)."
    )
    cross_track_p90: float = number(
        ge=0,
        default=1.0,
        doc="Per centimetre of the 90th percentile of the runs' largest cross-track errors once on the path.",
    )
    cross_track_rms: float = number(
        ge=0, default=1.0, doc="Per centimetre of the cross-track error's RMS over all runs."
    )
    time: float = number(
        ge=0, default=1.0, doc="Per unit of the mean ratio of completion time to the reference's duration, above 1."
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def describe(self) -> str:
        """The objective with these weights, in one line."""
        return (
            f"{self.gate:g} × failed share + {self.cross_track_p90:g} × p90 max cross-track once on the path/cm + "
            f"{self.cross_track_rms:g} × cross-track RMS/cm + {self.time:g} × (completion time/duration − 1)"
        )


@dataclass(frozen=True)
class ObjectiveValue:
    """The objective over a set of runs and the figures it is made of.

    Parameters
    ----------
    value : float
        J, lower is better.
    runs, passed : int
        How many runs, and how many passed the gate.
    cross_track_p50_m, cross_track_p90_m, cross_track_max_m : float
        Percentiles of the runs' largest cross-track errors once on the path, m (NaN if no run finished).
    cross_track_rms_m : float
        RMS of the cross-track error over all finished runs, m.
    time_ratio : float
        Mean of completion time / reference duration.
    """

    value: float
    runs: int
    passed: int
    cross_track_p50_m: float
    cross_track_p90_m: float
    cross_track_max_m: float
    cross_track_rms_m: float
    time_ratio: float

    def as_dict(self) -> dict[str, float]:
        """The figures by name (for JSON)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def describe(self) -> str:
        """``J 1.23: 39/40 passed, cross-track p50/p90/max 4.1/9.8/21 mm, RMS 2.0 mm, time ×1.05``."""
        mm = [1e3 * v for v in (self.cross_track_p50_m, self.cross_track_p90_m, self.cross_track_max_m)]
        return (
            f"J {self.value:.3f}: {self.passed}/{self.runs} passed, cross-track p50/p90/max "
            f"{mm[0]:.1f}/{mm[1]:.1f}/{mm[2]:.1f} mm, RMS {1e3 * self.cross_track_rms_m:.1f} mm, "
            f"time ×{self.time_ratio:.3f}"
        )


def _time_ratio(outcome: FuzzOutcome) -> float:
    done, duration = outcome.value("completion_time_s"), outcome.value("reference_duration_s")
    if not math.isfinite(done) or not duration > 0:
        return NEVER_DONE_RATIO
    return min(max(done / duration, 1.0), NEVER_DONE_RATIO)


def evaluate_objective(outcomes: Sequence[FuzzOutcome], weights: ObjectiveWeights) -> ObjectiveValue:
    """The objective of ``outcomes`` (one controller's runs) with ``weights`` (see the module notes).

    Parameters
    ----------
    outcomes : sequence of FuzzOutcome
        The runs, from :func:`~agvctl.fuzz.run.run_fuzz_task`.
    weights : ObjectiveWeights
        The weights.

    Returns
    -------
    ObjectiveValue
        J and its figures; with no finished run, J is the gate's full weight plus 10 per cross-track term.

    Raises
    ------
    ConfigError
        ``evaluate_objective: <argument>: <problem>``: no runs, or arguments of the wrong type.
    """
    if isinstance(outcomes, (str, bytes)) or not isinstance(outcomes, Sequence) or not outcomes:
        raise ConfigError(
            "evaluate_objective", "outcomes", f"expected a non-empty sequence of runs (got {outcomes!r:.60})"
        )
    if not all(isinstance(o, FuzzOutcome) for o in outcomes):
        raise ConfigError("evaluate_objective", "outcomes", "expected FuzzOutcome runs")
    if not isinstance(weights, ObjectiveWeights):
        raise ConfigError("evaluate_objective", "weights", f"expected ObjectiveWeights (got {weights!r:.60})")
    passed = sum(o.passed for o in outcomes)
    finished = [o for o in outcomes if o.error is None and o.metrics]
    peak = np.array([o.value("cross_track_error_max_joined_m") for o in finished])
    rms = np.array([o.value("cross_track_error_rms_m") for o in finished])
    peak, rms = peak[np.isfinite(peak)], rms[np.isfinite(rms)]
    failed_share = 1.0 - passed / len(outcomes)
    if peak.size == 0 or rms.size == 0:
        nan = math.nan
        value = weights.gate + 10.0 * (weights.cross_track_p90 + weights.cross_track_rms) + weights.time
        return ObjectiveValue(value, len(outcomes), passed, nan, nan, nan, nan, NEVER_DONE_RATIO)
    p50, p90 = (float(np.percentile(peak, q)) for q in (50, 90))
    rms_all = float(np.sqrt(np.mean(rms**2)))
    time_ratio = float(np.mean([_time_ratio(o) for o in outcomes]))
    value = (
        weights.gate * failed_share
        + weights.cross_track_p90 * p90 / 0.01
        + weights.cross_track_rms * rms_all / 0.01
        + weights.time * (time_ratio - 1.0)
    )
    return ObjectiveValue(value, len(outcomes), passed, p50, p90, float(np.max(peak)), rms_all, time_ratio)
