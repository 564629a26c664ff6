"""Benchmark of the estimation: the pose EKF's step, the Kalman wheel-speed step, the sensors, and the closed loop
closed on estimates.

Per-step times (goal: EKF step median ≤ 30 µs) are measured on the figure-8 of ``experiments/figure8_ekf.toml``:
its logged sensor readings are replayed through each component, one call timed at a time. The closed loop is
timed as ``agvctl run`` runs it (plots excluded), with the MPC and with the reference feed-forward in its place,
each with ``localization = "ekf"``, ``wheel_speed = "kalman"`` and with the truth and exact speeds: the difference
is what estimation costs (goal: the closed loop ≥ 100x real time).

Run:  python experiments/benchmarks/estimation.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from agvctl.estimation.ekf import PoseEkf
from agvctl.estimation.offline import log_encoder_counts, log_fixes
from agvctl.estimation.wheel_speed import KalmanWheelSpeed
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment
from agvctl.sensing import Sensors

EXPERIMENT = Path(__file__).resolve().parent.parent / "figure8_ekf.toml"


def _percentiles_us(times_s: list[float]) -> str:
    p50, p99 = np.percentile(np.array(times_s) * 1e6, [50, 99])
    return f"median {p50:6.1f} µs   p99 {p99:6.1f} µs"


def _variant(exp: Experiment, **controller: object) -> Experiment:
    c = dataclasses.replace(exp.spec.controller, **controller)
    return dataclasses.replace(exp, spec=dataclasses.replace(exp.spec, controller=c))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    exp = load_experiment(EXPERIMENT)
    log = run_experiment(exp).log  # also the warm-up: the compiled plant and OSQP set up once
    vehicle, ts = exp.controller_vehicle, exp.controller_vehicle.control.sample_period_s
    counts, gyro, fixes = log_encoder_counts(log), log["gyro_rate_rad_s"], log_fixes(log, ts)
    n = len(log)

    ekf_times: list[float] = []
    fix_times: list[float] = []
    for _ in range(args.repeat):
        ekf = PoseEkf(vehicle)
        ekf.reset(np.array([log["x_m"][0], log["y_m"][0], log["theta_rad"][0]]))
        for k in range(n):
            t0 = time.perf_counter()
            ekf.step(k, counts[k], float(gyro[k]), fixes[k])
            (fix_times if fixes[k] else ekf_times).append(time.perf_counter() - t0)
    speed_times: list[float] = []
    sensor_times: list[float] = []
    angles = np.column_stack([log["motor_angle_left_rad"], log["motor_angle_right_rad"]])
    poses = np.column_stack([log["x_m"], log["y_m"], log["theta_rad"]])
    da = np.column_stack([log["da_command_left_v"], log["da_command_right_v"]])
    for _ in range(args.repeat):
        kf, sensors = KalmanWheelSpeed(vehicle), Sensors(exp.plant_vehicle, seed=0)
        for k in range(n):
            t0 = time.perf_counter()
            c = sensors.encoder_counts(angles[k])
            sensors.read(k, c, poses[k], np.zeros(2))
            t1 = time.perf_counter()
            kf.update(c)
            kf.applied(da[k])
            t2 = time.perf_counter()
            sensor_times.append(t1 - t0)
            speed_times.append(t2 - t1)

    print(f"per sample, figure-8 of {EXPERIMENT.name} ({n} samples x {args.repeat}; one call timed at a time)")
    print(f"  EKF step, odometry only           {_percentiles_us(ekf_times)}   (goal: median <= 30 µs)")
    print(f"  EKF step with a late fix (replay) {_percentiles_us(fix_times)}   ({len(fix_times) // args.repeat} fixes)")
    print(f"  Kalman wheel speeds (both)        {_percentiles_us(speed_times)}")
    print(f"  sensors (counts, gyro, fixes)     {_percentiles_us(sensor_times)}")

    simulated = (n - 1) * ts
    print(f"closed loop, {simulated:.1f} s simulated (plots excluded; median and best of {args.repeat} runs)")
    for pose in ("mpc", "none"):
        for localization, wheel_speed in (("truth", "exact"), ("ekf", "kalman")):
            e = _variant(exp, pose=pose, localization=localization, wheel_speed=wheel_speed)
            if pose == "none":
                e = _variant(e, pose_settings=None)
            walls = [run_experiment(e).wall_time_s for _ in range(args.repeat)]
            wall, best = statistics.median(walls), min(walls)
            print(
                f"  pose = {pose!r:6} localization = {localization!r:7} wheel_speed = {wheel_speed!r:8} "
                f"wall {wall:.3f} s = {simulated / wall:4.0f}x real time (best {best:.3f} s = {simulated / best:4.0f}x)"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
