"""Evaluation: how a run is judged, from its log alone.

* :mod:`~agvctl.evaluation.signals` — a metric as a per-sample signal and a reduction
  (:class:`~agvctl.evaluation.signals.Metric`).
* :mod:`~agvctl.evaluation.metrics` — the figures of merit of a closed-loop run (``summary.json``'s ``metrics``),
  each a metric of :data:`~agvctl.evaluation.metrics.METRICS` but a few settling times and the estimator's
  consistency.
* :mod:`~agvctl.evaluation.limits` — the table of limits (each the name of a metric it bounds), an experiment's
  ``[limits]`` and the verdict of each limit on a run.
* :mod:`~agvctl.evaluation.path_metrics` — errors against the reference *path* (cross-track, along-track lag,
  path heading), separating being off the path from being behind the clock.
"""

from agvctl.evaluation.limits import (
    LIMITS,
    Limit,
    LimitResult,
    LimitsSpec,
    RunVerdict,
    all_passed,
    evaluate_limits,
    judge_run,
)
from agvctl.evaluation.metrics import METRICS, RunRecord, closed_loop_metrics, estimate_metrics
from agvctl.evaluation.path_metrics import PATH_LOG_COLUMNS, PathErrors, ReferencePath, path_errors
from agvctl.evaluation.signals import Metric, Reduction

__all__ = [
    "LIMITS",
    "METRICS",
    "PATH_LOG_COLUMNS",
    "Limit",
    "LimitResult",
    "LimitsSpec",
    "Metric",
    "PathErrors",
    "Reduction",
    "ReferencePath",
    "RunRecord",
    "RunVerdict",
    "all_passed",
    "closed_loop_metrics",
    "estimate_metrics",
    "evaluate_limits",
    "judge_run",
    "path_errors",
]
