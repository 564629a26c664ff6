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

The QP is built from named blocks (:mod:`~agvctl.controllers.mpc.ltv_qp`), the error frame and the prediction model are
strategies that supply its matrices (:mod:`~agvctl.controllers.mpc.error_frames`,
:mod:`~agvctl.controllers.mpc.prediction`). Everything that varies with time depends on the reference only, so each
block computes it for the whole reference at :meth:`LtvMpcController.reset`; a step is the initial error, each block's
handful of slice copies into OSQP's vectors and its CSC data arrays at the positions the builder computed, ``update``
and a warm-started ``solve``. OSQP is set up once, in the constructor, with every entry that can ever be nonzero in the
sparsity pattern.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import osqp
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.base import PoseCommand, SolveStatus
from agvctl.controllers.mpc.body_rate import BodyRate
from agvctl.controllers.mpc.c_solver import GeneratedOsqp, QpSolverError
from agvctl.controllers.mpc.c_step import StepParts, generate_step_c, step_tables
from agvctl.controllers.mpc.c_step_loop import CompiledController
from agvctl.controllers.mpc.c_update import WHEEL_CONSTANTS, generate_update_c
from agvctl.controllers.mpc.common import MpcStepper
from agvctl.controllers.mpc.config import MpcConfig, check_ltv_settings
from agvctl.controllers.mpc.docking import BACKING_STEPS
from agvctl.controllers.mpc.error_frames import ERROR_FRAMES
from agvctl.controllers.mpc.fallback import clamp
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.ltv_qp import (
    FirstMove,
    InputCost,
    QpReference,
    QpStep,
    Rate,
    Reversal,
    SpeedBox,
    StepBlock,
    StepQp,
    reversal_samples,
)
from agvctl.controllers.mpc.ltv_qp_model import Dynamics, StateCost
from agvctl.controllers.mpc.prediction import RELINEARISE_RAD
from agvctl.controllers.mpc.qp_blocks import BlockQp, VariableBlock
from agvctl.controllers.mpc.shaping import HorizonStep
from agvctl.errors import AgvctlError, ConfigError, expect_instance
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference

__all__ = ["LtvMpcController"]

FloatArray = NDArray[np.float64]

