"""How far the default controller's start transient is from an ideal one, on the acceptance fuzz scenarios.

Over the 500 acceptance scenarios the MPC's RMS tracking error is decided in the first seconds, while it removes a
start offset of up to 5 cm and 5°. This script bounds what any controller could do there. For every
``--every``-th scenario it runs the default controller, then solves an optimal control problem (CasADi, IPOPT): the
unicycle of eqs 39-43 from the same start pose at rest, its wheel accelerations free within ±``--accel`` (eq 5's
a_lim by default; the lightest, least frictional plant of the envelope reaches about 1.0 m/s², so ``--accel 1.2``
gives a bound valid for every plant) and its wheel speeds within the DA's top speed, minimising the squared
position error against the time-indexed reference over the first ``--horizon`` seconds, with no condition at the
end. No loop lag, friction or model error: no real run can do better over those seconds, and every run's error
after them is at least zero, so sqrt(optimum / samples of the run) bounds its RMS tracking error from below.

Prints, over the scenarios, the median RMS of the MPC and of the bound, and the median ratio of the MPC's squared
error in the first seconds to the optimum.

Run:  python experiments/fuzz/ideal_start.py [--every 10] [--seed 10] [--accel 0.657] [--jobs 2]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import casadi as ca
import numpy as np

from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment

CONFIG = Path(__file__).resolve().parent / "acceptance.toml"


def ideal_squared_error(exp: Experiment, start_pose: tuple[float, float, float], samples: int, accel: float) -> float:
    """min Σ_k |p_k − p_ref,k|² over k = 0 … samples for the unicycle with wheel accelerations within ±accel."""
    vehicle = exp.controller_vehicle
    ts = vehicle.control.sample_period_s
    b = vehicle.wheels.separation_m * 0.98  # the envelope's narrowest separation turns fastest
    ref = exp.reference.sample(np.arange(samples + 1) * ts)
    opti = ca.Opti()
    state = opti.variable(5, samples + 1)  # x, y, θ, v_l, v_r
    accel_lr = opti.variable(2, samples)
    opti.subject_to(state[:, 0] == ca.DM([*start_pose, 0.0, 0.0]))

    def rate(z: ca.MX, a: ca.MX) -> ca.MX:  # eqs 39-43 with the wheel speeds integrated
        speed, yaw_rate = 0.5 * (z[3] + z[4]), (z[4] - z[3]) / b
        return ca.vertcat(speed * ca.cos(z[2]), speed * ca.sin(z[2]), yaw_rate, a[0], a[1])

    h = 0.5 * ts
    for k in range(samples):
        z = state[:, k]
        for _ in range(2):  # two RK4 steps per sample
            k1 = rate(z, accel_lr[:, k])
            k2 = rate(z + 0.5 * h * k1, accel_lr[:, k])
            k3 = rate(z + 0.5 * h * k2, accel_lr[:, k])
            k4 = rate(z + h * k3, accel_lr[:, k])
            z = z + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        opti.subject_to(state[:, k + 1] == z)
    top = vehicle.derived.max_speed_m_s
    opti.subject_to(opti.bounded(-accel, ca.vec(accel_lr), accel))
    opti.subject_to(opti.bounded(-top, ca.vec(state[3:5, :]), top))
    rx, ry = ca.DM(ref.x_m).T, ca.DM(ref.y_m).T
    cost = ca.sumsqr(state[0, :] - rx) + ca.sumsqr(state[1, :] - ry)
    opti.minimize(cost)
    opti.set_initial(state[0, :], rx)
    opti.set_initial(state[1, :], ry)
    opti.set_initial(state[2, :], ca.DM(ref.theta_rad).T)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "max_iter": 3000, "tol": 1e-10, "sb": "yes"})
    try:
        return float(opti.solve().value(cost))
    except RuntimeError:  # not converged: its last iterate is feasible-ish; report it, flagged by NaN
        return math.nan


def one(task: tuple[int, int, float, float]) -> dict[str, float]:
    index, seed, accel, horizon_s = task
    warnings.simplefilter("ignore")  # explicit limits without headroom warn; they are part of the scenario
    spec = dataclasses.replace(load_fuzz_config(CONFIG), seed=seed)
    scenario = generate_scenario(spec, load_vehicle(), index)
    with tempfile.TemporaryDirectory() as tmp:
        files = scenario_files(spec, scenario, "mpc")
        for name, text in files.items():
            (Path(tmp) / name).write_text(text, encoding="utf-8")
        exp = load_experiment(Path(tmp) / next(n for n in files if n.endswith("_mpc.toml")))
        log = run_experiment(exp).log
    squared = (log["x_m"] - log["ref_x_m"]) ** 2 + (log["y_m"] - log["ref_y_m"]) ** 2
    samples = round(horizon_s / exp.controller_vehicle.control.sample_period_s)
    start = (float(log["x_m"][0]), float(log["y_m"][0]), float(log["theta_rad"][0]))
    ideal = ideal_squared_error(exp, start, samples, accel)
    n = len(squared)
    return {
        "scenario": index,
        "mpc_rms_m": float(np.sqrt(np.mean(squared))),
        "bound_rms_m": math.sqrt(ideal / n),
        "mpc_start": float(np.sum(squared[: samples + 1])),
        "ideal_start": ideal,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--every", type=int, default=10, help="every N-th scenario of the 500 (default 10)")
    parser.add_argument("--seed", type=int, default=10)
    parser.add_argument("--accel", type=float, default=None, help="wheel acceleration bound, m/s² (default a_lim)")
    parser.add_argument("--horizon", type=float, default=4.0, help="seconds of the start compared (default 4)")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    accel = args.accel if args.accel is not None else load_vehicle().derived.accel_limit_m_s2
    tasks = [(i, args.seed, accel, args.horizon) for i in range(0, 500, args.every)]
    rows = []
    with ProcessPoolExecutor(args.jobs) as pool:
        for k, row in enumerate(pool.map(one, tasks), 1):
            rows.append(row)
            print(f"\r{k}/{len(tasks)} scenarios", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    ok = [r for r in rows if math.isfinite(r["ideal_start"]) and r["ideal_start"] > 0]
    mpc = np.median([r["mpc_rms_m"] for r in rows])
    bound = np.median([r["bound_rms_m"] for r in ok])
    ratio = np.median([r["mpc_start"] / r["ideal_start"] for r in ok])
    print(f"{len(rows)} scenarios (seed {args.seed}, every {args.every}), wheel accelerations within ±{accel:.3f} m/s²")
    print(f"  median RMS tracking error: default controller {mpc * 1e3:.2f} mm, ideal start {bound * 1e3:.2f} mm")
    print(f"  squared error in the first {args.horizon:g} s, controller / ideal: median {ratio:.2f}")
    if len(ok) < len(rows):
        print(f"  {len(rows) - len(ok)} optimal control problems did not converge (left out)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
