"""Online calibration by the pose EKF against UMBmark (appendix A.1), on the same plant.

The plant: the right wheel 1 % larger and the wheel base 2 % wider than the vehicle file says (the edges of its
tolerances). UMBmark (Borenstein & Feng): four-metre squares driven cw and ccw on odometry, five runs each, the end
positions measured to 3 mm; it gives the radius ratio and the wheel base. The EKF: one figure-8 on the MPC with
its default sensors (fixes at 4 Hz, 1 cm, 0.5°), ``sensor_seed`` 1…N; it gives both radii and the wheel base, and
their σ. Printed: each method's estimate against the truth, in % of the truth.

Run:  python experiments/calibration_comparison.py [--seeds 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

from agvctl.calibration import UmbmarkConfig, simulate_umbmark
from agvctl.estimation.calibration import calibration_summary
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENT = Path(__file__).resolve().parent / "figure8_ekf.toml"
PLANT = ["wheels.right.radius_m=0.101", f"wheels.separation_m={0.54 * 1.02!r}"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    exp = load_experiment(EXPERIMENT)
    believed, truth = exp.controller_vehicle, exp.plant_vehicle.with_overrides(PLANT)
    true_ratio = truth.wheels.right.radius_m / truth.wheels.left.radius_m
    true_b = truth.wheels.separation_m
    print(f"truth: r_r/r_l = {true_ratio:.5f}, b = {true_b:.5f} m (believed 1, {believed.wheels.separation_m} m)")
    print(f"{'method':<34} {'r_r/r_l error':>14} {'b error':>10} {'r_l error':>10} {'r_r error':>10}")
    for seed in range(args.seeds):
        u = simulate_umbmark(truth, believed, UmbmarkConfig(), noise_scale=1.0, seed=seed).correction
        ratio_err = (u.wheel_radius_ratio.estimate / true_ratio - 1) * 100
        b_err = (u.separation_m.estimate / true_b - 1) * 100
        print(f"{'UMBmark, 4 m squares, seed ' + str(seed):<34} {ratio_err:>13.3f}% {b_err:>9.3f}%")
    for seed in range(1, args.seeds + 1):
        plant = dataclasses.replace(exp.spec.plant, sensor_seed=seed)
        e = dataclasses.replace(exp, plant_vehicle=truth, spec=dataclasses.replace(exp.spec, plant=plant))
        cal = calibration_summary(run_experiment(e).log, believed, truth)
        assert cal is not None
        rl, rr, b = (cal[k] for k in ("wheels.left.radius_m", "wheels.right.radius_m", "wheels.separation_m"))
        ratio_err = ((rr["estimate"] / rl["estimate"]) / true_ratio - 1) * 100
        errs = [(c["estimate"] / c["truth"] - 1) * 100 for c in (b, rl, rr)]
        print(
            f"{'EKF, one figure-8, sensor seed ' + str(seed):<34} {ratio_err:>13.3f}% {errs[0]:>9.3f}% "
            f"{errs[1]:>9.3f}% {errs[2]:>9.3f}%   (σ {b['sigma'] / b['truth'] * 100:.3f}% on b)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
