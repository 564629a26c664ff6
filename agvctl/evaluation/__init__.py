"""Evaluation: how a run is judged, from its log alone.

* :mod:`~agvctl.evaluation.limits` — the table of limits (name, metric, series, unit), an experiment's
  ``[limits]`` and the verdict of each limit on a run.
* :mod:`~agvctl.evaluation.metrics` — the figures of merit of a closed-loop run (``summary.json``'s ``metrics``).
* :mod:`~agvctl.evaluation.path_metrics` — errors against the reference *path* (cross-track, along-track lag,
  path heading), separating being off the path from being behind the clock.
"""

from agvctl.evaluation.limits import LIMITS, Limit, LimitResult, LimitsSpec, all_passed, evaluate_limits
from agvctl.evaluation.metrics import RunRecord, closed_loop_metrics, estimate_metrics
from agvctl.evaluation.path_metrics import PATH_LOG_COLUMNS, PathErrors, ReferencePath, path_errors

__all__ = [
    "LIMITS",
    "PATH_LOG_COLUMNS",
    "Limit",
    "LimitResult",
    "LimitsSpec",
    "PathErrors",
    "ReferencePath",
    "RunRecord",
    "all_passed",
    "closed_loop_metrics",
    "estimate_metrics",
    "evaluate_limits",
    "path_errors",
]
