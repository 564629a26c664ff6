"""The summary of a closed-loop run (``summary.json``): metrics and every limit's verdict."""

from __future__ import annotations

from typing import Any

from agvctl.estimation.calibration import calibration_summary
from agvctl.evaluation.limits import judge_run
from agvctl.fileio import json_safe
from agvctl.scenario.experiment import Experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = ["SUMMARY_METRICS", "run_summary"]

SUMMARY_METRICS = (
    "tracking_error_rms_m",
    "tracking_error_max_m",
    "heading_error_max_deg",
    "final_position_error_m",
    "cross_track_error_max_m",
    "cross_track_error_rms_m",
    "along_track_lag_max_m",
    "path_heading_error_max_deg",
    "peak_wheel_accel_m_s2",
    "wheel_speed_error_max_m_s",
    "peak_motor_current_a",
    "da_saturation_fraction",
    "current_limited_fraction",
    "solve_time_p50_ms",
    "solve_time_p99_ms",
    "solver_failures",
    "non_finite_commands",
)


def run_summary(experiment: Experiment, result: ClosedLoopResult) -> dict[str, Any]:
    """The summary of a closed-loop run, written as ``summary.json``: metrics and every limit's verdict.

    Parameters
    ----------
    experiment : Experiment
        The experiment that was run: its limits and vehicles.
    result : ClosedLoopResult
        Its run.

    Returns
    -------
    dict
        ``experiment``, ``passed``, ``metrics`` (:data:`SUMMARY_METRICS` first; NaN as None), ``wall_time_s``,
        ``setup_time_s``, ``simulated_s``, ``limits`` (each limit's and requirement's verdict, with its margin, the time
        of its worst point and its window), ``min_normalised_margin`` (the smallest margin over its bound,
        :func:`~agvctl.evaluation.limits.smallest_normalised_margin`; negative: the run failed), and with an
        estimator that learns the odometry calibration its ``calibration`` against the plant's truth
        (:func:`~agvctl.estimation.calibration.calibration_summary`).
    """
    exp = experiment.spec
    verdict = judge_run(result, exp.limits, experiment.controller_vehicle, exp.requirements)
    ordered = {k: verdict.metrics[k] for k in SUMMARY_METRICS}
    ordered.update({k: v for k, v in verdict.metrics.items() if k not in ordered})
    calibration = calibration_summary(result.log, experiment.controller_vehicle, experiment.plant_vehicle)
    return {
        "experiment": exp.name,
        "passed": verdict.passed,
        "min_normalised_margin": json_safe({"m": verdict.min_normalised_margin})["m"],
        "metrics": json_safe(ordered),
        "wall_time_s": result.wall_time_s,
        "setup_time_s": result.setup_time_s,
        "loop": result.loop,
        "simulated_s": result.n_samples * result.sample_period_s,
        "limits": [r.as_dict() for r in verdict.limits],
        **({"calibration": {k: json_safe(v) for k, v in calibration.items()}} if calibration is not None else {}),
    }
