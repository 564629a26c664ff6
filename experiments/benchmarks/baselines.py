"""Yardsticks: WPILib's Ramsete and LTV unicycle laws against the default MPC, in the same closed loop.

Each pose controller drops into the same cascade (the experiment's PI wheel loops, DA/amplifier, full plant) on:

- the shipped ``figure8`` and ``figure8_offpath`` experiments;
- an untuned scenario: a short line (0.3 m), two opposite 35° arcs (radius 2 m) and a full circle
  (radius 1 m) at the default (physical) limits, the vehicle starting 3 cm / 2° off and the true right wheel
  0.8 % larger than the controller thinks (written to a temporary directory as a path and an experiment file).

Prints per run the time-indexed tracking error (RMS, max, final), the path errors (max cross-track, final
cross-track, max |along-track lag|, max |heading error| against the path) and the distance from the end of the
path at the end. No goals: these are yardsticks.

Run:  python experiments/benchmarks/baselines.py [--keep DIR]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

from agvctl.controllers.base import PoseController
from agvctl.controllers.baselines.ltv_lqr import LtvLqrController
from agvctl.controllers.baselines.ramsete import RamseteController
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.evaluation.path_metrics import path_errors
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment, run_experiment

SHIPPED = Path(__file__).resolve().parents[1]

UNTUNED_PATH = """\
# an untuned scenario: a short line, two opposite 35° arcs and a full circle, no [limits] (the defaults)
name = "untuned-line-arcs-circle"
[[segments]]
type = "line"
length_m = 0.3
[[segments]]
type = "arc"
radius_m = 2.0
angle_deg = 35
[[segments]]
type = "arc"
radius_m = 2.0
angle_deg = -35
[[segments]]
type = "arc"
radius_m = 1.0
angle_deg = 360
"""

UNTUNED_EXPERIMENT = """\
name = "untuned"
trajectory = "untuned_path.toml"
vehicle = "default"
settle_s = 2.0
[plant]
set = { "wheels.right.radius_m" = %r }
initial_pose = { x_m = 0.0, y_m = -0.03, theta_deg = 2.0 }
[controller]
pose = "mpc"
"""


def run(path: Path, which: str) -> dict[str, float]:
    experiment = load_experiment(path)
    vehicle = experiment.controller_vehicle
    pose: PoseController | None = {
        "mpc": None,  # the file's own controller
        "ramsete": RamseteController(vehicle),
        "ltv_lqr": LtvLqrController(vehicle),
    }[which]
    result = run_experiment(experiment, pose_controller=pose)
    m = closed_loop_metrics(result)
    log = result.log
    pe = path_errors(log["t_s"], log["x_m"], log["y_m"], log["theta_rad"], experiment.reference)
    end = experiment.reference.final_pose
    finite = all(
        bool(np.all(np.isfinite(log[c])))
        for c in ("x_m", "y_m", "setpoint_wheel_speed_left_m_s", "setpoint_wheel_speed_right_m_s")
    )
    return {
        "rms_mm": m["tracking_error_rms_m"] * 1e3,
        "max_mm": m["tracking_error_max_m"] * 1e3,
        "final_mm": m["final_position_error_m"] * 1e3,
        "xtrack_max_mm": float(np.max(pe.cross_track_m)) * 1e3,
        "xtrack_final_mm": float(pe.cross_track_m[-1]) * 1e3,
        "lag_max_mm": float(np.max(np.abs(pe.along_track_lag_m))) * 1e3,
        "path_heading_max_deg": math.degrees(float(np.max(np.abs(pe.heading_error_rad)))),
        "to_end_mm": math.hypot(log["x_m"][-1] - end.x_m, log["y_m"][-1] - end.y_m) * 1e3,
        "finite": float(finite),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument(
        "--keep", type=Path, help="write the untuned scenario's files to this directory (default: a temporary one)"
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        where = args.keep or Path(tmp)
        where.mkdir(parents=True, exist_ok=True)
        (where / "untuned_path.toml").write_text(UNTUNED_PATH, encoding="utf-8")
        nominal = load_vehicle().wheels.right.radius_m
        (where / "untuned.toml").write_text(UNTUNED_EXPERIMENT % (nominal * 1.008), encoding="utf-8")
        cases = [SHIPPED / "figure8.toml", SHIPPED / "figure8_offpath.toml", where / "untuned.toml"]
        header = (
            "rms_mm",
            "max_mm",
            "final_mm",
            "xtrack_max_mm",
            "xtrack_final_mm",
            "lag_max_mm",
            "path_heading_max_deg",
            "to_end_mm",
        )
        print(f"{'experiment':22s} {'pose':8s} " + " ".join(f"{h:>20s}" for h in header))
        for case in cases:
            for which in ("mpc", "ramsete", "ltv_lqr"):
                r = run(case, which)
                flag = "" if r["finite"] else "  NON-FINITE"
                print(f"{case.stem:22s} {which:8s} " + " ".join(f"{r[h]:20.2f}" for h in header) + flag)
    return 0


if __name__ == "__main__":
    sys.exit(main())
