"""Benchmark of a whole controller cascade's step: a unicycle law (Ramsete, or the LTV unicycle LQR) or the LTV MPC
and the PI loops in Python against the generated C cascade (``agvctl codegen``'s ``agv_cascade_step``), in the same
run.

The figure-8 path is run in closed loop with the law; the estimated poses and measured motor speeds it gave
the controllers are recorded. Then the cascade steps through them: in Python (the law, the setpoints as motor speeds,
the loops), and as the C that ``agvctl codegen`` writes for the experiment, timed in C around each call
(``clock_gettime``, no ctypes in the measure). Prints the median and p99 step of each in µs and their ratio, and the
figure-8 closed loop's wall time and real-time factor with the cascade in Python or in C, and the loop in Python
(``run_closed_loop(compiled=False)``) or in C (:mod:`agvctl.sim.compiled_loop`, the controllers in Python called
back from it): the loop's own time (``wall_time_s``) and the whole run's, its log (errors against the path, the
payload's readings) made.

With ``--law mpc`` the cascade in C is the MPC's (its steps and its QP's solver, the path as tables), and in the
closed loop the MPC in C is ``qp_solver = "osqp_c"`` (a pose controller the loop in C calls back: its step is not a
compiled step of the loop's).

Run:  python experiments/benchmarks/cascade_c.py [--law ramsete|ltv_lqr|mpc] [--repeat 5]
"""

from __future__ import annotations

import argparse
import ctypes
import dataclasses
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from agvctl.codegen import generate_code
from agvctl.controllers.base import PoseController
from agvctl.controllers.baselines.c_unicycle import COMPILED_LAWS
from agvctl.controllers.mpc import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS, CompiledPIWheelController
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.params import SIDES, VehicleParams
from agvctl.plant.codegen import compiled_library
from agvctl.scenario.experiment import load_experiment, run_experiment
from agvctl.sim.loop import run_closed_loop

EXPERIMENT = Path(__file__).parents[1] / "figure8.toml"

TIMER_C = """#define _POSIX_C_SOURCE 199309L
#include <time.h>
#include "agv_cascade.h"
/* Each step of the cascade over n recorded samples, timed around the call, ns. */
void bench_steps(long n, const double *poses, const double *motors, double *ns)
{
    agv_cascade_state state;
    struct timespec a, b;
    double da[2];
    long k;
    agv_cascade_init(&state);
    for (k = 0; k < n; ++k) {
        clock_gettime(CLOCK_MONOTONIC, &a);
        agv_cascade_step(&state, k, poses + 3 * k, motors + 2 * k, da);
        clock_gettime(CLOCK_MONOTONIC, &b);
        ns[k] = (double)(b.tv_sec - a.tv_sec) * 1e9 + (double)(b.tv_nsec - a.tv_nsec);
    }
}
"""


def law_figure8(folder: Path, law: str) -> Path:
    """The figure-8 experiment with ``law`` as its pose controller, written into ``folder``."""
    trajectory = (EXPERIMENT.parent / "../trajectories/figure8.toml").resolve()
    text = f'name = "figure8_{law}"\ntrajectory = "{trajectory}"\nsettle_s = 2.0\n\n[controller]\npose = "{law}"\n'
    (folder / f"figure8_{law}.toml").write_text(text, encoding="utf-8")
    return folder / f"figure8_{law}.toml"


