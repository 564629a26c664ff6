"""Writing a closed-loop run's outputs: log, summary, the resolved scenario, plots."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.config import dump_toml, to_dict
from agvctl.config.references import absolute_reference
from agvctl.estimation.base import CALIBRATION_COLUMNS
from agvctl.estimation.calibration import calibrated_vehicle
from agvctl.fileio import write_text
from agvctl.plots import save_closed_loop_plots
from agvctl.scenario.experiment import Experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = [
    "CALIBRATED_VEHICLE_FILE",
    "RUN_FILES",
    "calibrated_vehicle_toml",
    "resolved_experiment_toml",
    "write_run_outputs",
]

RUN_FILES = ("log.csv", "summary.json", "experiment.toml", "plant_vehicle.toml")
"""The files :func:`write_run_outputs` writes into the output directory besides the plots."""
CALIBRATED_VEHICLE_FILE = "calibrated_vehicle.toml"
"""The controller's vehicle with the odometry calibration the pose estimator learnt, written by
:func:`write_run_outputs` when it learnt one (``localization = "ekf"``)."""


def calibrated_vehicle_toml(experiment: Experiment, result: ClosedLoopResult) -> str | None:
    """The text of :data:`CALIBRATED_VEHICLE_FILE`: the controller's vehicle with the radii and wheel base the
    estimator ended the run with and its tolerances narrowed to 3σ
    (:func:`~agvctl.estimation.calibration.calibrated_vehicle`), a header saying how they were obtained.

    Parameters
    ----------
    experiment : Experiment
        The experiment that was run.
    result : ClosedLoopResult
        Its run, whose log holds the estimator's calibration columns.

    Returns
    -------
    str or None
        The vehicle file's text; None for a run whose estimator learns no calibration.
    """
    log = result.log
    eps, sig = (
        np.array([float(log[c][-1]) for c in names]) for names in (CALIBRATION_COLUMNS[:3], CALIBRATION_COLUMNS[3:6])
    )
    if not np.all(np.isfinite(eps)):
        return None
    vehicle = calibrated_vehicle(experiment.controller_vehicle, eps, sig)
    w = vehicle.wheels
    header = "\n".join(
        [
            f"'{vehicle.name}' calibrated online by the pose EKF in the run of {experiment.spec.name}",
            f"({result.n_samples * result.sample_period_s:.1f} s, from {experiment.spec.source}): the wheel radii and",
            "wheel base it learnt from the position fixes, tolerances narrowed to 3 sigma of its estimate:",
            f"r_l = {w.left.radius_m:.6g} m, r_r = {w.right.radius_m:.6g} m, b = {w.separation_m:.6g} m.",
        ]
    )
    return dump_toml(to_dict(vehicle), header=header)


def resolved_experiment_toml(experiment: Experiment) -> str:
    """The experiment's file as it was run: every key with its value, the trajectory and vehicle files (and the
    Python files it names code in) by their absolute paths, headed by the file it was resolved from.

    Parameters
    ----------
    experiment : Experiment
        The loaded experiment.

    Returns
    -------
    str
        The TOML text written as a run's ``experiment.toml``.
    """
    exp = experiment.spec
    resolved = to_dict(exp)
    resolved["trajectory"] = str(exp.resolve(exp.trajectory).resolve())
    if exp.vehicle != "default":
        resolved["vehicle"] = str(exp.resolve(exp.vehicle).resolve())
    for key in ("pose", "wheel_loops", "localization", "wheel_speed"):
        resolved["controller"][key] = absolute_reference(resolved["controller"][key], exp.base_dir)
    header = f"resolved from {exp.source}"
    if experiment.vehicle_overrides:
        header += f", its vehicle changed by --set {' --set '.join(experiment.vehicle_overrides)}"
    return dump_toml(resolved, header=header)


def write_run_outputs(
    experiment: Experiment,
    result: ClosedLoopResult,
    summary: dict[str, Any],
    out_dir: Path,
    *,
    plots: bool = True,
) -> list[Path]:
    """Write a closed-loop run's outputs into a folder.

    The outputs are ``log.csv``, ``summary.json``, the resolved ``experiment.toml``, the true vehicle, the
    calibrated one (:data:`CALIBRATED_VEHICLE_FILE`, when the estimator learnt a calibration) and the plots. Every
    text is made before the first file is written, and each file is written atomically.

    Parameters
    ----------
    experiment : Experiment
        The experiment that was run.
    result : ClosedLoopResult
        Its run.
    summary : dict
        The run's summary (``agvctl run`` gives :func:`~agvctl.checks.summary.run_summary`), written as JSON; its
        ``limits`` give the wheel-acceleration bound the plots draw.
    out_dir : Path
        The folder, made if missing.
    plots : bool
        Whether to draw the plots too.

    Returns
    -------
    list of Path
        The files written.
    """
    exp = experiment.spec
    texts = {
        "summary.json": json.dumps(summary, indent=2) + "\n",
        "experiment.toml": resolved_experiment_toml(experiment),
        "plant_vehicle.toml": dump_toml(to_dict(experiment.plant_vehicle), header="the simulated truth of this run"),
    }
    calibrated = calibrated_vehicle_toml(experiment, result)
    if calibrated is not None:
        texts[CALIBRATED_VEHICLE_FILE] = calibrated
    out_dir.mkdir(parents=True, exist_ok=True)
    result.log.to_csv(out_dir / "log.csv")
    for name, text in texts.items():
        write_text(out_dir / name, text)
    written = [out_dir / "log.csv", *(out_dir / name for name in texts)]
    if plots:
        gate = {r["limit"]: r["bound"] for r in summary.get("limits", ())}
        written += save_closed_loop_plots(
            result.log,
            experiment.controller_vehicle,
            out_dir,
            title=exp.name,
            wheel_accel_bound_m_s2=gate.get("peak_wheel_accel_m_s2"),
            drawn_path=experiment.reference.drawn_path,
        )
    return written
