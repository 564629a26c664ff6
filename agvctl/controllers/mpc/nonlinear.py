"""Nonlinear MPC pose controller with CasADi and IPOPT (``pose = "nmpc"``), for comparison with the LTV MPC.

The problem of :mod:`agvctl.controllers.mpc.common`, like :mod:`agvctl.controllers.mpc.ltv`, but on the
nonlinear kinematics instead of their linearisation: multiple shooting over the horizon, each sample
integrated with 4 RK4 steps of the report's eqs 39-43 (plus the wheel-loop lag for
``"kinematic+wheel_loop"``). Its cost weighs the world-frame position error alike in every direction, which is
the LTV MPC's path-frame cost (a rotation of it) when that weighs both axes alike (``along_track_share`` = 1,
``turn_in_place_position_scale`` = 1); then both solve the same problem.

The NLP is built once, in the constructor; each step passes the current pose, the reference window and the
previous command as parameters, warm-started from the previous solution shifted by one sample.
"""

from __future__ import annotations

import math
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.common import MpcStepper
from agvctl.controllers.mpc.config import MpcConfig, check_nmpc_settings
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.shaping import HorizonStep
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference

__all__ = ["NonlinearMpcController", "prediction_step"]

FloatArray = NDArray[np.float64]

RK4_STEPS_PER_SAMPLE = 4
_ACCEPTED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def prediction_step(
    sample_period_s: float, separation_m: float, wheel_loop_time_constant_s: float | None = None
) -> ca.Function:
    """The prediction model over one sample, as a CasADi function ``step(x, s) -> x_next``.

    The kinematics of eqs 39-43 on x = (x_m, y_m, theta_rad), driven by the held setpoints s directly or, given the
    wheel loop's time constant τ, through v̇ = (s − v)/τ on x = (x_m, y_m, theta_rad, v_left_m_s, v_right_m_s);
    integrated with 4 RK4 steps per sample.

    Parameters
    ----------
    sample_period_s : float
        T_s, the time the setpoints are held, s.
    separation_m : float
        The wheel separation b of eq 40, m.
    wheel_loop_time_constant_s : float or None
        τ of the wheel loops' lag, s (None: the setpoints drive the kinematics directly).

    Returns
    -------
    casadi.Function
        ``step(x, s) -> x_next``, with s the setpoints (left, right) in m/s.
    """
    lag = wheel_loop_time_constant_s is not None
    nx = 5 if lag else 3
    b = separation_m
    x, s = ca.SX.sym("x", nx), ca.SX.sym("s", 2)

    def rhs(z: ca.SX) -> ca.SX:
        v = z[3:5] if lag else s
        U = 0.5 * (v[0] + v[1])  # eq 39
        w = (v[1] - v[0]) / b  # eq 40
        out = [U * ca.cos(z[2]), U * ca.sin(z[2]), w]  # eqs 41-43
        if wheel_loop_time_constant_s is not None:
            out += [(s[0] - z[3]) / wheel_loop_time_constant_s, (s[1] - z[4]) / wheel_loop_time_constant_s]
        return ca.vertcat(*out)

    h = sample_period_s / RK4_STEPS_PER_SAMPLE
    z = x
    for _ in range(RK4_STEPS_PER_SAMPLE):
        k1 = rhs(z)
        k2 = rhs(z + 0.5 * h * k1)
        k3 = rhs(z + 0.5 * h * k2)
        k4 = rhs(z + h * k3)
        z = z + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("step", [x, s], [z])


