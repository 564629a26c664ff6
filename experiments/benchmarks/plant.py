"""Benchmark of the open-loop plant simulator: a fast, accurate open-loop simulator.

Prints, in one run on this machine:
  * 60 s of open-loop simulation (1,500 samples of 40 ms, random piecewise-constant DA inputs): wall time and
    real-time factor of agvctl's compiled simulator, with the one-time setup (compile on a cold cache, load on a
    warm one) reported apart;
  * the same 60 s through python-control's ``input_output_response`` on the same equations (the CasADi right-hand
    side), called once per sample with the input held (a zero-order hold; see TOOL-NOTES), and the speed ratio;
  * 1,000 vehicles x 60 s as one batch (parameter variants, the same inputs).

Run:  python experiments/benchmarks/plant.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

import casadi as ca
import control
import numpy as np


def row(label: str, value: str) -> None:
    print(f"  {label:<44} {value}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer repetitions, 100-vehicle batch")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    # a cold cache first, to report the one-time compile; then the same cache again (a later run's view)
    os.environ["AGVCTL_CACHE_DIR"] = tempfile.mkdtemp(prefix="agvctl-bench-cache-")
    from agvctl.actuator import Actuator
    from agvctl.params import load_vehicle
    from agvctl.plant import integrator
    from agvctl.plant.full import FullModel, parameter_vector
    from agvctl.sim import simulate_batch, simulate_open_loop

    vehicle = load_vehicle()
    ts = vehicle.control.sample_period_s
    rng = np.random.default_rng(args.seed)
    n = 1500
    da = np.repeat(rng.uniform(-5.0, 5.0, size=(n // 10, 2)), 10, axis=0)  # a new command every 0.4 s

    t0 = time.perf_counter()
    first = simulate_open_loop(vehicle, da)
    cold_total = time.perf_counter() - t0
    integrator._CACHE.clear()  # forget the in-process plant: the next setup loads the cached library from disk
    warm = simulate_open_loop(vehicle, da)
    reps = 5 if args.quick else 20
    walls = [simulate_open_loop(vehicle, da).wall_time_s for _ in range(reps)]
    wall = statistics.median(walls)
    print(f"agvctl compiled RK4 (8 substeps per 40 ms), 60 s open loop, {n} samples")
    row("cold setup (generate + compile C, cached)", f"{first.setup_time_s:8.3f} s  (first call {cold_total:.3f} s)")
    row("warm setup (load cached library)", f"{warm.setup_time_s:8.3f} s")
    row(f"wall time, median of {reps}", f"{wall * 1e3:8.2f} ms  = {60.0 / wall:,.0f}x real time")

    # python-control on the same equations: the CasADi right-hand side, input held over each sample
    model = FullModel()
    rhs = ca.Function("rhs", [model.x, model.u, model.p], [model.xdot])
    p = parameter_vector(vehicle)
    u_motor = Actuator(vehicle).apply(da).motor_voltage_v

    def updfcn(t: float, x: np.ndarray, u: np.ndarray, params: dict) -> np.ndarray:
        return np.asarray(rhs(x, u, p)).ravel()

    sys_io = control.nlsys(updfcn, None, inputs=2, outputs=5, states=5, name="agv_full")
    t0 = time.perf_counter()
    x = np.zeros(5)
    states = [x]
    for k in range(n):
        res = control.input_output_response(
            sys_io,
            [0.0, ts],
            np.column_stack([u_motor[k], u_motor[k]]),
            x,
            solve_ivp_method="RK45",
            solve_ivp_kwargs={"rtol": 1e-6, "atol": 1e-9},
        )
        x = res.states[:, -1]
        states.append(x)
    t_ioresp = time.perf_counter() - t0
    X_ref = np.array(states)
    pose_diff = np.hypot(first.log["x_m"] - X_ref[:, 2], first.log["y_m"] - X_ref[:, 3]).max()
    print("python-control input_output_response, same equations, held input (one call per sample)")
    row("wall time", f"{t_ioresp:8.3f} s")
    row("ratio python-control / agvctl", f"{t_ioresp / wall:8.0f}x")
    row("largest pose difference between the two", f"{pose_diff * 1e3:8.3f} mm")

    n_batch = 100 if args.quick else 1000
    base = vehicle
    variants = [
        base.with_overrides(
            [f"body.mass_kg={85.0 * s}", f"motor.coulomb_friction_n_m={0.055 * s}", f"motor.stiction_n_m={0.07 * s}"]
        )
        for s in rng.uniform(0.8, 1.2, size=n_batch)
    ]
    t0 = time.perf_counter()
    logs = simulate_batch(variants, da)
    t_batch = time.perf_counter() - t0
    assert all(np.isfinite(log["x_m"]).all() for log in logs)
    print(f"batch: {n_batch} vehicles x 60 s (mass and friction varied), {os.cpu_count()} threads")
    row("wall time", f"{t_batch:8.3f} s  ({t_batch / n_batch * 1e3:.2f} ms per vehicle)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