_ACCEPTED = (osqp.SolverStatus.OSQP_SOLVED, osqp.SolverStatus.OSQP_SOLVED_INACCURATE)
_C_STATUS: tuple[SolveStatus, ...] = ("solved", "fallback_shifted", "fallback_feedforward")
"""The generated controller step's codes, as statuses."""
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

    The solver is set up once here; :meth:`reset` only recomputes the reference-dependent data. When OSQP fails or
    hits its limits (its status) or raises its own exception, :meth:`update` returns a fallback (see
    :attr:`~agvctl.controllers.base.PoseCommand.status`) and counts it; any other exception propagates.

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

    keeps_body_bounds = True
    """The QP bounds its setpoints by the path's body bounds (a body-rate block), so the shaper bounds its commands
    by them too."""

    solver_errors = (osqp.OSQPException, QpSolverError)
    """OSQP's exceptions for an error in its own workings, in Python or in its generated C (a failed or unfinished
    solve is its status instead)."""

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
        check_ltv_settings(self.config)
        self._frame = ERROR_FRAMES[self.config.error_frame](self.config.horizon, self.sample_period_s)
        self.nx = self._model.n_states
        self._build_problem()

    # -- public -------------------------------------------------------------------------------------------

    @property
    def predicted_setpoints_m_s(self) -> FloatArray:
        """The last solved setpoint sequence (N×2, left/right, m/s) — for plots and tests."""
        if self._c is not None:
            return self._c.sequence()
        return self._fallback.sequence_m_s.copy()

    @property
    def qp(self) -> StepQp:
        """The assembled QP: its blocks, its matrices with every entry that can ever be nonzero and its vectors as
        the last step wrote them (what a generated solver of it is set up on,
        :func:`~agvctl.controllers.mpc.c_qp.generate_qp_c`)."""
        return self._qp

    @property
    def step_parts(self) -> StepParts:
        """What the QP's step in C is generated from (:func:`~agvctl.controllers.mpc.c_step.generate_step_c`): the QP,
        the error frame, the prediction model and the constants the step uses."""
        c, v_max = self.config, self.max_wheel_speed_m_s
        return StepParts(self._qp, self._frame, self._model, c.horizon, self.sample_period_s, v_max, RELINEARISE_RAD)

    def step_tables(self) -> list[FloatArray]:
        """The present reference's tables as the QP's step in C reads them
        (:func:`~agvctl.controllers.mpc.c_step.step_tables`).

        Returns
        -------
        list of ndarray
            One-dimensional arrays, in the order of the step's tables.

        Raises
        ------
        RuntimeError
            Before :meth:`reset`.
        """
        if self._grid is None:
            raise RuntimeError("LtvMpcController.step_tables called before reset(reference)")
        return step_tables(self._qp, self._grid)

    @property
    def last_start(self) -> int:
        """The present reference's last window start (0 before :meth:`reset`)."""
        return 0 if self._grid is None else self._grid.last_start

    @property
    def osqp_settings(self) -> dict[str, Any]:
        """OSQP's settings as the solver was set up with them: the config's tolerance and limits, then
        :data:`OSQP_SETTINGS`, then the constructor's overrides (what a generated solver of the QP uses too)."""
        return dict(self._osqp_settings)

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` as a new controller would: OSQP's iterates back to zero and its step size ρ
        (adapted during a run) back to its setting, so a run never depends on the runs before it."""
        super().reset(reference)
        self._solver.warm_start(x=self._zeros_z, y=self._zeros_y)
        self._solver.update_settings(rho=self._rho)
        if self._c is not None:
            self._c.set(**self.c_settings())
            self._c.reset()

    def _track(self, reference: Reference) -> HorizonReference:
        grid = super()._track(reference)
        if self._c is not None:
            self._c.track()
        return grid

    def observe_pose_covariance(self, covariance: FloatArray) -> None:
        """See :meth:`MpcStepper.observe_pose_covariance <agvctl.controllers.mpc.common.MpcStepper>`."""
        super().observe_pose_covariance(covariance)
        if self._c is not None:
            self._c.observe(covariance)

    def update(self, t_s: float, pose: FloatArray, wheel_speed_m_s: FloatArray) -> PoseCommand:
        """See :meth:`MpcStepper.update <agvctl.controllers.mpc.common.MpcStepper.update>`; with ``qp_solver =
        "osqp_c"`` the step is the generated C's (:mod:`~agvctl.controllers.mpc.c_update`), docking decided and
        planned here."""
        if self._c is None:
            return super().update(t_s, pose, wheel_speed_m_s)
        t0 = time.perf_counter()
        if self._grid is None:
            raise RuntimeError(f"{type(self).__name__}.update called before reset(reference)")
        end, measured = self._end, np.asarray(wheel_speed_m_s, dtype=np.float64)
        code, left, right = self._c.update(end.local_time_s(t_s), end.on_path, end.done, pose, measured)
        status: SolveStatus = _C_STATUS[code]
        if code:
            self._failures += 1
        self._governor.clock = clock = self._c.clock
        if math.isfinite(float(measured[0])) and math.isfinite(float(measured[1])):
            manoeuvre = end.after_step(t_s, clock * self.sample_period_s, pose, measured)
            if manoeuvre is not None:
                self._track(manoeuvre)
        return PoseCommand(left, right, time.perf_counter() - t0, status, reference_done=end.done)

    def c_docking(self) -> tuple[dict[str, float] | None, list[tuple[list[FloatArray], float] | None]]:
        """Docking for the generated C, planned ahead on the present path (after :meth:`reset`): what deciding takes
        (None with docking off) and, for each backing distance of :data:`~agvctl.controllers.mpc.docking.BACKING_STEPS`,
        the manoeuvre's tables and duration (s), or None where it backs up under 5 cm. Tracks each manoeuvre in turn:
        reset again before stepping.

        Returns
        -------
        tuple
            The constants, and the manoeuvres by steps from the fewest.
        """
        docking = self._end.docking
        if not docking.config.enabled:
            return None, []
        manoeuvres: list[tuple[list[FloatArray], float] | None] = []
        fewest, most = BACKING_STEPS
        for steps in range(fewest, most + 1):
            reference = docking.manoeuvre(steps)
            if reference is None:
                manoeuvres.append(None)
                continue
            grid = self._track(reference)
            manoeuvres.append((step_tables(self._qp, grid), reference.duration_s))
        return docking.constants, manoeuvres

    def c_settings(self) -> dict[str, float]:
        """The numbers the controller's step in C takes (:data:`~agvctl.controllers.mpc.c_update.UPDATE_SETTINGS`):
        its vehicle and settings, and what the present path sets (after :meth:`reset`; before, a path without
        limits).

        Returns
        -------
        dict of str to float
            Every name of ``UPDATE_SETTINGS`` and its value.
        """
        config, body = self.config, self._body
        u_fs, i_max, left, right = self._reach.constants
        enter, release, tolerance, end = self._rest.constants
        return dict(
            sample_period_s=self.sample_period_s,
            separation_m=self.separation_m,
            max_speed_m_s=self.max_wheel_speed_m_s,
            governor=float(config.reference_governor),
            lag_start_m=config.governor_lag_start_m,
            lag_stop_m=config.governor_lag_stop_m,
            catch_up=config.governor_catch_up,
            lead_factor_s=self._lead_factor_s,
            u_fs_v=u_fs,
            i_max_a=i_max,
            **{f"reach_left_{name}": v for name, v in zip(WHEEL_CONSTANTS, left, strict=True)},
            **{f"reach_right_{name}": v for name, v in zip(WHEEL_CONSTANTS, right, strict=True)},
            rest_enabled=float(config.rest.enabled),
            rest_max_error_m=config.rest.max_error_m,
            rest_stopped_m_s=config.rest.stopped_m_s,
            rest_enter=enter,
            rest_release=release,
            rest_tolerance_x=tolerance[0],
            rest_tolerance_y=tolerance[1],
            rest_tolerance_theta=tolerance[2],
            body_shaped=float(self.keeps_body_bounds),
            max_step_m_s=self._shaper.max_step_m_s,
            body_active=float(body.active),
            body_mean_step=body.mean_step_m_s,
            body_difference_step=body.difference_step_m_s,
            body_lateral=body.lateral_m2_s2,
            body_breakaway_share=body.breakaway_share,
            rest_end_x=end[0],
            rest_end_y=end[1],
            rest_end_theta=end[2],
        )

    def _retarget(self, reference: Reference) -> HorizonReference:
        """``reference``'s horizon grid, and each block's precompute for it."""
        if self._body.bounds_rates != self._with_body:
            self._build_problem()  # the body's rate rows where the path limits the body's motion, none elsewhere
        grid = HorizonReference(reference, self.config, self.sample_period_s, self._model)
        ff = grid.feedforward_m_s
        d = np.zeros_like(ff)
        d[1:] = ff[1:] - ff[:-1]
        self._ff_pairs: list[list[float]] = ff.tolist()  # per-step reads as plain floats
        self._model.restart()
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        self._qp.retarget(QpReference(grid, self.max_wheel_speed_m_s, a_step, d, self._reach, self._lead_factor_s))
        if self._c is not None:
            self._c.start(self._qp, step_tables(self._qp, grid))
        return grid

    # -- problem structure --------------------------------------------------------------------------------

    def _blocks(self) -> list[StepBlock]:
        """The QP's blocks in row order (:mod:`~agvctl.controllers.mpc.ltv_qp`): the constraints, then the cost."""
        c, N, T, b = self.config, self.config.horizon, self.sample_period_s, self.separation_m
        box = SpeedBox(N)
        M = reversal_samples(c)
        return [
            Dynamics(self._model, self._frame, N, T, b),
            box,
            Rate(N),
            FirstMove(),
            *self._model.constraint_blocks(N, box),
            *([BodyRate(N, self._body, box)] if self._body.bounds_rates else []),
            *([Reversal(M, c.weight_reversal)] if M else []),
            StateCost(c, self._frame, self.nx, b),
            InputCost(c),
        ]

    def _build_problem(self) -> None:
        c, N = self.config, self.config.horizon
        variables = [VariableBlock("states", N * self.nx), VariableBlock("setpoints", 2 * N)]
        self._with_body = self._body.bounds_rates
        self._qp: StepQp = BlockQp(variables, self._blocks())
        qp = self._qp
        self._i_setpoints = qp.layout.start("setpoints")
        self._x0 = np.zeros(self.nx)
        self._zeros_z = np.zeros(qp.layout.n_variables)
        self._zeros_y = np.zeros(qp.n_rows)

        settings = {
            "eps_abs": c.tolerance,
            "eps_rel": c.tolerance,
            "max_iter": c.max_iterations,
            "time_limit": c.max_solve_time_s if c.max_solve_time_s is not None else 1.0e10,
            **OSQP_SETTINGS,
            **self._osqp_overrides,
        }
        self._osqp_settings = settings
        self._rho = float(settings["rho"])
        try:
            self._solver = self._set_up(settings)
        except ConfigError:
            raise
        except (TypeError, ValueError) as exc:  # OSQP's own refusal of a setting's name or value
            problem = " ".join(str(exc).split())
            raise ConfigError("LtvMpcController", "osqp_settings", problem) from None
        # at rest the problem above is the zero problem: A's varying entries are set at reset

    def _set_up(self, settings: dict[str, Any]) -> osqp.OSQP | GeneratedOsqp:
        """The solver set up on the QP: OSQP, or its C generated for the QP, with the controller's step in C around it
        (``qp_solver``)."""
        qp = self._qp
        self._c: CompiledController | None = None
        if self.config.qp_solver == "osqp":
            solver = osqp.OSQP()
            solver.setup(qp.P, qp.q, qp.A, qp.lower, qp.upper, **settings)
            return solver
        try:
            origin, parts = "an LTV MPC in the closed loop", self.step_parts
            step = generate_step_c(parts, origin=origin, generator="agvctl")
            update = generate_update_c(parts, origin=origin, generator="agvctl")
            single = self.config.qp_solver == "osqp_c_float"
            generated = GeneratedOsqp(qp, settings, single=single, files={**step.files, **update.files})
            self._c = CompiledController(generated.solver, step, update)
            self._c.set(**self.c_settings())
            return generated
        except AgvctlError as exc:  # no compiler, or another OSQP release than the generator's
            problem = f"{self.config.qp_solver!r} cannot be used here: {exc}"
            raise ConfigError("LtvMpcController", "qp_solver", problem) from None

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
        x0[0], x0[1] = self._frame.position_error(float(pose[0]) - x_ref, float(pose[1]) - y_ref, ct, st)
        x0[2] = wrap_angle(float(pose[2]) - th_ref)
        self._model.wheel_errors(x0, step.wheel_speed_m_s, (wheel_l, wheel_r))
        return x0

    def _load_matrices(self, step: QpStep) -> dict[str, Any]:
        """This step's changed entries of P and A, as OSQP ``update`` arguments (see
        :meth:`~agvctl.controllers.mpc.qp_blocks.BlockQp.matrix_update`)."""
        return self._qp.matrix_update(step)

    def _solve(self, step: HorizonStep) -> tuple[float, float] | None:
        g, k, N = step.grid, step.k, self.config.horizon
        x0 = self._initial_error(step)
        e = x0.tolist()
        u_l, u_r = step.previous_m_s.tolist()
        if not math.isfinite(sum(e) + u_l + u_r):
            return None  # a broken measurement: never let NaN into OSQP's warm start
        ff_l, ff_r = self._ff_pairs[k]
        # s_{−1} − s_ff,0, with s_{−1} brought into the speed box (see FirstMove)
        v_max = self.max_wheel_speed_m_s
        start = (clamp(u_l, -v_max, v_max) - ff_l, clamp(u_r, -v_max, v_max) - ff_r)
        heading_rad, coupling = self._model.coupling(self._frame, g, k, e[2])
        qp_step = QpStep(k, x0, e, start, (ff_l, ff_r), heading_rad, coupling, step.wheel_speed_m_s, step.window)
        qp = self._qp
        qp.write(qp_step)
        solver = self._solver
        solver.update(q=qp.q, l=qp.lower, u=qp.upper, **self._load_matrices(qp_step))
        result = solver.solve(raise_error=False)
        z = result.x
        if result.info.status_val not in _ACCEPTED or not math.isfinite(np.add.reduce(z)):
            solver.warm_start(x=self._zeros_z, y=self._zeros_y)  # do not start the next solve from garbage
            return None
        iU = self._i_setpoints
        return self._fallback.store_solution(k, g.feedforward_m_s[k : k + N], z[iU : iU + 2 * N].reshape(N, 2), v_max)
