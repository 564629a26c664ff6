"""Linear time-varying MPC pose controller on OSQP (``pose = "mpc"``), the default pose controller.

The problem of :mod:`agvctl.controllers.mpc.common`, linearised about the reference along the horizon. The
decision variables are deviations from the reference: δs_k = s_k − s_ff,k (setpoints minus feed-forward) and
the predicted error states x_1 … x_N, kept as variables (the sparse, "uncondensed" form):

    x = [e_along, e_across, e_θ]             error in the reference's path frame   (error_frame = "path")
        [e_x, e_y, e_θ]                      or in world axes                     (error_frame = "world")
        + [δv_l, δv_r] for the wheel-loop lag (prediction_model = "kinematic+wheel_loop")

Linearising the kinematics (eqs 39-43) about the reference's U, ω, θ at each interval's midpoint gives, in the
path frame, ė_along = ω e_across + δU, ė_across = −ω e_along + U e_θ, ė_θ = δω, with δU = (δv_l + δv_r)/2 and
δω = (δv_r − δv_l)/b; in world axes ė_x = −U sin θ e_θ + cos θ δU, ė_y = U cos θ e_θ + sin θ δU. The lag adds
δv̇ = (δs − δv)/τ; the kinematic model has δv = δs. Each interval is discretised exactly for a held input
(matrix exponential of the augmented system). The two frames are the same model in rotated coordinates (the
cost is rotation invariant), so they track identically; ``path`` is the default for its readable errors.

Everything that varies with time depends on the reference only, so it is computed for the whole reference at
:meth:`LtvMpcController.reset`; a step is the initial error, a handful of slice copies into OSQP's vectors and
its CSC data array at precomputed positions, ``update`` and a warm-started ``solve``. OSQP is set up once, in
the constructor, with every entry that can ever be nonzero in the sparsity pattern.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import osqp
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.mpc.common import MpcStepper
from agvctl.controllers.mpc.config import MpcConfig, wheel_loop_time_constant_s
from agvctl.controllers.mpc.horizon import HorizonReference, turning_in_place
from agvctl.controllers.mpc.ltv_qp import QpLayout, constraint_pattern, cost_matrix
from agvctl.controllers.mpc.matrix_exponential import expm_batch
from agvctl.controllers.mpc.shaping import HorizonStep, SetpointWindow
from agvctl.errors import ConfigError, expect_instance
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference

__all__ = ["LtvMpcController"]

FloatArray = NDArray[np.float64]

_INF = 1.0e30
_RELINEARISE_RAD = 0.01
"""The heading error about which the position error's response to δU is linearised (see
:meth:`LtvMpcController._couple_heading`) is refreshed when the present one has moved more than this (0.57°) from
it: a stale point mispredicts a lateral motion of at most 0.01·δU·t (under 0.1 mm over the horizon for a 1 cm/s
correction), and an unchanged matrix spares OSQP its refactorisation, about a third of a step."""
_ACCEPTED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)
OSQP_SETTINGS: dict[str, Any] = {
    "polishing": False,
    "warm_starting": True,
    "verbose": False,
    "rho": 1.0,
    "adaptive_rho_interval": 25,
    "check_termination": 5,
    "alpha": 1.2,
}
"""OSQP settings besides tolerance, iteration and time limits (from the config); the constructor's
``osqp_settings`` overrides them. A fixed adaptive-rho interval keeps runs deterministic (OSQP's default
adapts on measured time); ρ = 1 and relaxation α = 1.2 need fewer iterations than OSQP's defaults on the hardest
steps and on warm-started tracking steps (``docs/decisions/0012-osqp.md``)."""


class LtvMpcController(MpcStepper):
    """Linear time-varying MPC on OSQP; satisfies :class:`~agvctl.controllers.base.PoseController`.

    The solver is set up once here; :meth:`reset` only recomputes the reference-dependent data. :meth:`update`
    never raises: when OSQP fails or hits its limits it returns a fallback (see
    :attr:`~agvctl.controllers.base.PoseCommand.status`) and counts it.

    Parameters
    ----------
    vehicle
        The controller's model: the wheel separation b (m), the sample period T_s (s) and the default wheel-speed
        and acceleration limits (m/s, m/s²).
    config
        Horizon, weights, limits, the prediction model and the governor, docking and solver settings
        (:class:`~agvctl.controllers.mpc.config.MpcConfig`, as in an experiment file's ``[controller]`` table).
    osqp_settings
        Entries that replace those of :data:`OSQP_SETTINGS`.
    """

    def __init__(
        self,
        vehicle: VehicleParams,
        config: MpcConfig | None = None,
        *,
        osqp_settings: Mapping[str, Any] | None = None,
    ) -> None:
        expect_instance(vehicle, VehicleParams, "LtvMpcController", "vehicle")
        if config is not None:
            expect_instance(config, MpcConfig, "LtvMpcController", "config")
        super().__init__(vehicle, config)
        if osqp_settings is not None:
            expect_instance(osqp_settings, Mapping, "LtvMpcController", "osqp_settings")
        self._osqp_overrides = dict(osqp_settings or {})
        self._lag = self.config.prediction_model == "kinematic+wheel_loop"
        self.nx = 5 if self._lag else 3
        self._build_problem()

    # -- public -------------------------------------------------------------------------------------------

    @property
    def predicted_setpoints_m_s(self) -> FloatArray:
        """The last solved setpoint sequence (N×2, left/right, m/s) — for plots and tests."""
        return self._fallback.sequence_m_s.copy()

    def _retarget(self, reference: Reference) -> HorizonReference:
        """Precompute ``reference``'s horizon grid and every time-varying matrix entry."""
        grid = HorizonReference(reference, self.config, self.sample_period_s)
        self._precompute(grid)
        self._heading_lin = 0.0
        return grid

    # -- problem structure --------------------------------------------------------------------------------

    def _build_problem(self) -> None:
        c, N, nx = self.config, self.config.horizon, self.nx
        layout = QpLayout(horizon=N, n_states=nx, wheel_loop=self._lag)
        self._iU, self._iS = layout.i_setpoints, layout.n_variables
        self._r_box, self._r_rate, self._r_first = layout.r_box, layout.r_rate, layout.r_first
        self._r_reach = layout.r_reach
        n_z, n_rows = layout.n_variables, layout.n_rows

        A, self._pos_A, self._pos_B = constraint_pattern(layout)
        self._A_data = A.data.copy()
        self._heading_lin = 0.0
        # the entries (position rows, wheel-speed columns) of A_1 … A_{N−1}: where driving with the present heading
        # error shows in the position error (see _solve), ordered by k, row, column
        nn = nx * nx
        self._pos_position_wheels = (
            np.column_stack(
                [self._pos_A[[(k - 1) * nn + i * nx + j for k in range(1, N) for j in (3, 4)]] for i in (0, 1)]
            )
            if self._lag
            else None
        )
        """Positions in the constraint matrix's data of A_k's (along or x, across or y) × (δv_l, δv_r) entries,
        k = 1 … N − 1: column 0 the first position row, column 1 the second."""

        P = cost_matrix(c, layout)
        self._P_data = P.data.copy()
        # the position weights of x_1 … x_N (along then across, by k): alone in their columns (diagonal state weights)
        columns = (np.arange(N)[:, None] * nx + np.arange(2)[None, :]).ravel()
        self._pos_P_position = P.indptr[columns].astype(np.int64)
        assert np.array_equal(P.indices[self._pos_P_position], columns)
        # the entries that vary from step to step, and the values OSQP holds of them (none yet: NaN differs from all)
        self._A_varying = np.unique(np.concatenate([self._pos_A, self._pos_B])).astype(np.int64)
        self._A_held = np.full(self._A_varying.size, np.nan)
        self._P_held = np.full(self._pos_P_position.size, np.nan)
        self._q = np.zeros(n_z)
        self._l = np.zeros(n_rows)
        self._u = np.zeros(n_rows)
        self._rate_c = np.zeros((N, 2))
        self._x0 = np.zeros(nx)
        self._start = np.zeros(2)
        self._zeros_z = np.zeros(n_z)
        self._zeros_y = np.zeros(n_rows)

        self._solver = osqp.OSQP()
        settings = {
            "eps_abs": c.tolerance,
            "eps_rel": c.tolerance,
            "max_iter": c.max_iterations,
            "time_limit": c.max_solve_time_s if c.max_solve_time_s is not None else 1.0e10,
            **OSQP_SETTINGS,
            **self._osqp_overrides,
        }
        try:
            self._solver.setup(P, self._q, A, self._l, self._u, **settings)
        except (TypeError, ValueError) as exc:  # OSQP's own refusal of a setting's name or value
            problem = " ".join(str(exc).split())
            raise ConfigError("LtvMpcController", "osqp_settings", problem) from None
        # at rest the problem above is the zero problem: A's varying entries are set at reset

    def _precompute(self, g: HorizonReference) -> None:
        """The discrete A_j, B_j of every interval of the reference, and the bound/cost data as flat arrays so
        that each step's values are contiguous slices."""
        c, nx, T, b = self.config, self.nx, self.sample_period_s, self.separation_m
        n = g.n_points - 1
        U, w, th = g.mid_speed_m_s, g.mid_yaw_rate_rad_s, g.mid_theta_rad
        M = np.zeros((n, nx + 2, nx + 2))
        if c.error_frame == "path":
            M[:, 0, 1], M[:, 1, 0], M[:, 1, 2] = w, -w, U
            be = np.array([[0.5, 0.5], [0.0, 0.0], [-1.0 / b, 1.0 / b]])
            Be = np.broadcast_to(be, (n, 3, 2))
        else:
            ct, st = np.cos(th), np.sin(th)
            M[:, 0, 2], M[:, 1, 2] = -U * st, U * ct
            Be = np.zeros((n, 3, 2))
            Be[:, 0, :] = 0.5 * ct[:, None]
            Be[:, 1, :] = 0.5 * st[:, None]
            Be[:, 2, :] = (-1.0 / b, 1.0 / b)
        if self._lag:
            inv_tau = 1.0 / wheel_loop_time_constant_s(c)
            M[:, 0:3, 3:5] = Be
            M[:, 3, 3] = M[:, 4, 4] = -inv_tau
            M[:, 3, 5] = M[:, 4, 6] = inv_tau
        else:
            M[:, 0:3, 3:5] = Be
        E = expm_batch(M * T)
        self._Ad = np.ascontiguousarray(E[:, :nx, :nx])
        self._neg_Ad_flat = np.ascontiguousarray(-self._Ad).reshape(n * nx * nx)
        self._neg_Bd_flat = np.ascontiguousarray(-E[:, :nx, nx:]).reshape(n * nx * 2)

        # the position weights (along, across) at each grid point: where the reference turns in place,
        # alike in every direction ("along the path" is only where a spinning frame points) and scaled by
        # turn_in_place_position_scale (the path is the turning point: any translation is off it)
        share = c.along_track_share if c.error_frame == "path" else 1.0
        spinning = turning_in_place(g.yaw_rate_rad_s, g.speed_m_s, b)
        weights = np.empty((g.n_points, 2))
        weights[:, 0] = np.where(spinning, c.turn_in_place_position_scale, share)
        weights[:, 1] = np.where(spinning, c.turn_in_place_position_scale, 1.0)
        self._position_weights = weights * 2.0 * c.weight_position
        self._horizon_scale = np.ones((c.horizon, 1))
        self._horizon_scale[-1] = c.weight_terminal_scale

        ff = g.feedforward_m_s
        v_max, a_step = self.max_wheel_speed_m_s, self.max_wheel_accel_m_s2 * T
        self._box_lo = (-v_max - ff).ravel()
        self._box_hi = (v_max - ff).ravel()
        d = np.zeros_like(ff)
        d[1:] = ff[1:] - ff[:-1]  # d_j = s_ff,j − s_ff,j−1: the rate of the feed-forward itself
        self._d_flat = d.ravel()
        self._rate_lo = (-a_step - d).ravel()
        self._rate_hi = (a_step - d).ravel()
        # s_k − v_k ∈ [−D↓, D↑] at the reference's wheel speeds: δs_k − δv_k ∈ v_ref − s_ff + [−D↓, D↑]
        up, down = self._reach.accel_m_s2(g.wheel_m_s[:-1])
        self._reach_base = (g.wheel_m_s[:-1] - ff).ravel()
        self._reach_down = (down * self._lead_factor_s).ravel()
        self._reach_up = (up * self._lead_factor_s).ravel()

    # -- one step -----------------------------------------------------------------------------------------

    def _initial_error(self, step: HorizonStep) -> FloatArray:
        """x_0: the pose (and wheel-speed) error against the reference at the governed clock, which lies a
        fraction of a sample past grid point k (0 while it keeps time)."""
        g, k, pose, wheel_speed_m_s = step.grid, step.k, step.pose, step.wheel_speed_m_s
        x0 = self._x0
        f = step.fraction
        x_ref, y_ref, th_ref = g.x_m[k], g.y_m[k], g.theta_rad[k]
        ct, st = g.cos_theta[k], g.sin_theta[k]
        wheel_ref = g.wheel_m_s[k]
        if f > 0.0:
            x_ref += f * (g.x_m[k + 1] - x_ref)
            y_ref += f * (g.y_m[k + 1] - y_ref)
            th_ref += f * wrap_angle(g.theta_rad[k + 1] - th_ref)
            ct, st = math.cos(th_ref), math.sin(th_ref)
            wheel_ref = wheel_ref + f * (g.wheel_m_s[k + 1] - wheel_ref)
        dx, dy = float(pose[0]) - x_ref, float(pose[1]) - y_ref
        if self.config.error_frame == "path":
            x0[0], x0[1] = ct * dx + st * dy, -st * dx + ct * dy
        else:
            x0[0], x0[1] = dx, dy
        x0[2] = wrap_angle(float(pose[2]) - th_ref)
        if self._lag:
            x0[3] = float(wheel_speed_m_s[0]) - wheel_ref[0]
            x0[4] = float(wheel_speed_m_s[1]) - wheel_ref[1]
        return x0

    def _couple_heading(self, g: HorizonReference, k: int, x0: FloatArray, first: FloatArray, data: FloatArray) -> None:
        """Linearised about the reference, the position error moves with δU along the reference's heading: blind,
        where the reference stands still (the start, a stop), to what driving with the present heading error e_θ,0
        does. About the present error δU moves it along θ_ref + e_θ,0, a change of (cos e_θ,0 − 1, sin e_θ,0) in
        the path frame (rotated by θ_ref in world axes), δU = (δv_l + δv_r)/2: first order in T_s, held over the
        horizon. Adds it to A_1 … A_{N−1} in ``data`` (which holds −A) and to A_0 x_0 in ``first``."""
        N, T = self.config.horizon, self.sample_period_s
        if abs(float(x0[2]) - self._heading_lin) > _RELINEARISE_RAD:
            self._heading_lin = float(x0[2])
        e0 = self._heading_lin
        if abs(e0) < 1e-4:  # below 0.006°: a change under 1e-6 of T_s per m/s, nothing to see
            return
        along, across = 0.5 * T * (math.cos(e0) - 1.0), 0.5 * T * math.sin(e0)
        rows = self._pos_position_wheels
        assert rows is not None
        if self.config.error_frame == "path":
            data[rows[:, 0]] -= along
            data[rows[:, 1]] -= across
            cx0, cy0 = along, across
        else:
            ct_h, st_h = g.cos_theta[k : k + N], g.sin_theta[k : k + N]
            cx, cy = ct_h * along - st_h * across, st_h * along + ct_h * across
            data[rows[:, 0]] -= np.repeat(cx[1:], 2)
            data[rows[:, 1]] -= np.repeat(cy[1:], 2)
            cx0, cy0 = float(cx[0]), float(cy[0])
        first[0] += cx0 * (x0[3] + x0[4])
        first[1] += cy0 * (x0[3] + x0[4])

    def _solve(self, step: HorizonStep) -> tuple[float, float] | None:
        g, k = step.grid, step.k
        c, N, nx = self.config, self.config.horizon, self.nx
        iU, iS = self._iU, self._iS
        x0 = self._initial_error(step)
        u_prev = step.previous_m_s
        if not math.isfinite(
            x0[0] + x0[1] + x0[2] + float(u_prev[0]) + float(u_prev[1]) + (x0[3] + x0[4] if self._lag else 0.0)
        ):
            return None  # a broken measurement: never let NaN into OSQP's warm start

        # A's time-varying entries: −A_{k+1} … −A_{k+N−1}, −B_k … −B_{k+N−1}
        data = self._A_data
        nn = nx * nx
        data[self._pos_A] = self._neg_Ad_flat[(k + 1) * nn : (k + N) * nn]
        data[self._pos_B] = self._neg_Bd_flat[k * nx * 2 : (k + N) * nx * 2]

        lo, hi = self._l, self._u
        first = self._Ad[k] @ x0
        if self._lag:
            self._couple_heading(g, k, x0, first, data)
        lo[:nx] = first
        hi[:nx] = first
        rb, rr, rf = self._r_box, self._r_rate, self._r_first
        lo[rb:rr] = self._box_lo[2 * k : 2 * (k + N)]
        hi[rb:rr] = self._box_hi[2 * k : 2 * (k + N)]
        lo[rr:rf] = self._rate_lo[2 * (k + 1) : 2 * (k + N)]
        hi[rr:rf] = self._rate_hi[2 * (k + 1) : 2 * (k + N)]
        ff0 = g.feedforward_m_s[k]
        # s_{−1} − s_ff,0, with s_{−1} brought into the speed box: the only case where the hard first-move
        # constraint could be infeasible is |s_{−1}| > v_max + a_lim·T_s, and there it is relaxed just enough
        v_max = self.max_wheel_speed_m_s
        start = self._start
        start[0] = min(max(float(u_prev[0]), -v_max), v_max)
        start[1] = min(max(float(u_prev[1]), -v_max), v_max)
        start -= ff0
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        lo[rf : rf + 2] = start - a_step
        hi[rf : rf + 2] = start + a_step
        if self._lag:
            assert step.window is not None  # finite wheel speeds: x_0 holds them
            self._reach_bounds(k, ff0, step.wheel_speed_m_s, step.window)

        # rate cost w_Δ‖D δs + r‖², r_0 = −start, r_k = d_{k+k'}: linear term 2 w_Δ Dᵀ r
        r = self._rate_c
        r[0] = -start
        r[1:] = self._d_flat[2 * (k + 1) : 2 * (k + N)].reshape(N - 1, 2)
        q = self._q
        qu = q[iU:iS].reshape(N, 2)
        np.subtract(r, 0.0, out=qu)
        qu[:-1] -= r[1:]
        qu *= 2.0 * c.weight_input_rate

        solver = self._solver
        solver.update(q=q, l=lo, u=hi)
        self._load_matrices(k)
        result = solver.solve(raise_error=False)
        z = result.x
        if result.info.status_val not in _ACCEPTED or not math.isfinite(float(z.sum())):
            solver.warm_start(x=self._zeros_z, y=self._zeros_y)  # do not start the next solve from garbage
            return None
        seq = g.feedforward_m_s[k : k + N] + z[iU:iS].reshape(N, 2)
        np.minimum(seq, v_max, out=seq)
        np.maximum(seq, -v_max, out=seq)
        self._fallback.store(k, seq)
        return float(seq[0, 0]), float(seq[0, 1])

    def _reach_bounds(
        self, k: int, ff0: FloatArray, wheel_speed_m_s: NDArray[np.float64], window: SetpointWindow
    ) -> None:
        """The setpoints' reachable leads over their wheels (the wheel-loop model's rows): the first sample's from the
        measured speed (within its speed box), later ones from the reference's speeds, never tighter than the first
        (so that holding the first setpoint stays feasible as the wheel converges)."""
        N, lo, hi = self.config.horizon, self._l, self._u
        rb, rc = self._r_box, self._r_reach
        window_lo, window_hi = window.lower_m_s, window.upper_m_s
        np.maximum(lo[rb : rb + 2], window_lo - ff0, out=lo[rb : rb + 2])
        np.minimum(hi[rb : rb + 2], window_hi - ff0, out=hi[rb : rb + 2])
        ahead = slice(2 * (k + 1), 2 * (k + N))
        if max(abs(float(wheel_speed_m_s[0])), abs(float(wheel_speed_m_s[1]))) <= self.max_wheel_speed_m_s:
            base = self._reach_base[ahead]
            lead_down = np.maximum(self._reach_down[ahead].reshape(-1, 2), window.lead_down_m_s).ravel()
            lead_up = np.maximum(self._reach_up[ahead].reshape(-1, 2), window.lead_up_m_s).ravel()
            lo[rc : rc + 2 * (N - 1)] = base - lead_down
            hi[rc : rc + 2 * (N - 1)] = base + lead_up
        else:  # a wheel beyond the speed box (a reset at speed): only the first sample is bounded
            lo[rc : rc + 2 * (N - 1)] = -_INF
            hi[rc : rc + 2 * (N - 1)] = _INF

    def _load_matrices(self, k: int) -> None:
        """Give OSQP this step's varying entries of P (the position weights of the window) and of A (set in
        ``_A_data`` by the step), only when they changed: an unchanged pair keeps OSQP's factorisation, which on a
        straight or a constant arc is most steps."""
        N, p_data = self.config.horizon, self._P_data
        p_data[self._pos_P_position] = (self._position_weights[k + 1 : k + N + 1] * self._horizon_scale).ravel()
        p_new, a_new = p_data[self._pos_P_position], self._A_data[self._A_varying]
        p_changed, a_changed = not np.array_equal(p_new, self._P_held), not np.array_equal(a_new, self._A_held)
        if not (p_changed or a_changed):
            return
        update: dict[str, FloatArray | NDArray[np.int64]] = {}
        if p_changed:
            update.update(Px=p_new, Px_idx=self._pos_P_position)
            self._P_held = p_new
        if a_changed:
            update.update(Ax=a_new, Ax_idx=self._A_varying)
            self._A_held = a_new
        self._solver.update(**update)
