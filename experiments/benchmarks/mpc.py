"""MPC benchmark: the OSQP LTV MPC, the CasADi/IPOPT NMPC and do-mpc on the same tracking problem.

The problem: the figure-8 reference (0.5 m/s) from ``trajectories/figure8.toml`` plus 2 s at rest, horizon 20,
the same weights, wheel-speed and wheel-acceleration limits and prediction model (kinematics + a first-order
wheel loop whose time constant is identified below), on the same plant: the full nonlinear model (friction,
centrifugal terms, current limit) behind the 12-bit DA and the amplifier, with a simple discrete PI speed loop
per wheel written here (pole-zero cancellation of the decoupled model's mechanical time constant, closed-loop
time constant ≈ 0.1 s, integrator clamped while the DA saturates). The closed-loop runner will use the tuned
PI loops of ``agvctl.controllers``; this loop only has to be the same for all three controllers.

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

from agvctl.actuator import Actuator
from agvctl.controllers.base import PoseCommand
from agvctl.controllers.mpc_common import HorizonReference, MpcConfig, limit_command, resolved_limits
from agvctl.controllers.mpc_ltv import LtvMpcController
from agvctl.controllers.mpc_nonlinear import NonlinearMpcController, prediction_step
from agvctl.params import VehicleParams, load_vehicle
from agvctl.planning import plan_file
from agvctl.planning.reference import Reference
from agvctl.plant.full import parameter_vector, state_from_motor_speeds
from agvctl.sim.integrator import compiled_plant, sample_splits

ROOT = Path(__file__).resolve().parents[2]
SETTLE_S = 2.0
PI_CLOSED_LOOP_TIME_CONSTANT_S = 0.1


class BenchWheelLoop:
    """Discrete PI per wheel on the motor speed (rad/s) → DA voltage (V). Not the product's tuned loop."""

    def __init__(self, vehicle: VehicleParams) -> None:
        m = vehicle.motor.left
        d = vehicle.derived
        k_e, k_t, R, f_m = (m.voltage_constant_v_s_rad, m.torque_constant_n_m_a, m.resistance_ohm,
                            m.viscous_friction_n_m_s_rad)  # fmt: skip
        gain_rad_s_per_v = (k_t / R) / (k_e * k_t / R + f_m)  # steady motor speed per volt (eqs 60-61)
        tau_m = d.mechanical_time_constant_s
        self.kp = tau_m / (PI_CLOSED_LOOP_TIME_CONSTANT_S * gain_rad_s_per_v)  # motor V per rad/s
        self.ki = self.kp / tau_m
        self.T = vehicle.control.sample_period_s
        self.amp_gain = vehicle.amplifier.gain
        self.da_max = Actuator(vehicle).max_da_voltage_v
        self.integral = np.zeros(2)

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        e = setpoint_rad_s - measured_rad_s
        u = (self.kp * e + self.ki * (self.integral + self.T * e)) / self.amp_gain
        saturated = np.abs(u) > self.da_max
        self.integral += np.where(saturated & (np.sign(u) == np.sign(e)), 0.0, self.T * e)
        return np.clip(u, -self.da_max, self.da_max)