def laws(name: str, settings: MpcConfig | None) -> tuple[Callable[[VehicleParams], PoseController], ...]:
    """The pose controller in Python and in C, by name (the MPC with the experiment's resolved ``settings``)."""
    if name != "mpc":
        return COMPILED_LAWS[name].python, COMPILED_LAWS[name].compiled
    assert settings is not None
    c_settings = dataclasses.replace(settings, qp_solver="osqp_c")
    return (lambda v: LtvMpcController(v, settings)), (lambda v: LtvMpcController(v, c_settings))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--law", choices=[*sorted(COMPILED_LAWS), "mpc"], default="ramsete")
    parser.add_argument("--repeat", type=int, default=5, help="passes over the recorded inputs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="agvctl-bench-") as folder:
        path = law_figure8(Path(folder), args.law)
        experiment, code = load_experiment(path), generate_code(path, measure_memory=False)
    vehicle = experiment.controller_vehicle
    gains, options = experiment.wheel_loops.design.gains, experiment.wheel_loops.options
    log = run_experiment(experiment).log
    n = len(log)
    poses = np.ascontiguousarray(np.column_stack([log["est_x_m"], log["est_y_m"], log["est_theta_rad"]]))
    motors = np.ascontiguousarray(
        np.column_stack([log["measured_omega_motor_left_rad_s"], log["measured_omega_motor_right_rad_s"]])
    )
    rim = np.array([vehicle.rim_per_motor_rad(side) for side in SIDES])
    ts = vehicle.control.sample_period_s

    sources = {name: text for name, text in code.files.items() if name.endswith((".c", ".h"))}
    sources.pop("example_main.c")
    lib = compiled_library(
        {**sources, "bench.c": TIMER_C}, "agv_cascade_bench", flags=(*STRICT_C_FLAGS, "-fPIC", "-shared")
    )
    ns_c = np.zeros(n)
    python_ns: list[int] = []
    c_ns: list[float] = []
    settings = experiment.spec.controller.pose_settings
    python_law, c_law = laws(args.law, settings if isinstance(settings, MpcConfig) else None)
    law, loops = python_law(vehicle), PIWheelController(vehicle, gains, options)
    clock = time.perf_counter_ns
    for _ in range(args.repeat):
        law.reset(experiment.reference)
        loops.reset()
        for k in range(n):
            t0 = clock()
            command = law.update(k * ts, poses[k], motors[k] * rim)
            loops.update(np.array([command.wheel_speed_left_m_s, command.wheel_speed_right_m_s]) / rim, motors[k])
            python_ns.append(clock() - t0)
        lib.bench_steps(
            ctypes.c_long(n),
            ctypes.c_void_p(poses.ctypes.data),
            ctypes.c_void_p(motors.ctypes.data),
            ctypes.c_void_p(ns_c.ctypes.data),
        )
        c_ns.extend(ns_c.tolist())
    median = {"python": float(np.median(python_ns)) / 1e3, "c": float(np.median(c_ns)) / 1e3}
    p99 = {"python": float(np.percentile(python_ns, 99)) / 1e3, "c": float(np.percentile(c_ns, 99)) / 1e3}
    print(f"cascade step ({args.law} + PI loops) over {n} samples of {EXPERIMENT.name} x {args.repeat} passes:")
    print(f"  python  median {median['python']:8.3f} µs   p99 {p99['python']:8.3f} µs")
    print(f"  c       median {median['c']:8.3f} µs   p99 {p99['c']:8.3f} µs   (timed in C)")
    print(f"  ratio   Python / C median {median['python'] / median['c']:.0f}x")
    duration = experiment.reference.duration_s + experiment.spec.settle_s
    for name, pose, wheels, compiled in (
        ("cascade in Python, loop in Python", python_law(vehicle), PIWheelController(vehicle, gains, options), False),
        ("cascade in Python, loop in C", python_law(vehicle), PIWheelController(vehicle, gains, options), True),
        ("cascade in C, loop in Python", c_law(vehicle), CompiledPIWheelController(vehicle, gains, options), False),
        ("cascade in C, loop in C", c_law(vehicle), CompiledPIWheelController(vehicle, gains, options), True),
    ):
        loop_s, whole_s = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            result = run_closed_loop(
                plant_vehicle=experiment.plant_vehicle,
                controller_vehicle=vehicle,
                reference=experiment.reference,
                pose_controller=pose,
                wheel_controller=wheels,
                settle_s=experiment.spec.settle_s,
                compiled=compiled,
            )
            whole_s.append(time.perf_counter() - t0)
            loop_s.append(result.wall_time_s)
        print(
            f"  figure-8 closed loop, {name}: loop {min(loop_s) * 1e3:.1f} ms ({duration / min(loop_s):.0f}x real "
            f"time), whole run with its log {min(whole_s) * 1e3:.1f} ms ({duration / min(whole_s):.0f}x), best of 3"
        )


if __name__ == "__main__":
    main()
