"""The estimation's acceptance figures: the EKF figure-8 against odometry alone, its consistency (NEES) over
seeded Monte Carlo runs with and without the latency handling, the wheel-speed estimators, and the wheel loops at
rest.

1. ``figure8_ekf.toml`` and ``figure8_odometry.toml``: tracking and estimate errors against the truth.
2. NEES: ``--runs`` closed loops of ``figure8_ekf.toml``, each with its own ``[plant] sensor_seed`` (encoder
   phases, fix noise), the EKF started at the true pose as the loop does. The average NEES over the runs at a
   sample is chi-square(3·runs)/runs for a consistent filter; its 95 % interval is printed with the mean over the
   run (t >= 2 s, after the first fixes) and the share of samples inside it. The same with the fixes applied on
   arrival as if just measured (latency ignored), offline on the same logs (``agvctl.estimation.offline.filter_log``).
3. Motor-speed error against the truth at the sample instants: Kalman filter vs count difference.
4. DA code changes per second at rest (the last 2 s of a 4 s settle after the line): the wheel loops alone
   (feed-forward pose controller, setpoints zero) and the whole cascade (MPC on the EKF, on the truth).
5. Low speed: the wheel loops alone on a 5 mm/s line (1.8 rad/s at the motor): DA code changes per second, the
   true wheel speed's mean and ripple, and whether a wheel ever stops (stick-slip).

Run:  python experiments/estimation_consistency.py [--runs 50]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.pi.tuning import default_pi_gains
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.estimation.ekf import EkfSettings
from agvctl.estimation.offline import filter_log
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.params import VehicleParams
from agvctl.planning import LineSegment, WheelLimits, plan_segments
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment
from agvctl.sim.loop import run_closed_loop

HERE = Path(__file__).resolve().parent


def variant(
    exp: Experiment, *, settle_s: float | None = None, sensor_seed: int | None = None, **c: object
) -> Experiment:
    controller = dataclasses.replace(exp.spec.controller, **c)
    plant = exp.spec.plant if sensor_seed is None else dataclasses.replace(exp.spec.plant, sensor_seed=sensor_seed)
    settle = exp.spec.settle_s if settle_s is None else settle_s
    return dataclasses.replace(
        exp, spec=dataclasses.replace(exp.spec, controller=controller, plant=plant, settle_s=settle)
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=50)
    args = ap.parse_args()

    print("1. figure-8, right wheel 0.5 % larger than believed, default sensors (fixes 4 Hz, 1 cm, 0.5°, 50 ms)")
    for name in ("figure8_ekf", "figure8_odometry"):
        m = closed_loop_metrics(run_experiment(load_experiment(HERE / f"{name}.toml")))
        mm = {k: v * 1e3 for k, v in m.items() if k.endswith("_m")}
        print(
            f"   {name:17} tracking rms {mm['tracking_error_rms_m']:6.2f} mm  max {mm['tracking_error_max_m']:6.2f} mm"
            f"   estimate rms {mm['estimate_error_rms_m']:6.2f} mm  max {mm['estimate_error_max_m']:6.2f} mm"
        )

    exp = load_experiment(HERE / "figure8_ekf.toml")
    n = args.runs
    lo, hi = chi2.ppf([0.025, 0.975], 3 * n) / n
    logs = [run_experiment(variant(exp, sensor_seed=100 + i)).log for i in range(n)]
    keep = logs[0]["t_s"] >= 2.0
    print(f"2. average NEES over {n} closed-loop runs (3 dof; 95 % interval [{lo:.2f}, {hi:.2f}])")
    ignored = EkfSettings(latency_compensation=False)
    for label, nees in (
        ("latency replayed (the loop)", [log["nees"] for log in logs]),
        ("latency ignored (offline)", [filter_log(log, exp.controller_vehicle, ignored)["nees"] for log in logs]),
    ):
        anees = np.mean(nees, axis=0)[keep]
        inside = np.mean((anees >= lo) & (anees <= hi))
        print(f"   {label:28} mean {anees.mean():8.2f}   samples inside the interval {inside * 100:5.1f} %")

    print("3. motor-speed error (left) against the truth at t_k, figure8_ekf")
    for wheel_speed in ("kalman", "count_difference"):
        log = run_experiment(variant(exp, wheel_speed=wheel_speed)).log
        err = log["measured_omega_motor_left_rad_s"] - log["omega_motor_left_rad_s"]
        print(f"   {wheel_speed:17} rms {np.sqrt(np.mean(err**2)):.3f} rad/s   max {np.max(np.abs(err)):.3f} rad/s")

    print("4. DA code changes per second at rest (both wheels, last 2 s of a 4 s settle after line.toml)")
    line = load_experiment(HERE / "line.toml")
    for pose, localization, wheel_speed in (
        ("none", "truth", "kalman"),
        ("none", "truth", "count_difference"),
        ("mpc", "truth", "exact"),
        ("mpc", "truth", "kalman"),
        ("mpc", "ekf", "kalman"),
    ):
        e = variant(line, settle_s=4.0, pose=pose, localization=localization, wheel_speed=wheel_speed)
        if pose == "none":
            e = variant(e, pose_settings=None)
        log = run_experiment(e).log
        rest = log["t_s"] >= line.reference.duration_s + 2.0
        changes = sum(np.count_nonzero(np.diff(log[f"da_code_{s}"][rest])) for s in ("left", "right"))
        seconds = log["t_s"][rest][-1] - log["t_s"][rest][0]
        setting = f"pose = {pose!r:6} localization = {localization!r:7} wheel_speed = {wheel_speed!r:18}"
        print(f"   {setting} {changes / seconds:6.1f} /s")
    low_speed(load_experiment(HERE / "line.toml").controller_vehicle)
    return 0


def low_speed(vehicle: VehicleParams, speed_m_s: float = 0.005) -> None:
    limits = WheelLimits(wheel_speed_m_s=0.8, wheel_accel_m_s2=0.5, wheel_jerk_m_s3=3.0)
    segment = LineSegment(length_m=10 * speed_m_s, speed_m_s=speed_m_s)
    ref = plan_segments([segment], limits=limits, separation_m=vehicle.wheels.separation_m, sample_period_s=0.04)
    gains, _tau = default_pi_gains(vehicle)
    print(f"5. wheel loops alone at {speed_m_s * 1e3:g} mm/s (feed-forward pose controller; the cruise, left wheel)")
    for wheel_speed in ("exact", "kalman", "count_difference"):
        log = run_closed_loop(
            plant_vehicle=vehicle,
            controller_vehicle=vehicle,
            reference=ref,
            pose_controller=FeedForwardPoseController(),
            wheel_controller=PIWheelController(vehicle, gains),
            wheel_speed=wheel_speed,
        ).log
        t = log["t_s"]
        cruise = (t > 2.0) & (t < ref.duration_s - 2.0)
        changes = np.count_nonzero(np.diff(log["da_code_left"][cruise])) / (t[cruise][-1] - t[cruise][0])
        w = log["wheel_speed_left_m_s"][cruise] * 1e3
        print(
            f"   {wheel_speed:17} DA code changes {changes:5.1f} /s   speed {w.mean():.2f} mm/s ± {w.std():.3f} "
            f"(std)   stopped {np.count_nonzero(w == 0)} samples"
        )


if __name__ == "__main__":
    sys.exit(main())