class NonlinearMpcController(MpcStepper):
    """Nonlinear MPC with IPOPT; satisfies :class:`~agvctl.controllers.base.PoseController`.

    Same configuration, fallbacks and failure count as :class:`~agvctl.controllers.mpc.ltv.LtvMpcController`
    (``config.error_frame``, ``along_track_share`` and ``turn_in_place_position_scale`` do not apply: its cost weighs
    the position error alike in every direction).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: the wheel separation b (m), the sample period T_s (s) and the default wheel-speed
        and acceleration limits (m/s, m/s²).
    config : MpcConfig or None
        Horizon, weights, limits, the prediction model and the governor, docking and solver settings (None: the
        defaults).
    ipopt_options : dict or None
        IPOPT options that add to or replace the controller's (its iteration limit, tolerance and wall-time limit come
        from ``config``).
    """

    solver_errors = (RuntimeError,)
    """CasADi's exception for an error inside the solver call (a failed solve is IPOPT's return status instead)."""

    def __init__(
        self,
        vehicle: VehicleParams,
        config: MpcConfig | None = None,
        *,
        ipopt_options: dict[str, Any] | None = None,
    ) -> None:
        super().__init__(vehicle, config)
        check_nmpc_settings(self.config)
        self.nx = self._model.n_states
        self._w0: FloatArray | None = None
        self._lam_x0: FloatArray | None = None
        self._lam_g0: FloatArray | None = None
        self._last_k = -1
        self._build(ipopt_options or {})

    def _on_failure(self) -> None:
        self._w0 = None  # a failed solve's iterate is no warm start

    def _retarget(self, reference: Reference) -> HorizonReference:
        """Sample ``reference``'s horizon grid; forget the warm start."""
        self._rate_bounds()
        self._w0 = None
        self._last_k = -1
        return HorizonReference(reference, self.config, self.sample_period_s, self._model)

    # -- the NLP ------------------------------------------------------------------------------------------

    def _build(self, ipopt_options: dict[str, Any]) -> None:
        c, N, nx = self.config, self.config.horizon, self.nx
        step = prediction_step(self.sample_period_s, self.separation_m, self._model.time_constant_s)
        X = ca.SX.sym("X", nx, N)  # x_1 … x_N
        S = ca.SX.sym("S", 2, N)  # s_0 … s_{N−1}
        x0 = ca.SX.sym("x0", nx)
        ref = ca.SX.sym("ref", 3, N)  # reference pose at k = 1 … N
        ff = ca.SX.sym("ff", 2, N)
        u_prev = ca.SX.sym("u_prev", 2)
        cost = ca.SX(0)
        g = []
        prev_x, prev_s = x0, u_prev
        for k in range(N):
            g.append(X[:, k] - step(prev_x, S[:, k]))
            e = X[0:3, k] - ref[:, k]
            scale = c.weight_terminal_scale if k == N - 1 else 1.0
            cost += scale * (c.weight_position * (e[0] ** 2 + e[1] ** 2) + c.weight_heading * e[2] ** 2)
            cost += c.weight_input * ca.sumsqr(S[:, k] - ff[:, k])
            cost += c.weight_input_rate * ca.sumsqr(S[:, k] - prev_s)
            g.append(S[:, k] - prev_s)
            prev_x, prev_s = X[:, k], S[:, k]
        w = ca.veccat(X, S)
        p = ca.veccat(x0, ref, ff, u_prev)
        options: dict[str, Any] = {
            "print_time": False,
            "ipopt": {
                "print_level": 0,
                "sb": "yes",
                "max_iter": c.max_iterations,
                "tol": c.tolerance,
                "acceptable_tol": 10 * c.tolerance,
                "max_wall_time": c.max_solve_time_s if c.max_solve_time_s is not None else 1.0e20,
                "warm_start_init_point": "yes",
                "mu_init": 1e-3,
                **ipopt_options,
            },
        }
        self._solver = ca.nlpsol("nmpc", "ipopt", {"x": w, "p": p, "f": cost, "g": ca.vertcat(*g)}, options)
        self._rate_bounds()
        v_max = self.max_wheel_speed_m_s
        self._lbw = np.concatenate([np.full(nx * N, -np.inf), np.full(2 * N, -v_max)])
        self._ubw = np.concatenate([np.full(nx * N, np.inf), np.full(2 * N, v_max)])
        self._n_states = nx * N

    def _rate_bounds(self) -> None:
        """The constraint bounds: each prediction step's dynamics (= 0) and setpoint rates (within ±a_lim T_s)."""
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        lbg: list[float] = []
        ubg: list[float] = []
        for _ in range(self.config.horizon):
            lbg += [0.0] * self.nx + [-a_step, -a_step]
            ubg += [0.0] * self.nx + [a_step, a_step]
        self._lbg, self._ubg = np.array(lbg), np.array(ubg)

    # -- one step -----------------------------------------------------------------------------------------

    def _solve(self, step: HorizonStep) -> tuple[float, float] | None:
        g, k, pose, wheel_speed_m_s = step.grid, step.k, step.pose, step.wheel_speed_m_s
        N, nx = self.config.horizon, self.nx
        # the pose's heading taken to the branch nearest the (continuous) reference heading
        theta_ref = g.theta_rad[k]
        theta = float(pose[2])
        if math.isfinite(theta):
            theta += 2.0 * math.pi * round((theta_ref - theta) / (2.0 * math.pi))
        x0 = [float(pose[0]), float(pose[1]), theta, *self._model.measured_states(wheel_speed_m_s)]
        if not all(math.isfinite(v) for v in x0):
            return None  # a broken measurement
        ref = np.stack([g.x_m[k + 1 : k + N + 1], g.y_m[k + 1 : k + N + 1], g.theta_rad[k + 1 : k + N + 1]])
        ff = g.feedforward_m_s[k : k + N]
        f = step.fraction  # the governed clock between grid points (0 while it keeps time): interpolate
        if f > 0.0:
            ahead = np.stack([g.x_m[k + 2 : k + N + 2], g.y_m[k + 2 : k + N + 2], g.theta_rad[k + 2 : k + N + 2]])
            ref = ref + f * (ahead - ref)
            ff = ff + f * (g.feedforward_m_s[k + 1 : k + N + 1] - ff)
        v_max = self.max_wheel_speed_m_s
        u_prev = np.clip(step.previous_m_s, -v_max, v_max)  # as in the LTV MPC: keeps the first move feasible
        p = np.concatenate([x0, ref.T.ravel(), ff.ravel(), u_prev])

        if self._w0 is None or k != self._last_k + 1:
            # cold start: the reference itself (and its wheel speeds) with the feed-forward inputs
            states = [ref, *self._model.reference_states(g.wheel_m_s[k + 1 : k + N + 1])]
            w0 = np.concatenate([np.vstack(states).T.ravel(), ff.ravel()])
            args: dict[str, Any] = {"x0": w0}
        else:
            w0 = self._w0
            ns = self._n_states
            shifted = np.concatenate([w0[nx:ns], w0[ns - nx : ns], w0[ns + 2 :], w0[-2:]])
            lam_g = self._lam_g0
            assert lam_g is not None
            m = nx + 2
            lam_g = np.concatenate([lam_g[m:], lam_g[-m:]])
            args = {"x0": shifted, "lam_x0": self._lam_x0, "lam_g0": lam_g}
        sol = self._solver(p=p, lbx=self._lbw, ubx=self._ubw, lbg=self._lbg, ubg=self._ubg, **args)
        stats = self._solver.stats()
        if stats.get("return_status") not in _ACCEPTED:
            return None
        w = np.asarray(sol["x"]).ravel()
        if not np.all(np.isfinite(w)):
            return None
        self._w0 = w
        self._lam_x0 = np.asarray(sol["lam_x"]).ravel()
        self._lam_g0 = np.asarray(sol["lam_g"]).ravel()
        self._last_k = k
        seq = np.clip(w[self._n_states :].reshape(N, 2), -v_max, v_max)
        self._fallback.store(k, seq)
        return float(seq[0, 0]), float(seq[0, 1])
