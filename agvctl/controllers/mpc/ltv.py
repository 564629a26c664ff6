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

The cost is the common one plus, over the first :data:`~agvctl.controllers.mpc.ltv_qp.REVERSAL_SAMPLES` samples,
``weight_reversal`` per m/s of a setpoint against the direction its wheel is headed along the reference (a linear
cost through slack variables, zero on the reference): a small start-up correction blends into driving off, a large
one still turns a wheel backwards.

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
from agvctl.controllers.mpc.fallback import clamp
from agvctl.controllers.mpc.horizon import HorizonReference, turning_in_place
from agvctl.controllers.mpc.ltv_qp import REVERSAL_SAMPLES, QpLayout, constraint_pattern, cost_matrix, window_versions
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

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` as a new controller would: OSQP's iterates back to zero and its step size ρ
        (adapted during a run) back to its setting, so a run never depends on the runs before it."""
        super().reset(reference)
        self._solver.warm_start(x=self._zeros_z, y=self._zeros_y)
        self._solver.update_settings(rho=self._rho)

    def _retarget(self, reference: Reference) -> HorizonReference:
        """Precompute ``reference``'s horizon grid and every time-varying matrix entry."""
        grid = HorizonReference(reference, self.config, self.sample_period_s)
        self._precompute(grid)
        self._heading_lin = 0.0
        return grid

    # -- problem structure --------------------------------------------------------------------------------

    def _build_problem(self) -> None:
        c, N, nx = self.config, self.config.horizon, self.nx
        M = min(N, REVERSAL_SAMPLES) if c.weight_reversal > 0 else 0
        layout = QpLayout(horizon=N, n_states=nx, wheel_loop=self._lag, reversal_samples=M)
        self._iU, self._iS = layout.i_setpoints, layout.i_slacks
        self._r_box, self._r_rate, self._r_first = layout.r_box, layout.r_rate, layout.r_first
        self._r_reach = layout.r_reach
        self._n_reversal = M
        self._r_reversal = layout.r_reversal
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
        # the entries that vary from step to step, and which window's values OSQP holds (none yet)
        self._A_varying = np.unique(np.concatenate([self._pos_A, self._pos_B])).astype(np.int64)
        self._A_held: tuple[int, float] | None = None
        self._P_held: int | None = None
        self._q = np.zeros(n_z)
        self._q_setpoints = self._q[self._iU : self._iS].reshape(N, 2)
        # the lower and upper bounds as the rows of one array, so that a step writes both with one copy
        self._bounds = np.zeros((2, n_rows))
        self._l, self._u = self._bounds[0], self._bounds[1]
        self._x0 = np.zeros(nx)
        self._lo_first, self._hi_first = self._l[:nx], self._u[:nx]
        self._first_box = self._bounds[:, self._r_box : self._r_box + 2]
        reach = slice(self._r_reach, self._r_reach + 2 * (N - 1))
        self._l_reach, self._u_reach = self._l[reach].reshape(-1, 2), self._u[reach].reshape(-1, 2)  # wheel-loop model
        self._coupling = np.zeros((N, 2))
        self._coupling_heading = math.nan
        """The heading e_θ,0 the path frame's coupling rows were written for (NaN: none yet)."""
        # the reversal slacks' linear cost w_r, their rows r_k ≥ 0; the other two rows' lower bounds are set per step
        self._q[self._iS :] = c.weight_reversal
        self._l[self._r_reversal + 4 * M :] = 0.0
        self._u[self._r_reversal :] = _INF
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
        self._rho = float(settings["rho"])
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
        self._box = np.stack([(-v_max - ff).ravel(), (v_max - ff).ravel()])  # (lower, upper) × flat samples
        d = np.zeros_like(ff)
        d[1:] = ff[1:] - ff[:-1]  # d_j = s_ff,j − s_ff,j−1: the rate of the feed-forward itself
        self._d_pairs: list[list[float]] = d.tolist()  # per-step reads as plain floats
        self._ff_pairs: list[list[float]] = ff.tolist()
        self._rate = np.stack([(-a_step - d).ravel(), (a_step - d).ravel()])
        # the reversal rows' lower bounds: r + δs ≥ −s_ff where the wheel heads forward, r − δs ≥ s_ff backward
        self._reversal_lower = np.stack(
            [np.where(g.direction > 0, -ff, -_INF).ravel(), np.where(g.direction < 0, ff, -_INF).ravel()]
        )
        # the rate cost's linear term (see _solve) where it depends on the reference only: 2 w_Δ (d_j − d_j+1)
        # for the inner samples, 2 w_Δ d_j for the last
        w_rate = 2.0 * c.weight_input_rate
        self._rate_q_inner = np.zeros_like(d)
        self._rate_q_inner[:-1] = (d[:-1] - d[1:]) * w_rate
        self._rate_q_last = (d - 0.0) * w_rate
        # s_k − v_k ∈ [−D↓, D↑] at the reference's wheel speeds: δs_k − δv_k ∈ v_ref − s_ff + [−D↓, D↑]
        up, down = self._reach.accel_m_s2(g.wheel_m_s[:-1])
        self._reach_base = g.wheel_m_s[:-1] - ff
        self._reach_down = down * self._lead_factor_s
        self._reach_up = up * self._lead_factor_s

        # which windows share their matrices: A's entries A_{k+1} … A_{k+N−1}, B_k … B_{k+N−1} (and in world axes
        # the headings θ_k … θ_{k+N−1} of the heading coupling), P's the weights of points k+1 … k+N
        N, windows = c.horizon, g.last_start + 1
        a_sources = [(self._Ad, 1, N - 1), (E[:, :nx, nx:], 0, N - 1)]
        if c.error_frame == "world":
            a_sources.append((np.column_stack([g.cos_theta, g.sin_theta]), 0, N - 1))
        self._a_version: list[int] = window_versions(a_sources, windows).tolist()
        self._p_version: list[int] = window_versions([(self._position_weights, 1, N)], windows).tolist()
        self._A_held = None
        self._P_held = None

    # -- one step -----------------------------------------------------------------------------------------

    def _initial_error(self, step: HorizonStep) -> FloatArray:
        """x_0: the pose (and wheel-speed) error against the reference at the governed clock, which lies a
        fraction of a sample past grid point k (0 while it keeps time)."""
        pose, x0, f = step.pose, self._x0, step.fraction
        ref = step.grid.points[step.k]
        x_ref, y_ref, th_ref, ct, st = ref.x_m, ref.y_m, ref.theta_rad, ref.cos_theta, ref.sin_theta
        wheel_l, wheel_r = ref.wheel_left_m_s, ref.wheel_right_m_s
        if f > 0.0:
            ahead = step.grid.points[step.k + 1]
            x_ref += f * (ahead.x_m - x_ref)
            y_ref += f * (ahead.y_m - y_ref)
            th_ref += f * wrap_angle(ahead.theta_rad - th_ref)
            ct, st = math.cos(th_ref), math.sin(th_ref)
            wheel_l += f * (ahead.wheel_left_m_s - wheel_l)
            wheel_r += f * (ahead.wheel_right_m_s - wheel_r)
        dx, dy = float(pose[0]) - x_ref, float(pose[1]) - y_ref
        if self.config.error_frame == "path":
            x0[0], x0[1] = ct * dx + st * dy, -st * dx + ct * dy
        else:
            x0[0], x0[1] = dx, dy
        x0[2] = wrap_angle(float(pose[2]) - th_ref)
        if self._lag:
            v_l, v_r = step.wheel_speed_m_s.tolist()
            x0[3], x0[4] = v_l - wheel_l, v_r - wheel_r
        return x0

    def _heading_coupling(self, g: HorizonReference, k: int, x0: FloatArray) -> tuple[float, FloatArray | None]:
        """Linearised about the reference, the position error moves with δU along the reference's heading: blind,
        where the reference stands still (the start, a stop), to what driving with the present heading error e_θ,0
        does. About the present error δU moves it along θ_ref + e_θ,0, a change of (cos e_θ,0 − 1, sin e_θ,0) in
        the path frame (rotated by θ_ref in world axes), δU = (δv_l + δv_r)/2: first order in T_s, held over the
        horizon. Returns the heading e_θ,0 the coupling is linearised about (0 for none) and the coupling's
        (first, second) position-row entries per unit δU for x_0 … x_{N−1} (N×2; None for none)."""
        N, T = self.config.horizon, self.sample_period_s
        heading = float(x0[2])
        if abs(heading - self._heading_lin) > _RELINEARISE_RAD:
            self._heading_lin = heading
        e0 = self._heading_lin
        if abs(e0) < 1e-4:  # below 0.006°: a change under 1e-6 of T_s per m/s, nothing to see
            return 0.0, None
        coupling = self._coupling
        if self.config.error_frame == "path":  # alike at every k: written again only for a new e_θ,0
            if e0 != self._coupling_heading:
                coupling[:, 0], coupling[:, 1] = 0.5 * T * (math.cos(e0) - 1.0), 0.5 * T * math.sin(e0)
                self._coupling_heading = e0
        else:
            along, across = 0.5 * T * (math.cos(e0) - 1.0), 0.5 * T * math.sin(e0)
            ct_h, st_h = g.cos_theta[k : k + N], g.sin_theta[k : k + N]
            coupling[:, 0] = ct_h * along - st_h * across
            coupling[:, 1] = st_h * along + ct_h * across
        return e0, coupling

    def _load_matrices(self, k: int, heading_rad: float, coupling: FloatArray | None) -> dict[str, Any]:
        """This step's varying entries of P (the position weights of the window) and of A (−A_{k+1} … −A_{k+N−1},
        −B_k … −B_{k+N−1} and the heading coupling), as OSQP ``update`` arguments, only where the window's version
        (:func:`~agvctl.controllers.mpc.ltv_qp.window_versions`) or the coupling's heading changed since OSQP last
        had them: unchanged, OSQP keeps its factorisation, which on a straight or a constant arc is most steps."""
        N, nx = self.config.horizon, self.nx
        update: dict[str, Any] = {}
        p_key = self._p_version[k]
        if p_key != self._P_held:
            p_data = self._P_data
            p_data[self._pos_P_position] = (self._position_weights[k + 1 : k + N + 1] * self._horizon_scale).ravel()
            update.update(Px=p_data[self._pos_P_position], Px_idx=self._pos_P_position)
            self._P_held = p_key
        a_key = (self._a_version[k], heading_rad)
        if a_key != self._A_held:
            data, nn = self._A_data, nx * nx
            data[self._pos_A] = self._neg_Ad_flat[(k + 1) * nn : (k + N) * nn]
            data[self._pos_B] = self._neg_Bd_flat[k * nx * 2 : (k + N) * nx * 2]
            if coupling is not None:  # −A: the coupling of x_1 … x_{N−1} subtracted, alike for both wheels
                rows = self._pos_position_wheels
                assert rows is not None
                data[rows[:, 0]] -= np.repeat(coupling[1:, 0], 2)
                data[rows[:, 1]] -= np.repeat(coupling[1:, 1], 2)
            update.update(Ax=data[self._A_varying], Ax_idx=self._A_varying)
            self._A_held = a_key
        return update

    def _solve(self, step: HorizonStep) -> tuple[float, float] | None:
        g, k = step.grid, step.k
        N, iU, iS = self.config.horizon, self._iU, self._iS
        x0 = self._initial_error(step)
        e = x0.tolist()
        u_l, u_r = step.previous_m_s.tolist()
        if not math.isfinite(e[0] + e[1] + e[2] + u_l + u_r + (e[3] + e[4] if self._lag else 0.0)):
            return None  # a broken measurement: never let NaN into OSQP's warm start

        lo, hi, bounds = self._l, self._u, self._bounds
        first = np.dot(self._Ad[k], x0, out=self._lo_first)  # A_0 x_0, into the lower bounds' first rows
        heading_rad, coupling = self._heading_coupling(g, k, x0) if self._lag else (0.0, None)
        if coupling is not None:
            first[0] += coupling[0, 0] * (e[3] + e[4])
            first[1] += coupling[0, 1] * (e[3] + e[4])
        self._hi_first[:] = first
        rb, rr, rf = self._r_box, self._r_rate, self._r_first
        bounds[:, rb:rr] = self._box[:, 2 * k : 2 * (k + N)]
        bounds[:, rr:rf] = self._rate[:, 2 * (k + 1) : 2 * (k + N)]
        ff_l, ff_r = self._ff_pairs[k]
        # s_{−1} − s_ff,0, with s_{−1} brought into the speed box: the only case where the hard first-move
        # constraint could be infeasible is |s_{−1}| > v_max + a_lim·T_s, and there it is relaxed just enough
        v_max = self.max_wheel_speed_m_s
        start_l = clamp(u_l, -v_max, v_max) - ff_l
        start_r = clamp(u_r, -v_max, v_max) - ff_r
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        lo[rf], lo[rf + 1] = start_l - a_step, start_r - a_step
        hi[rf], hi[rf + 1] = start_l + a_step, start_r + a_step
        if M := self._n_reversal:
            r = self._r_reversal
            lo[r : r + 4 * M].reshape(2, 2 * M)[:] = self._reversal_lower[:, 2 * k : 2 * (k + M)]
        if self._lag:
            assert step.window is not None  # finite wheel speeds: x_0 holds them
            self._reach_bounds(k, (ff_l, ff_r), step.wheel_speed_m_s, step.window)

        # rate cost w_Δ‖D δs + r‖², r_0 = −s_{−1} + s_ff,0, r_j = d_{k+j}: linear term 2 w_Δ Dᵀ r, i.e.
        # 2 w_Δ (r_j − r_{j+1}) and 2 w_Δ r_{N−1} for the last
        qu = self._q_setpoints
        w_rate = 2.0 * self.config.weight_input_rate
        if N > 1:
            d_l, d_r = self._d_pairs[k + 1]
            qu[0, 0], qu[0, 1] = (-start_l - d_l) * w_rate, (-start_r - d_r) * w_rate
            qu[1 : N - 1] = self._rate_q_inner[k + 1 : k + N - 1]
            qu[N - 1] = self._rate_q_last[k + N - 1]
        else:
            qu[0, 0], qu[0, 1] = (-start_l - 0.0) * w_rate, (-start_r - 0.0) * w_rate

        solver = self._solver
        solver.update(q=self._q, l=lo, u=hi, **self._load_matrices(k, heading_rad, coupling))
        result = solver.solve(raise_error=False)
        z = result.x
        if result.info.status_val not in _ACCEPTED or not math.isfinite(np.add.reduce(z)):
            solver.warm_start(x=self._zeros_z, y=self._zeros_y)  # do not start the next solve from garbage
            return None
        return self._fallback.store_solution(k, g.feedforward_m_s[k : k + N], z[iU:iS].reshape(N, 2), v_max)

    def _reach_bounds(
        self, k: int, ff0: tuple[float, float], wheel_speed_m_s: NDArray[np.float64], window: SetpointWindow
    ) -> None:
        """The setpoints' reachable leads over their wheels (the wheel-loop model's rows): the first sample's from the
        measured speed (within its speed box), later ones from the reference's speeds, never tighter than the first
        (so that holding the first setpoint stays feasible as the wheel converges). ``ff0`` is the first sample's
        feed-forward (left, right; m/s)."""
        N, (ff_l, ff_r), lo, hi, rb = self.config.horizon, ff0, self._l, self._u, self._r_box
        (box_lo_l, box_lo_r), (box_hi_l, box_hi_r) = self._first_box.tolist()
        (lower_l, lower_r), (upper_l, upper_r) = window.lower_m_s, window.upper_m_s
        lo[rb], lo[rb + 1] = max(box_lo_l, lower_l - ff_l), max(box_lo_r, lower_r - ff_r)
        hi[rb], hi[rb + 1] = min(box_hi_l, upper_l - ff_l), min(box_hi_r, upper_r - ff_r)
        lo_reach, hi_reach = self._l_reach, self._u_reach
        v_l, v_r = wheel_speed_m_s.tolist()
        if max(abs(v_l), abs(v_r)) <= self.max_wheel_speed_m_s:
            base = self._reach_base[k + 1 : k + N]
            np.maximum(self._reach_down[k + 1 : k + N], window.lead_down_m_s, out=lo_reach)
            np.subtract(base, lo_reach, out=lo_reach)
            np.maximum(self._reach_up[k + 1 : k + N], window.lead_up_m_s, out=hi_reach)
            np.add(base, hi_reach, out=hi_reach)
        else:  # a wheel beyond the speed box (a reset at speed): only the first sample is bounded
            lo_reach[:] = -_INF
            hi_reach[:] = _INF
