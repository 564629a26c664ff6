"""What the two MPC pose controllers share: their configuration, the reference on the horizon grid, fallbacks.

Both controllers (:mod:`agvctl.controllers.mpc.ltv` on OSQP, :mod:`agvctl.controllers.mpc.nonlinear` on
CasADi) solve the same problem every sample period T_s:

    minimise  Σ_{k=1..N} ‖e_k‖²_Q (Q·terminal scale at k = N) + w_u Σ ‖s_k − s_ff,k‖²
              + w_Δ Σ_{k=0..N−1} ‖s_k − s_{k−1}‖²
    subject to the prediction model, |s_k| ≤ v_max and |s_k − s_{k−1}| ≤ a_lim·T_s (all hard)

with s_k the wheel-speed setpoints (left, right) in m/s held over sample k, e_k the pose error (position in
m, heading in rad) and s_ff the reference's feed-forward. The prediction model is the report's kinematics
(eqs 39-43: U = (v_r + v_l)/2, ω = (v_r − v_l)/b, ẋ = U cos θ, ẏ = U sin θ, θ̇ = ω) driven either directly
by the setpoints (``"kinematic"``) or through a first-order lag v̇ = (s − v)/τ standing for the closed
wheel-speed loop (``"kinematic+wheel_loop"``).

s_{−1} is the previous command (the measured wheel speeds at the first step after a reset): the setpoint
ramps at most at a_lim, and the wheel loop follows the ramp. Measured against the *measured* wheel speed
instead, the constraint would be violated through every acceleration (the loop lags its setpoint by about
τ·a > a_lim·T_s), so it would have to be soft all the time. The only case where the hard constraints are
infeasible is |s_{−1}| > v_max + a_lim·T_s (e.g. a measured speed over the limit at reset); there s_{−1} is
first clipped to ±v_max, which relaxes the first move just enough — the limit of an infinitely heavy slack
penalty, without the slack's poor conditioning (a slack weighted 10⁶ made OSQP need 400+ iterations in the
acceleration phases, where the reference sits exactly at a_lim and the rate constraints are degenerate).
"""

from __future__ import annotations

import math
import time
from typing import Any, overload

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.base import PoseCommand, SolveStatus
from agvctl.controllers.mpc.config import (
    DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S,
    MpcConfig,
    lead_factor_s,
    resolved_config,
    resolved_limits,
    wheel_loop_time_constant_s,
)
from agvctl.controllers.mpc.docking import Docking
from agvctl.controllers.mpc.fallback import SetpointFallback, limit_command
from agvctl.feasibility import WheelReach
from agvctl.planning.reference import Reference

__all__ = [
    "DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S",
    "MpcStepper",
    "HorizonReference",
    "START_TURN_FORWARD_SHARE",
    "MpcConfig",
    "SetpointFallback",
    "lead_factor_s",
    "limit_command",
    "resolved_config",
    "resolved_limits",
    "turning_in_place",
    "wheel_loop_time_constant_s",
]

FloatArray = NDArray[np.float64]

START_TURN_FORWARD_SHARE = 0.1
"""At the start of a forward path, before any turn in place, the command's mean speed is at least this share of its
wheels' speed difference: turning towards the path from rest with a zero mean, two wheels that break away unequally
(stiction, radii) move the centre backwards, away from a path the vehicle points at (by micrometres: over the 500
acceptance fuzz scenarios, 10-17 runs whose largest cross-track error is their start offset read 0.3-17 µm more than
Ramsete's, which drives straight off; 0.1 took 2 of them away on seed 10 and 6 on seed 77, with the median RMS error
unchanged; 0.2 took more but cost 3 % of it)."""


