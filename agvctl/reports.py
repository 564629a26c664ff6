"""Writing a closed-loop run's outputs: log, summary, the resolved scenario, plots."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agvctl.config import dump_toml, to_dict
from agvctl.fileio import write_text
from agvctl.plots import save_closed_loop_plots
from agvctl.scenario.experiment import Experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = ["RUN_FILES", "resolved_experiment_toml", "write_run_outputs"]

RUN_FILES = ("log.csv", "summary.json", "experiment.toml", "plant_vehicle.toml")
"""The files :func:`write_run_outputs` writes into the output directory besides the plots."""


def resolved_experiment_toml(experiment: Experiment) -> str:
    """The experiment's file as it was run: every key with its value, the trajectory and vehicle files by their
    absolute paths, headed by the file it was resolved from."""
    exp = experiment.spec
    resolved = to_dict(exp)
    resolved["trajectory"] = str(exp.resolve(exp.trajectory).resolve())
    if exp.vehicle != "default":
        resolved["vehicle"] = str(exp.resolve(exp.vehicle).resolve())
    return dump_toml(resolved, header=f"resolved from {exp.source}")


def write_run_outputs(
    experiment: Experiment,
    result: ClosedLoopResult,
    summary: dict[str, Any],
    out_dir: Path,
    *,
    plots: bool = True,
) -> list[Path]:
    """Write ``log.csv``, ``summary.json``, the resolved ``experiment.toml`` and the true vehicle, and (optionally)
    the plots. Every text is made before the first file is written, and each file is written atomically."""
    exp = experiment.spec
    texts = {
        "summary.json": json.dumps(summary, indent=2) + "\n",
        "experiment.toml": resolved_experiment_toml(experiment),
        "plant_vehicle.toml": dump_toml(to_dict(experiment.plant_vehicle), header="the simulated truth of this run"),
    }
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
            wheel_accel_bound_m_s2=gate.get("wheel_accel_m_s2"),
        )
    return written