class Plant:
    """The full nonlinear plant behind the DA/amplifier and :class:`BenchWheelLoop`, one sample at a time."""

    def __init__(self, vehicle: VehicleParams, pose: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        self.plant = compiled_plant()
        self.p = parameter_vector(vehicle)
        self.splits = sample_splits(vehicle)
        self.actuator = Actuator(vehicle)
        self.loop = BenchWheelLoop(vehicle)
        self.T = vehicle.control.sample_period_s
        self.rim = np.array([vehicle.wheels.radius_left_m / vehicle.motor.left.gear_ratio,
                             vehicle.wheels.radius_right_m / vehicle.motor.right.gear_ratio])  # fmt: skip
        self.x = state_from_motor_speeds(vehicle, (0.0, 0.0), pose)
        self.u = np.zeros(2)

    def wheel_speed_m_s(self) -> np.ndarray:
        return self.plant.aux(self.x, self.u, self.p)[0:2] * self.rim

    def step(self, setpoint_m_s: np.ndarray) -> None:
        omega = self.plant.aux(self.x, self.u, self.p)[0:2]
        da = self.loop.update(setpoint_m_s / self.rim, omega)
        self.u = self.actuator.apply(da).motor_voltage_v
        self.x, _aux, _stats = self.plant.step(self.x, self.u, self.p, self.T, self.splits)


def identify_wheel_loop_time_constant(vehicle: VehicleParams) -> float:
    """τ of the bench wheel loop: the time to 63 % of a small step, 0.30 → 0.35 m/s on a straight line (small,
    so that the current limit does not turn it into a ramp at a_lim; moving, so that stiction stays out)."""
    plant = Plant(vehicle)
    T = vehicle.control.sample_period_s
    for _ in range(100):
        plant.step(np.array([0.3, 0.3]))
    v0 = float(plant.wheel_speed_m_s()[0])
    speeds = [v0]
    for _ in range(50):
        plant.step(np.array([0.35, 0.35]))
        speeds.append(float(plant.wheel_speed_m_s()[0]))
    v = np.array(speeds)
    level = v0 + 0.632 * (0.35 - v0)
    k = int(np.argmax(v >= level))
    frac = (level - v[k - 1]) / (v[k] - v[k - 1])  # interpolate between samples k−1 and k
    return (k - 1 + frac) * T


@dataclass
class RunResult:
    step_ms: np.ndarray
    error_m: np.ndarray
    heading_error_rad: np.ndarray
    failures: int


def closed_loop(controller, reference: Reference, vehicle: VehicleParams) -> RunResult:
    """Run one controller on the full plant over the reference plus :data:`SETTLE_S`."""
    T = vehicle.control.sample_period_s
    n = math.ceil((reference.duration_s + SETTLE_S) / T)
    plant = Plant(vehicle)
    controller.reset(reference)
    times = np.empty(n)
    err = np.empty(n)
    head = np.empty(n)
    ref = reference.sample((np.arange(n) + 1) * T)
    for k in range(n):
        pose = plant.x[2:5]
        wheel = plant.wheel_speed_m_s()
        t0 = time.perf_counter()
        cmd: PoseCommand = controller.update(k * T, pose, wheel)
        times[k] = time.perf_counter() - t0
        plant.step(np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s]))
        err[k] = math.hypot(plant.x[2] - ref.x_m[k], plant.x[3] - ref.y_m[k])
        head[k] = abs((plant.x[4] - ref.theta_rad[k] + math.pi) % (2 * math.pi) - math.pi)
    return RunResult(times * 1e3, err, head, controller.failures)


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
        pose_cost = c.weight_position * ((xs[0] - ref[0]) ** 2 + (xs[1] - ref[1]) ** 2) + c.weight_heading * (
            xs[2] - ref[2]
        ) ** 2
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
        self._grid = HorizonReference(reference, self.config, self.T)
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
    tau = identify_wheel_loop_time_constant(vehicle)
    config = MpcConfig(
        horizon=args.horizon,
        prediction_model=args.prediction_model,
        wheel_loop_time_constant_s=tau,
        error_frame=args.error_frame,
    )
    print(f"figure-8 at 0.5 m/s: {reference.duration_s:.2f} s + {SETTLE_S:.0f} s settle, "
          f"T_s = {vehicle.control.sample_period_s * 1e3:.0f} ms, horizon {config.horizon}, "
          f"{config.prediction_model} model, {config.error_frame} frame; "
          f"bench wheel loop τ = {tau * 1e3:.0f} ms (identified from a 0.30 → 0.35 m/s step)")  # fmt: skip
    print(f"weights: position {config.weight_position:g}/m², heading {config.weight_heading:g}/rad², input "
          f"{config.weight_input:g}, rate {config.weight_input_rate:g} (m/s)⁻²; limits "
          f"{resolved_limits(config, vehicle)[0]:.3f} m/s, {resolved_limits(config, vehicle)[1]:.3f} m/s²")

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