class HorizonReference:
    """The reference on the control grid t_j = j·T_s, sampled once at reset and padded with the final pose at
    rest so that any horizon window ``[k, k + N]`` is a slice.

    Arrays of length ``n_points`` (grid points, j = 0 … K + N + 1): ``x_m, y_m, theta_rad, speed_m_s,
    yaw_rate_rad_s, wheel_m_s`` (n×2). Arrays of length ``n_points − 1`` (intervals [t_j, t_j+1]):
    ``mid_*``, the reference at the midpoint of the interval, and ``feedforward_m_s`` (n×2), the setpoint
    that makes the prediction model follow the reference: the midpoint wheel speeds for the kinematic model,
    and for the wheel loop the inverse of its exact discretisation, s_j = (v_j+1 − a v_j)/(1 − a) with
    a = exp(−T_s/τ).
    """

    def __init__(self, reference: Reference, config: MpcConfig, sample_period_s: float) -> None:
        T = sample_period_s
        N = config.horizon
        self.sample_period_s = T
        self.last_start = len(reference.grid_times_s)
        """The largest window start: from here on the reference is at rest, so later windows are the same."""
        n = self.last_start + N + 2
        t = np.arange(n, dtype=np.float64) * T
        g = reference.sample(t)
        m = reference.sample(t[:-1] + 0.5 * T)
        self.n_points = n
        self.x_m, self.y_m, self.theta_rad = g.x_m, g.y_m, g.theta_rad
        self.cos_theta, self.sin_theta = np.cos(g.theta_rad), np.sin(g.theta_rad)
        self.speed_m_s, self.yaw_rate_rad_s = g.speed_m_s, g.yaw_rate_rad_s
        self.travel_m = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(g.x_m), np.diff(g.y_m)))))
        """Distance the reference point has moved by each grid point (m)."""
        self.wheel_m_s = np.column_stack([g.wheel_speed_left_m_s, g.wheel_speed_right_m_s])
        self.mid_theta_rad, self.mid_speed_m_s = m.theta_rad, m.speed_m_s
        self.mid_yaw_rate_rad_s = m.yaw_rate_rad_s
        mid_wheel = np.column_stack([m.wheel_speed_left_m_s, m.wheel_speed_right_m_s])
        if config.prediction_model == "kinematic":
            ff = mid_wheel
        else:
            a = math.exp(-T / wheel_loop_time_constant_s(config))
            ff = (self.wheel_m_s[1:] - a * self.wheel_m_s[:-1]) / (1.0 - a)
        self.feedforward_m_s: FloatArray = np.ascontiguousarray(ff)

    def window_start(self, t_s: float) -> int:
        """The grid index of the sample starting at ``t_s`` (rounded), clamped to ``[0, last_start]``."""
        k = round(t_s / self.sample_period_s)
        return min(max(k, 0), self.last_start)


@overload
def turning_in_place(yaw_rate_rad_s: float, speed_m_s: float, separation_m: float) -> bool: ...


@overload
def turning_in_place(yaw_rate_rad_s: FloatArray, speed_m_s: FloatArray, separation_m: float) -> NDArray[np.bool_]: ...


def turning_in_place(yaw_rate_rad_s: Any, speed_m_s: Any, separation_m: float) -> Any:
    """Whether the reference turns (almost) in place: its wheels' turning speed |ω|·b/2 above four times its speed
    (elementwise for arrays). There the path is a point, "along" it is only where a spinning frame points, and the
    governor measures the heading lag."""
    return abs(yaw_rate_rad_s) * 0.5 * separation_m > 4.0 * abs(speed_m_s) + 1e-6


