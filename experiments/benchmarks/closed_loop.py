"""Benchmark of the closed loop: 60 s of figure-8 with the OSQP MPC over the PI loops on the full plant.

The whole cascade of ``agvctl run`` — reference, LTV MPC (OSQP), PI wheel loops, DA converter and amplifier, the
compiled nonlinear plant, logging — for 60 s of simulated time (two figure-8 laps at 0.5 m/s and the rest at
standstill), plots excluded. Prints the loop's wall time and real-time factor (goal: ≤ 2 s, ≥ 30x), the MPC's
whole-step time per control step (goal: median ≤ 0.7 ms, p99 ≤ 2 ms), and the same loop with the reference
feed-forward in place of the MPC, which shows what the MPC costs.

The MPC talks to OSQP through its public interface (``OSQP.update``, ``OSQP.solve``). As a peer, the same loop
runs with the MPC's solver calls sent straight to osqp's compiled solver object (``OSQP._solver``, a private
attribute of osqp 1.x), which skips the public wrapper's argument handling and result namespace; the ratio says
what the public interface costs. A third runs the MPC on OSQP's C generated for its QP (``qp_solver = "osqp_c"``,
through ctypes): the same commands, and the ratio of its loop's wall time to the first's. A fourth runs the first's
loop in Python (``run_closed_loop(compiled=False)``) where the others run in C (:mod:`agvctl.sim.compiled_loop`, the
MPC and the PI loops called back from it): the same log, and the ratio of the two wall times.

Run:  python experiments/benchmarks/closed_loop.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import sys
from types import SimpleNamespace
from typing import Any

import numpy as np

from agvctl.controllers.base import PoseController
from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.tuning import default_pi_gains
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.params import load_vehicle
from agvctl.planning import ArcSegment, WheelLimits, plan_segments
from agvctl.sim.loop import run_closed_loop


class CompiledOsqp:
    """The MPC's OSQP calls sent to osqp's compiled solver, past the public wrapper (the peer; see the notes)."""

    def __init__(self, public: Any) -> None:
        self._compiled = public._solver

    def update(self, **data: Any) -> None:
        c = self._compiled
        if "q" in data:
            c.update_data_vec(q=data["q"], l=data["l"], u=data["u"])
        if "Px" in data or "Ax" in data:
            c.update_data_mat(P_x=data.get("Px"), P_i=data.get("Px_idx"), A_x=data.get("Ax"), A_i=data.get("Ax_idx"))

    def solve(self, raise_error: bool = False) -> SimpleNamespace:
        self._compiled.solve()
        return SimpleNamespace(x=self._compiled.solution.x, info=self._compiled.info)

    def warm_start(self, x: Any, y: Any) -> None:
        self._compiled.warm_start(x, y)

    def update_settings(self, rho: float) -> None:
        self._compiled.update_rho(rho)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()

    vehicle = load_vehicle()
    limits = WheelLimits(wheel_speed_m_s=0.8, wheel_accel_m_s2=0.5, wheel_jerk_m_s3=3.0)
    laps = [ArcSegment(radius_m=1.0, angle_deg=a, speed_m_s=0.5) for a in (360, -360, 360, -360)]
    reference = plan_segments(
        laps, limits=limits, separation_m=vehicle.wheels.separation_m, sample_period_s=vehicle.control.sample_period_s
    )
    settle = 60.0 - reference.duration_s
    gains, tau = default_pi_gains(vehicle)

    def once(pose: PoseController, compiled: bool = True) -> tuple[float, dict[str, float]]:
        result = run_closed_loop(
            plant_vehicle=vehicle,
            controller_vehicle=vehicle,
            reference=reference,
            pose_controller=pose,
            wheel_controller=PIWheelController(vehicle, gains),
            settle_s=settle,
            compiled=compiled,
        )
        return result.wall_time_s, closed_loop_metrics(result)

    mpc = LtvMpcController(vehicle, MpcConfig(wheel_loop_time_constant_s=tau))
    peer = LtvMpcController(vehicle, MpcConfig(wheel_loop_time_constant_s=tau))
    peer._solver = CompiledOsqp(peer._solver)  # type: ignore[assignment]
    generated = LtvMpcController(vehicle, MpcConfig(wheel_loop_time_constant_s=tau, qp_solver="osqp_c"))
    once(mpc)  # warm-up: the compiled plant and OSQP set up once
    once(peer)
    once(generated)
    runs, peer_runs, generated_runs, python_runs = [], [], [], []
    for _ in range(args.repeat):  # interleaved, so that all see the same machine
        runs.append(once(mpc))
        peer_runs.append(once(peer))
        generated_runs.append(once(generated))
        python_runs.append(once(mpc, compiled=False))
    peer_p50 = statistics.median(m["solve_time_p50_ms"] for _, m in peer_runs)
    walls = [w for w, _ in runs]
    p50 = statistics.median(m["solve_time_p50_ms"] for _, m in runs)
    p99 = statistics.median(m["solve_time_p99_ms"] for _, m in runs)
    m0 = runs[0][1]
    ff_walls = [once(FeedForwardPoseController())[0] for _ in range(args.repeat)]

    wall = statistics.median(walls)
    print(f"closed loop, 60 s simulated (two figure-8 laps at 0.5 m/s, {reference.duration_s:.1f} s, then at rest)")
    print(
        f"  OSQP MPC + PI + DA/amplifier + full plant  wall {wall:.3f} s (median of {args.repeat}, "
        f"min {min(walls):.3f})  = {60.0 / wall:.0f}x real time   (goal <= 2 s, >= 30x)"
    )
    print(
        f"  MPC whole step                             median {p50:.3f} ms   p99 {p99:.3f} ms   "
        f"(goals: median <= 0.3 ms, p99 <= 2 ms; median over runs)"
    )
    print(
        f"  the same, OSQP's compiled solver directly  median {peer_p50:.3f} ms: the public interface costs "
        f"{(p50 / peer_p50 - 1.0) * 100:.0f} % of the step (ratio {p50 / peer_p50:.2f})"
    )
    generated_wall = statistics.median(w for w, _ in generated_runs)
    generated_p50 = statistics.median(m["solve_time_p50_ms"] for _, m in generated_runs)
    print(
        f"  the same, its QP solved by generated C     wall {generated_wall:.3f} s, MPC step median "
        f"{generated_p50:.3f} ms (wall ratio to OSQP in Python {generated_wall / wall:.2f})"
    )
    python_wall = statistics.median(w for w, _ in python_runs)
    print(
        f"  the same, the loop in Python               wall {python_wall:.3f} s (the loop in C, the MPC and the PI "
        f"loops called back from it, takes {wall / python_wall:.2f} of it)"
    )
    print(
        f"  tracking                                   rms {m0['tracking_error_rms_m'] * 1e3:.2f} mm   "
        f"max {m0['tracking_error_max_m'] * 1e3:.2f} mm"
    )
    ff = statistics.median(ff_walls)
    print(
        f"  the same loop with feed-forward, no MPC    wall {ff:.3f} s: the MPC costs {wall - ff:.3f} s "
        f"of the {wall:.3f} s"
    )
    print(f"  per control step: {wall / 1500 * 1e3:.3f} ms in all, {(wall - ff) / 1500 * 1e3:.3f} ms of it the MPC")
    assert np.isfinite(wall)
    return 0


if __name__ == "__main__":
    sys.exit(main())
