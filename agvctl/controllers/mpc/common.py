"""What the two MPC pose controllers share: their configuration, the reference on the horizon grid, fallbacks.

Both controllers (:mod:`agvctl.controllers.mpc.ltv` on OSQP, :mod:`agvctl.controllers.mpc.nonlinear` on
CasADi) solve the same problem every sample period T_s::

    minimise  Σ_{k=1..N} ‖e_k‖²_Q (Q·terminal scale at k = N) + w_u Σ ‖s_k − s_ff,k‖²
              + w_Δ Σ_{k=0..N−1} ‖s_k − s_{k−1}‖²
    subject to the prediction model, |s_k| ≤ v_max and |s_k − s_{k−1}| ≤ a_lim·T_s (all hard)

with s_k the wheel-speed setpoints (left, right) in m/s held over sample k, e_k the pose error (position in
m, heading in rad) and s_ff the reference's feed-forward. The prediction model is the report's kinematics
(eqs 39-43: U = (v_r + v_l)/2, ω = (v_r − v_l)/b, ẋ = U cos θ, ẏ = U sin θ, θ̇ = ω) driven either directly
by the setpoints (``"kinematic"``) or through a first-order lag v̇ = (s − v)/τ standing for the closed
wheel-speed loop (``"kinematic+wheel_loop"``). The LTV MPC adds a linear cost on the first samples' setpoints
against the direction their wheels are headed (``weight_reversal``, :mod:`~agvctl.controllers.mpc.ltv`).

s_{−1} is the previous command (the measured wheel speeds at the first step after a reset): the setpoint
ramps at most at a_lim, and the wheel loop follows the ramp. Measured against the *measured* wheel speed
instead, the constraint would be violated through every acceleration (the loop lags its setpoint by about
τ·a > a_lim·T_s), so it would have to be soft all the time. The only case where the hard constraints are
infeasible is ``|s_{−1}| > v_max + a_lim·T_s`` (e.g. a measured speed over the limit at reset); there s_{−1} is
first clipped to ±v_max, which relaxes the first move just enough — the limit of an infinitely heavy slack
penalty, without the slack's poor conditioning where the reference sits exactly at a_lim and the rate constraints
are degenerate (``docs/decisions/0012-osqp.md``).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import PoseCommand, SolveStatus
from agvctl.controllers.mpc.body_bounds import BodyBounds
from agvctl.controllers.mpc.config import MpcConfig, resolved_config, resolved_limits
from agvctl.controllers.mpc.docking import Docking, EndOfPath
from agvctl.controllers.mpc.fallback import SetpointFallback
from agvctl.controllers.mpc.governor import ReferenceGovernor
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.prediction import PREDICTION_MODELS, PredictionModel
from agvctl.controllers.mpc.rest import Rest
from agvctl.controllers.mpc.shaping import (
    CommandShaper,
    HorizonStep,
    NoBackingAtStart,
    ReachWindow,
    TowardTurningPoint,
)
from agvctl.feasibility import WheelReach, feedback_accel_m_s2
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference

__all__ = ["MpcStepper"]

FloatArray = NDArray[np.float64]


class MpcStepper:
    """The step both MPCs share, composed of named parts:

    * the reference governor (:class:`~agvctl.controllers.mpc.governor.ReferenceGovernor`) sets the window on the
      horizon grid (:class:`~agvctl.controllers.mpc.horizon.HorizonReference`);
    * the reachable-setpoint window (:class:`~agvctl.controllers.mpc.shaping.ReachWindow`) bounds the setpoints
      by what the wheels can follow;
    * the solver (a subclass's :meth:`_solve`) gives the first setpoints of the horizon, or the fallback
      (:class:`~agvctl.controllers.mpc.fallback.SetpointFallback`: the shifted plan, then the feed-forward) does;
    * the command shaper (:class:`~agvctl.controllers.mpc.shaping.CommandShaper`) applies the rules of motion,
      the window, the bounds on the body's motion and the hard limits;
    * at the end of the path, :class:`~agvctl.controllers.mpc.docking.EndOfPath` decides whether to dock, and
      :class:`~agvctl.controllers.mpc.rest.Rest` whether to hold the wheels instead of solving: done, the error
      within the pose estimate's uncertainty (:meth:`observe_pose_covariance`).

    A subclass builds its solver in its constructor (after this one's) and implements :meth:`_retarget` (the grid
    of a new reference, and whatever the solver precomputes for it), :meth:`_solve` and, if a failed solve can spoil
    its state, :meth:`_on_failure`; it names in :attr:`solver_errors` the exceptions its solver raises for its own
    failures.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: the wheel separation b (m), the sample period T_s (s), the default wheel-speed and
        acceleration limits (m/s, m/s²) and what each wheel can reach (its motor's current limit, back-EMF and
        friction).
    config : MpcConfig or None
        The settings (None: the defaults); an unset wheel-loop time constant becomes
        :data:`~agvctl.controllers.mpc.config.DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S`.
    """

    solver_errors: tuple[type[Exception], ...] = ()
    """The exceptions the solver raises to report a failure of its own: counted and fallen back from, like a solve
    :meth:`_solve` reports as failed (None). Any other exception is a fault in the step (an index out of range, a
    wrong shape) and propagates, so that the run reports it as its error rather than as a solver failure
    (``docs/decisions/0015-run-errors-exit-3.md``)."""

    keeps_body_bounds: bool = False
    """Whether the solver constrains its setpoints by the path's body bounds
    (:class:`~agvctl.controllers.mpc.body_bounds.BodyBounds`): only then does the command shaper bound the commands
    by them too. Commands bounded behind the back of a solver that plans without the bounds leave its predictions
    wrong, and its corrections grow instead of settling."""

    def __init__(self, vehicle: VehicleParams, config: MpcConfig | None) -> None:
        self.config = c = resolved_config(config or MpcConfig())
        self.sample_period_s = vehicle.control.sample_period_s
        self.separation_m = vehicle.wheels.separation_m
        self.max_wheel_speed_m_s, self.max_wheel_accel_m_s2 = resolved_limits(c, vehicle)
        self._vehicle_accel_m_s2 = self.max_wheel_accel_m_s2
        self._feedback_accel_m_s2 = feedback_accel_m_s2(vehicle)
        self._model: PredictionModel = PREDICTION_MODELS[c.prediction_model](c, self.sample_period_s)
        self._lead_factor_s = self._model.lead_factor_s
        self._reach = WheelReach(vehicle)
        self._window = ReachWindow(self._reach, self._lead_factor_s, self.max_wheel_speed_m_s)
        self._governor = ReferenceGovernor(c, self.separation_m)
        rules = (NoBackingAtStart(c.horizon), TowardTurningPoint(self.separation_m))
        self._body = BodyBounds(self.sample_period_s, self.separation_m, c.body_command_share, c.body_breakaway_share)
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        body = self._body if self.keeps_body_bounds else None
        self._shaper = CommandShaper(rules, self.max_wheel_speed_m_s, a_step, body)
        self._end = EndOfPath(Docking(vehicle, c.docking), self.sample_period_s)
        self._rest = Rest(c.rest)
        self._fallback = SetpointFallback(c.horizon)
        self._grid: HorizonReference | None = None
        self._failures = 0

    @property
    def failures(self) -> int:
        """How many updates since construction fell back because the solver failed or ran out of time."""
        return self._failures

    @property
    def reference_time_s(self) -> float:
        """The time on the path being tracked (≤ t; equal to t while the vehicle keeps up); the path's duration
        while a docking manoeuvre is under way."""
        if not self._end.on_path:
            return self._end.path_duration_s
        return min(self._governor.time_s(self.sample_period_s), self._end.path_duration_s)

    def _retarget(self, reference: Reference) -> HorizonReference:
        """Track ``reference`` from now on: its horizon grid and whatever the solver precomputes for it."""
        raise NotImplementedError

    def _solve(self, step: HorizonStep) -> tuple[float, float] | None:
        """The first setpoints (left, right; m/s) of the horizon solved for ``step``, or None on failure."""
        raise NotImplementedError

    def _on_failure(self) -> None:
        """Forget solver state that a failed solve may have spoiled (e.g. a warm start)."""

    def _track(self, reference: Reference) -> HorizonReference:
        self._grid = grid = self._retarget(reference)
        self._fallback.clear()
        self._governor.restart()
        return grid

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` (precomputes its horizon data; clears warm starts and fallbacks). Unless the
        settings fix a_lim, the setpoints change no faster than the reference's own acceleration limit plus what
        the planner leaves to the feedback (:func:`~agvctl.feasibility.feedback_accel_m_s2`), at most eq 5's a_lim:
        a path planned gently for its load is tracked gently, start-up corrections, turns and stops included. Where
        the solver :attr:`keeps_body_bounds`, the path's limits on the body's motion bound every command
        (:class:`~agvctl.controllers.mpc.body_bounds.BodyBounds`)."""
        if self.config.max_wheel_accel_m_s2 is None:
            planned = reference.limits.wheel_accel_m_s2 + self._feedback_accel_m_s2
            self.max_wheel_accel_m_s2 = min(self._vehicle_accel_m_s2, planned)
            self._shaper.max_step_m_s = self.max_wheel_accel_m_s2 * self.sample_period_s
        self._body.reset(reference.limits.body)
        grid = self._track(reference)
        self._shaper.reset(grid)
        self._end.reset(reference)
        self._rest.reset(reference)

    def observe_pose_covariance(self, covariance: NDArray[np.float64]) -> None:
        """The pose estimate's 3×3 covariance at this sample (the closed loop passes it for an estimator that has
        one): how far the end pose the controller sees can be from the truth."""
        self._rest.observe(covariance)
        self._end.docking.observe(covariance)

    def _solve_or_fall_back(self, step: HorizonStep) -> tuple[float, float, SolveStatus]:
        try:
            setpoint = self._solve(step)
        except self.solver_errors:  # the solver's own failure: fall back (any other exception is a fault)
            setpoint = None
        if setpoint is not None:
            return setpoint[0], setpoint[1], "solved"
        self._failures += 1
        self._on_failure()
        shifted = self._fallback.shifted(step.k)
        if shifted is not None:
            return shifted[0], shifted[1], "fallback_shifted"
        ff = step.grid.feedforward_m_s[step.k]
        return float(ff[0]), float(ff[1]), "fallback_feedforward"

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """Setpoints for the sample starting at ``t_s`` (see
        :class:`~agvctl.controllers.base.PoseController`); ``solve_time_s`` is the whole step's wall time."""
        t0 = time.perf_counter()
        grid = self._grid
        if grid is None:
            raise RuntimeError(f"{type(self).__name__}.update called before reset(reference)")
        k = self._governor.advance(grid, self._end.local_time_s(t_s), pose)
        measured = np.asarray(wheel_speed_m_s, dtype=np.float64)
        window = self._window(measured)
        previous = self._shaper.previous(measured, window)
        step = HorizonStep(grid, k, self._governor.fraction, pose, measured, window, previous, self._end.on_path)
        status: SolveStatus = "solved"
        if self._rest(pose, measured, self._end.done):
            left, right = 0.0, 0.0  # within what the estimate knows: hold, nothing to solve
        else:
            left, right, status = self._solve_or_fall_back(step)
        left, right = self._shaper(step, left, right)
        if window is not None:
            clock_s = self._governor.clock * self.sample_period_s
            manoeuvre = self._end.after_step(t_s, clock_s, pose, measured)
            if manoeuvre is not None:
                self._track(manoeuvre)
        return PoseCommand(left, right, time.perf_counter() - t0, status, reference_done=self._end.done)