class MpcStepper:
    """The step both MPCs share: the reference governor, the reachable-setpoint window, solve or fall back
    (shifted plan, then feed-forward), count, clip to limits.

    **Reference governor (graceful lag).** The controller tracks the reference at its own clock c (in samples),
    not at t/T_s: every step c advances by σ ∈ [0, 1], σ = 1 while the vehicle's lag behind the reference point
    stays under ``governor_lag_start_m`` and falling linearly to 0 (the reference waits) at ``governor_lag_stop_m``;
    below ``governor_lag_start_m`` it rises on the same line up to ``governor_catch_up`` while c is behind t/T_s, so
    a delay (an offset start, a weak stretch) is made up where the vehicle can, and c never runs ahead of t/T_s.
    The lag is the along-path error (in the reference's heading frame) or, in a turn in place, the heading lag
    times b/2 (the wheels' arc length). So a vehicle weaker than its model, or starting behind, falls behind
    *along* the path and stays on it instead of cutting corners after a point that runs away; the reference
    never runs more than a few centimetres ahead, and it reaches the end and stops there (the closed loop runs
    until c reaches the end: see :attr:`reference_time_s`). While the vehicle keeps up, c = t/T_s exactly and
    nothing changes.

    **In a turn in place, only towards the point.** Where the reference turns on the spot, a mean speed that would
    carry the vehicle away from the turning point is dropped from the command (the turn kept).

    **Reachable setpoints (anti-windup across the cascade).** Each wheel's setpoint stays within a bounded lead of
    its *measured* speed: s − v ∈ [−D↓, D↑], D = reach_lead·a_reach·T_s/(1 − e^(−T_s/τ)) for the wheel-loop lag τ
    (reach_lead·a_reach·T_s for the kinematic model), a_reach from :class:`~agvctl.actuator.WheelReach` (current
    limit, back-EMF and friction of the controller's model): for the first sample from the measured speed, for
    the predicted ones from the reference's (never tighter than the first, so the problem stays feasible). The
    previous command s_{−1} is brought into the same window before the solve, so the setpoints never run away
    from wheels that are current- or voltage-limited.

    Subclasses set ``_grid`` (a :class:`HorizonReference`, at reset), ``_fallback``, ``max_wheel_speed_m_s``,
    ``max_wheel_accel_m_s2``, ``sample_period_s``, ``separation_m``, ``_reach`` (the controller vehicle's
    :class:`~agvctl.actuator.WheelReach`), ``_lead_factor_s`` (D/a_reach) and implement
    ``_solve(k, pose, wheel_speed_m_s)``, returning the first setpoint pair or None on failure;
    ``_fraction`` ∈ [0, 1) is the governed clock's position between grid points k and k + 1.
    """

    _grid: HorizonReference | None
    _fallback: SetpointFallback
    _u_prev: NDArray[np.float64] | None
    _failures: int
    _reach: WheelReach
    _lead_factor_s: float
    max_wheel_speed_m_s: float
    max_wheel_accel_m_s2: float
    sample_period_s: float
    separation_m: float
    config: MpcConfig
    _lead_up_m_s: NDArray[np.float64] = np.zeros(2)
    _lead_down_m_s: NDArray[np.float64] = np.zeros(2)
    _window: tuple[NDArray[np.float64], NDArray[np.float64]] = (np.zeros(2), np.zeros(2))
    _docking: Docking
    _turned_in_place: NDArray[np.bool_] = np.zeros(1, dtype=np.bool_)
    _clock: float = -1.0
    """The governed reference clock in samples (−1: not started)."""
    _main_duration_s: float = 0.0
    _current_duration_s: float = 0.0
    _time_offset_s: float = 0.0
    _done: bool = False
    _fraction: float = 0.0

    @property
    def failures(self) -> int:
        """How many updates since construction fell back because the solver failed or ran out of time."""
        return self._failures

    @property
    def reference_time_s(self) -> float:
        """The reference time the controller is tracking (≤ t; equal to t while the vehicle keeps up). Just short
        of the reference's duration while the controller is still at work at its end (docking)."""
        if self._done:
            return max(self._main_duration_s, max(self._clock, 0.0) * self.sample_period_s)
        return min(max(self._clock, 0.0) * self.sample_period_s, self._main_duration_s - 1e-6)

    def _restart_clock(self) -> None:
        self._clock = -1.0
        self._fraction = 0.0

    def _retarget(self, reference: Reference) -> None:
        """Track ``reference`` from now on: its horizon grid and whatever the solver precomputes for it."""
        raise NotImplementedError

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` (precomputes its horizon data; clears warm starts and fallbacks)."""
        self._retarget(reference)
        g = self._grid
        assert g is not None
        spins = turning_in_place(g.yaw_rate_rad_s, g.speed_m_s, self.separation_m)
        self._turned_in_place = np.maximum.accumulate(spins)  # per grid point: turned in place by then
        self._u_prev = None
        self._restart_clock()
        self._main_duration_s = self._current_duration_s = reference.duration_s
        self._time_offset_s = 0.0
        self._done = False
        self._docking.reset(reference)

    def _at_the_end(self, t_s: float, pose: NDArray[np.float64], measured: NDArray[np.float64], at_end: bool) -> None:
        """At the end of the current reference: done, or (stopped beside the end, even after being done) start
        docking."""
        if not at_end:
            return
        if not (self.config.docking and self._docking.needed(pose)):
            self._done = True
            return
        if max(abs(float(measured[0])), abs(float(measured[1]))) > 0.01:
            return  # still moving: decide at rest
        manoeuvre = self._docking.plan(pose)
        if manoeuvre is None:
            self._done = True
            return
        self._done = False
        self._retarget(manoeuvre)
        self._current_duration_s = manoeuvre.duration_s
        self._restart_clock()
        self._time_offset_s = t_s + self.sample_period_s  # the manoeuvre's t = 0 is the next sample

    def setpoint_window_m_s(
        self, wheel_speed_m_s: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lower, upper) setpoints (left, right) each wheel can follow from ``wheel_speed_m_s`` (finite); the
        leads D↓, D↑ (m/s) are kept in ``_lead_down_m_s``, ``_lead_up_m_s``."""
        v_l, v_r = float(wheel_speed_m_s[0]), float(wheel_speed_m_s[1])
        up_l, up_r, down_l, down_r = self._reach.accel_pair_m_s2(v_l, v_r)
        f, v_max = self._lead_factor_s, self.max_wheel_speed_m_s
        self._lead_up_m_s = np.array([up_l * f, up_r * f])
        self._lead_down_m_s = np.array([down_l * f, down_r * f])
        # kept meeting the speed box, even from a measured speed beyond it
        lo = np.array([min(v_l - down_l * f, v_max), min(v_r - down_r * f, v_max)])
        hi = np.array([max(v_l + up_l * f, -v_max), max(v_r + up_r * f, -v_max)])
        return lo, hi

    def _starting_forward(self, g: HorizonReference, k: int) -> bool:
        """Whether the run is at the start of its path (the reference has moved less than 5 cm) and the path
        begins forwards (no backward speed over the horizon, some forward speed)."""
        if self._time_offset_s > 0.0 or g.travel_m[k] >= 0.05:
            return False
        ahead = g.speed_m_s[k : k + self.config.horizon + 1]
        return bool(np.min(ahead) >= -1e-9 and np.max(ahead) > 1e-6)

    def _lag_m(self, g: HorizonReference, clock: float, pose: NDArray[np.float64]) -> float:
        """How far the vehicle at ``pose`` is behind the reference at ``clock`` (samples): along the path, or in a
        turn in place the heading lag times b/2 or, if larger, the distance from the turning point (a weak wheel
        that cannot keep up with the spin pushes the vehicle off the point: the reference waits for it to get
        back); negative when ahead. Ahead in the turn the reference comes to it, at no more than its own pace while
        the vehicle is off the point (never held there: the MPC, predicting the reference turning on, would wait for
        it while it waited for the vehicle)."""
        k = min(int(clock), g.n_points - 2)
        f = clock - k
        x = g.x_m[k] + f * (g.x_m[k + 1] - g.x_m[k])
        y = g.y_m[k] + f * (g.y_m[k + 1] - g.y_m[k])
        th = g.theta_rad[k] + f * wrap_angle(g.theta_rad[k + 1] - g.theta_rad[k])
        along = math.cos(th) * (float(pose[0]) - x) + math.sin(th) * (float(pose[1]) - y)
        yaw = g.yaw_rate_rad_s[k]
        heading_lag = 0.0
        if turning_in_place(yaw, g.speed_m_s[k], self.separation_m):
            heading_lag = -math.copysign(1.0, yaw) * wrap_angle(float(pose[2]) - th) * 0.5 * self.separation_m
            off_point = math.hypot(float(pose[0]) - x, float(pose[1]) - y)
            if heading_lag < 0.0:  # ahead in the turn: the reference comes to it (at its own pace if off the point)
                start = self.config.governor_lag_start_m
                return float(heading_lag if off_point <= start else start)
            return float(max(heading_lag, off_point))
        return float(max(-along, heading_lag))

    def _toward_turning_point(
        self, g: HorizonReference, k: int, pose: NDArray[np.float64], left: float, right: float
    ) -> tuple[float, float]:
        """Where the reference turns in place, the setpoints (left, right) without their mean speed if it would carry
        the vehicle away from the turning point (the turn kept): the path there is the point, so moving away from it
        moves off the path. Driving along the heading with speed U changes the squared distance to the point at
        −2U·(distance ahead along the heading), so only a mean speed towards the point is kept."""
        if not turning_in_place(float(g.yaw_rate_rad_s[k]), float(g.speed_m_s[k]), self.separation_m):
            return left, right
        th = float(pose[2])
        ahead = math.cos(th) * (float(g.x_m[k]) - float(pose[0])) + math.sin(th) * (float(g.y_m[k]) - float(pose[1]))
        mean = 0.5 * (left + right)
        if mean * ahead < 0.0:
            return left - mean, right - mean
        return left, right

    def _advance_clock(self, g: HorizonReference, t_s: float, pose: NDArray[np.float64]) -> int:
        """Advance the governed clock for the sample at ``t_s``; the window start k (``_fraction`` set)."""
        c = self.config
        if not c.reference_governor:
            self._clock = float(g.window_start(t_s))
            self._fraction = 0.0
            return int(self._clock)
        if self._clock < 0.0:
            self._clock = float(g.window_start(t_s))
        else:
            lag = self._lag_m(g, self._clock + 1.0, pose)
            if not math.isfinite(lag):
                lag = 0.0
            band = max(c.governor_lag_stop_m - c.governor_lag_start_m, 1e-9)
            sigma = min(max((c.governor_lag_stop_m - lag) / band, 0.0), c.governor_catch_up)
            self._clock = min(self._clock + sigma, float(g.window_start(t_s)))  # never ahead of t
        k = int(self._clock)
        self._fraction = self._clock - k
        return k

    def _solve(
        self, k: int, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]
    ) -> tuple[float, float] | None:
        raise NotImplementedError

    def _on_failure(self) -> None:
        """Forget solver state that a failed solve may have spoiled (e.g. a warm start)."""

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """Setpoints for the sample starting at ``t_s`` (see
        :class:`~agvctl.controllers.base.PoseController`); ``solve_time_s`` is the whole step's wall time."""
        t0 = time.perf_counter()
        g = self._grid
        if g is None:
            raise RuntimeError(f"{type(self).__name__}.update called before reset(reference)")
        t_local = max(t_s - self._time_offset_s, 0.0)  # the time on the current reference (docking restarts it)
        k = self._advance_clock(g, t_local, pose)
        measured = np.asarray(wheel_speed_m_s, dtype=np.float64)
        finite = math.isfinite(float(measured[0])) and math.isfinite(float(measured[1]))
        lo, hi = self.setpoint_window_m_s(measured) if finite else (measured, measured)
        self._window = (lo, hi)
        a_step = self.max_wheel_accel_m_s2 * self.sample_period_s
        if self._u_prev is None:
            self._u_prev = measured.copy()
        elif finite:  # anti-windup: the previous command stays reachable from the wheels
            u = self._u_prev
            u[0] = min(max(float(u[0]), float(lo[0]) - a_step), float(hi[0]) + a_step)
            u[1] = min(max(float(u[1]), float(lo[1]) - a_step), float(hi[1]) + a_step)
        status: SolveStatus = "solved"
        try:
            setpoint = self._solve(k, pose, measured)
        except Exception:  # noqa: BLE001 - a solver failure must never stop the run
            setpoint = None
        if setpoint is None:
            self._failures += 1
            self._on_failure()
            shifted = self._fallback.shifted(k)
            if shifted is not None:
                left, right = shifted
                status = "fallback_shifted"
            else:
                left, right = float(g.feedforward_m_s[k, 0]), float(g.feedforward_m_s[k, 1])
                status = "fallback_feedforward"
        else:
            left, right = setpoint
        if self._starting_forward(g, k):
            # at the start of a forward path, never back up to a start point the vehicle is already past: the
            # reference comes to it (the turn is kept, the backward speed dropped); before any turn in place, keep
            # a forward mean so that a turn towards the path cannot back the centre away from it
            turned = bool(self._turned_in_place[min(k, len(self._turned_in_place) - 1)])
            least = 0.0 if turned else 0.5 * START_TURN_FORWARD_SHARE * abs(right - left)
            mean = 0.5 * (left + right)
            if mean < least:
                left, right = left + least - mean, right + least - mean
        left, right = self._toward_turning_point(g, k, pose, left, right)
        if finite:
            left = min(max(left, float(lo[0])), float(hi[0]))
            right = min(max(right, float(lo[1])), float(hi[1]))
        v_max = self.max_wheel_speed_m_s
        left = limit_command(left, self._u_prev[0], v_max, a_step)
        right = limit_command(right, self._u_prev[1], v_max, a_step)
        self._u_prev[0], self._u_prev[1] = left, right
        if finite:
            at_end = self._clock * self.sample_period_s >= self._current_duration_s - 1e-9
            self._at_the_end(t_s, pose, measured, at_end)
        return PoseCommand(left, right, time.perf_counter() - t0, status)
