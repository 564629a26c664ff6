"""MPC benchmark: the OSQP LTV MPC, the CasADi/IPOPT NMPC and do-mpc on the same tracking problem.

The problem: the figure-8 reference (0.5 m/s) from ``trajectories/figure8.toml`` plus 2 s at rest, horizon 20,
the same weights, wheel-speed and wheel-acceleration limits and prediction model (kinematics + a first-order
wheel loop whose time constant is identified below), on the same plant: the full nonlinear model (friction,
centrifugal terms, current limit) behind the 12-bit DA and the amplifier, with the tuned PI wheel loops of
``agvctl run`` (``agvctl.sim.loop.run_closed_loop``): the same loop for all three controllers.

Each controller's step is timed with ``time.perf_counter`` around the whole call (Python included), and the
run is repeated (``--repeat``) because the machine is shared: the table gives the median over repeats of each
run's median and 99th percentile. Tracking errors are the distance to the reference's position at the same
time.

    PYTHONPATH=. python experiments/benchmarks/mpc.py [--repeat 3] [--no-dompc] [--horizon 20]
        [--prediction-model kinematic|kinematic+wheel_loop] [--error-frame path|world]

do-mpc is optional (``pip install agvctl[bench]``); without it its row is skipped with a message.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agvctl.controllers.base import PoseCommand, PoseController
from agvctl.controllers.mpc.config import MpcConfig, resolved_limits
from agvctl.controllers.mpc.fallback import limit_command
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController, prediction_step
from agvctl.controllers.mpc.prediction import PREDICTION_MODELS
from agvctl.controllers.pi.tuning import default_pi_gains
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.params import VehicleParams, load_vehicle
from agvctl.planning import plan_file
from agvctl.planning.reference import Reference
from agvctl.sim.loop import run_closed_loop

ROOT = Path(__file__).resolve().parents[2]
SETTLE_S = 2.0


@dataclass
class RunResult:
    step_ms: np.ndarray
    error_m: np.ndarray
    heading_error_rad: np.ndarray
    failures: int


def closed_loop(controller: PoseController, reference: Reference, vehicle: VehicleParams) -> RunResult:
    """Run one pose controller in the product's closed loop (``agvctl run``'s): the tuned PI wheel loops with
    Coulomb feed-forward, the DA/amplifier and the full plant, over the reference plus :data:`SETTLE_S`."""
    design = default_pi_gains(vehicle)
    result = run_closed_loop(
        plant_vehicle=vehicle,
        controller_vehicle=vehicle,
        reference=reference,
        pose_controller=controller,
        wheel_controller=PIWheelController(vehicle, design.gains),
        settle_s=SETTLE_S,
    )
    log = result.log
    failures = int(getattr(controller, "failures", result.solver_failures))
    return RunResult(
        log["solve_time_s"][:-1] * 1e3, log["position_error_m"], np.abs(log["heading_error_rad"]), failures
    )


class DoMpcController:
    """The same problem in do-mpc (discrete model, IPOPT), behind the PoseController interface.

    do-mpc has no constraint on input increments, so the previous input is an extra model state and
    |s_k − s_{k−1}| ≤ a_lim·T_s are nonlinear constraints on (x, u); its ``rterm`` is the input-rate weight.
    Its cost sits on x_0 … x_N−1 (``lterm``) and x_N (``mterm``): x_0 is fixed, so it is the same cost.
    """

    def __init__(self, vehicle: VehicleParams, config: MpcConfig) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # do-mpc warns about optional features at import
            import do_mpc
        self.config = config
        self.T = vehicle.control.sample_period_s
        self.v_max, self.a_lim = resolved_limits(config, vehicle)
        lag = config.prediction_model == "kinematic+wheel_loop"
        self.lag = lag
        step = prediction_step(self.T, vehicle.wheels.separation_m,
                               config.wheel_loop_time_constant_s if lag else None)  # fmt: skip
        model = do_mpc.model.Model("discrete", "SX")
        names = ["x", "y", "th"] + (["vl", "vr"] if lag else [])
        xs = [model.set_variable("_x", n) for n in names]
        up = [model.set_variable("_x", "ul_prev"), model.set_variable("_x", "ur_prev")]
        s = [model.set_variable("_u", "sl"), model.set_variable("_u", "sr")]
        ref = [model.set_variable("_tvp", n) for n in ("xr", "yr", "thr", "ffl", "ffr")]
        import casadi as ca

        nxt = step(ca.vertcat(*xs), ca.vertcat(*s))
        for i, n in enumerate(names):
            model.set_rhs(n, nxt[i])
        model.set_rhs("ul_prev", s[0])
        model.set_rhs("ur_prev", s[1])
        model.setup()
        c = config
        pose_cost = (
            c.weight_position * ((xs[0] - ref[0]) ** 2 + (xs[1] - ref[1]) ** 2)
            + c.weight_heading * (xs[2] - ref[2]) ** 2
        )
        input_cost = c.weight_input * ((s[0] - ref[3]) ** 2 + (s[1] - ref[4]) ** 2)
        mpc = do_mpc.controller.MPC(model)
        mpc.settings.n_horizon = c.horizon
        mpc.settings.t_step = self.T
        mpc.settings.store_full_solution = False
        mpc.settings.nlpsol_opts = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": 0,
                                    "ipopt.tol": c.tolerance, "ipopt.max_iter": c.max_iterations}  # fmt: skip
        mpc.set_objective(lterm=pose_cost + input_cost, mterm=c.weight_terminal_scale * pose_cost)
        mpc.set_rterm(sl=c.weight_input_rate, sr=c.weight_input_rate)
        for name in ("sl", "sr"):
            mpc.bounds["lower", "_u", name] = -self.v_max
            mpc.bounds["upper", "_u", name] = self.v_max
        a_step = self.a_lim * self.T
        mpc.set_nl_cons("rate_l_up", s[0] - up[0], ub=a_step)
        mpc.set_nl_cons("rate_l_dn", up[0] - s[0], ub=a_step)
        mpc.set_nl_cons("rate_r_up", s[1] - up[1], ub=a_step)
        mpc.set_nl_cons("rate_r_dn", up[1] - s[1], ub=a_step)
        self._template = mpc.get_tvp_template()
        self._grid: HorizonReference | None = None
        self._k = 0
        mpc.set_tvp_fun(self._tvp)
        mpc.setup()
        self.mpc = mpc
        self.failures = 0
        self._u_prev: np.ndarray | None = None
        self._started = False

    def _tvp(self, t_now: float):
        g = self._grid
        if g is None:  # do-mpc calls it once at setup
            return self._template
        k = self._k
        for j in range(self.config.horizon + 1):
            i = k + j
            f = min(i, len(g.feedforward_m_s) - 1)
            ff = g.feedforward_m_s[f]
            self._template["_tvp", j] = np.array([g.x_m[i], g.y_m[i], g.theta_rad[i], ff[0], ff[1]])
        return self._template

    def reset(self, reference: Reference) -> None:
        model = PREDICTION_MODELS[self.config.prediction_model](self.config, self.T)
        self._grid = HorizonReference(reference, self.config, self.T, model)
        self._u_prev = None
        self._started = False

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        t0 = time.perf_counter()
        g = self._grid
        assert g is not None
        self._k = k = g.window_start(t_s)
        if self._u_prev is None:
            self._u_prev = np.array(wheel_speed_m_s, dtype=float)
        theta = float(pose[2])
        theta += 2 * math.pi * round((g.theta_rad[k] - theta) / (2 * math.pi))
        u_prev = np.clip(self._u_prev, -self.v_max, self.v_max)
        x0 = [float(pose[0]), float(pose[1]), theta]
        if self.lag:
            x0 += [float(wheel_speed_m_s[0]), float(wheel_speed_m_s[1])]
        x0 = np.array(x0 + list(u_prev)).reshape(-1, 1)
        if not self._started:
            self.mpc.x0 = x0
            self.mpc.u0 = u_prev.reshape(-1, 1)
            self.mpc.set_initial_guess()
            self._started = True
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # do-mpc's numpy/casadi deprecation notices
            u = np.asarray(self.mpc.make_step(x0)).ravel()
        status = "solved"
        if not self.mpc.solver_stats["success"]:
            self.failures += 1
            status = "fallback_feedforward"
            u = g.feedforward_m_s[k].copy()
        a_step = self.a_lim * self.T
        left = limit_command(float(u[0]), self._u_prev[0], self.v_max, a_step)
        right = limit_command(float(u[1]), self._u_prev[1], self.v_max, a_step)
        self._u_prev[:] = (left, right)
        return PoseCommand(left, right, time.perf_counter() - t0, status)  # type: ignore[arg-type]


def quietly(fn: Callable[..., object], *args: object) -> object:
    """Call ``fn`` with warnings silenced (do-mpc's setup triggers casadi's numpy-interop FutureWarning)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*args)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="closed-loop runs per controller (default 3)")
    ap.add_argument("--horizon", type=int, default=20)
    ap.add_argument("--no-dompc", action="store_true", help="skip do-mpc")
    ap.add_argument("--prediction-model", choices=("kinematic", "kinematic+wheel_loop"),
                    default="kinematic+wheel_loop")  # fmt: skip
    ap.add_argument("--error-frame", choices=("path", "world"), default="path", help="the OSQP MPC's")
    args = ap.parse_args(argv)

    vehicle = load_vehicle(None)
    reference = plan_file(ROOT / "trajectories" / "figure8.toml", vehicle)
    tau = default_pi_gains(vehicle).loop_time_constant_s
    config = MpcConfig(
        horizon=args.horizon,
        prediction_model=args.prediction_model,
        wheel_loop_time_constant_s=tau,
        error_frame=args.error_frame,
    )
    print(f"figure-8 at 0.5 m/s: {reference.duration_s:.2f} s + {SETTLE_S:.0f} s settle, "
          f"T_s = {vehicle.control.sample_period_s * 1e3:.0f} ms, horizon {config.horizon}, "
          f"{config.prediction_model} model, {config.error_frame} frame; "
          f"wheel-loop τ = {tau * 1e3:.0f} ms (first-order fit to the tuned PI's closed loop)")  # fmt: skip
    print(
        f"weights: position {config.weight_position:g}/m², heading {config.weight_heading:g}/rad², input "
        f"{config.weight_input:g}, rate {config.weight_input_rate:g} (m/s)⁻²; limits "
        f"{resolved_limits(config, vehicle)[0]:.3f} m/s, {resolved_limits(config, vehicle)[1]:.3f} m/s²"
    )

    makers: list[tuple[str, Callable[[], object]]] = [
        ("OSQP LTV MPC", lambda: LtvMpcController(vehicle, config)),
        ("CasADi NMPC (IPOPT)", lambda: NonlinearMpcController(vehicle, config)),
    ]
    if not args.no_dompc:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                import do_mpc  # noqa: F401
            makers.append(("do-mpc (IPOPT)", lambda: quietly(DoMpcController, vehicle, config)))
        except ImportError:
            print("do-mpc is not installed (pip install 'agvctl[bench]'): skipping its row")

    rows = []
    for label, make in makers:
        runs = []
        for _ in range(args.repeat):
            controller = make()
            runs.append(closed_loop(controller, reference, vehicle))
            print(f"  {label}: run {len(runs)} median {np.median(runs[-1].step_ms):.3f} ms", file=sys.stderr)
        med = float(np.median([np.median(r.step_ms) for r in runs]))
        p99 = float(np.median([np.percentile(r.step_ms, 99) for r in runs]))
        r0 = runs[0]
        rms = float(np.sqrt(np.mean(r0.error_m**2)))
        heading = float(np.degrees(np.max(r0.heading_error_rad)))
        rows.append((label, med, p99, rms, float(np.max(r0.error_m)), heading, sum(r.failures for r in runs)))

    print()
    header = (f"{'controller':<22} {'step median':>12} {'step p99':>10} {'err RMS':>9} {'err max':>9} "
              f"{'head max':>9} {'failures':>9}")  # fmt: skip
    print(header)
    print(f"{'':<22} {'ms':>12} {'ms':>10} {'mm':>9} {'mm':>9} {'deg':>9} {'(all runs)':>9}")
    print("-" * len(header))
    for label, med, p99, rms, mx, hd, fails in rows:
        print(f"{label:<22} {med:12.3f} {p99:10.3f} {rms * 1e3:9.2f} {mx * 1e3:9.2f} {hd:9.3f} {fails:9d}")
    print("-" * len(header))
    osqp_med, osqp_p99 = rows[0][1], rows[0][2]
    met = osqp_med <= 0.7 and osqp_p99 <= 2.0
    print(f"OSQP MPC goal: median ≤ 0.7 ms, p99 ≤ 2 ms: {'met' if met else 'NOT met'}")
    for label, med, *_ in rows[1:]:
        print(f"{label} / OSQP MPC step-time ratio (medians): {med / osqp_med:.1f}x")
    dompc = [r for r in rows if r[0].startswith("do-mpc")]
    if dompc:
        ratio = dompc[0][1] / osqp_med
        print(f"goal do-mpc / OSQP ≥ 10x: {'met' if ratio >= 10 else 'NOT met'} ({ratio:.1f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
