"""The bounds on the body's motion that a command keeps: the path's limits on the body's acceleration, as the
commands may use them.

A pair of wheel-speed setpoints (s_l, s_r) commands the body's speed U = (s_l + s_r)/2 and yaw rate
ω = (s_r − s_l)/b (eqs 39-40). Where the path limits the body's acceleration (:class:`~agvctl.planning.BodyLimits`),
the commands change by at most a share (``body_command_share``) of it per sample:

* |ΔU| ≤ share · ``linear_accel_m_s2`` · T_s and |Δω| ≤ share · ``angular_accel_rad_s2`` · T_s, from the previous
  command;
* |U ω| ≤ share · ``lateral_accel_m_s2``: a command's centripetal acceleration.

While a wheel is at or near rest (below :data:`NEAR_REST_SPEED_M_S`), a step uses ``body_breakaway_share`` of these:
within a sample or two the wheel breaks away, stops or reverses, and there its friction jumps (from holding to
sliding, or across zero speed) faster than the wheel loop acts, so what the body feels is that jump on top of the
step. The LTV
MPC constrains its setpoints by the same bounds (:class:`~agvctl.controllers.mpc.body_rate.BodyRate`); the command
shaper (:class:`~agvctl.controllers.mpc.shaping.CommandShaper`) applies them to every command, a fallback's and the
rest's included. A path with no such limit leaves every command as it was.
"""

from __future__ import annotations

import math

from agvctl.controllers.mpc.fallback import clamp
from agvctl.planning.spec import BodyLimits

__all__ = ["NEAR_REST_SPEED_M_S", "BodyBounds"]

NEAR_REST_SPEED_M_S = 0.01
"""A wheel slower than 1 cm/s is at rest or about to be: within a sample or two it breaks away from its stiction,
stops, or reverses, and its friction jumps. Wide enough to take in the stops and reversals, narrow enough that
start-up corrections keep their pace (``docs/decisions/0041-what-the-payload-feels.md``)."""


class BodyBounds:
    """The per-sample bounds on the commanded body motion of one path (see the module notes).

    Parameters
    ----------
    sample_period_s : float
        T_s, s.
    separation_m : float
        The wheel separation b, m.
    command_share : float
        The share of each limit the commands use, in (0, 1].
    breakaway_share : float
        The share of the per-sample bounds a step uses while a wheel is at or near rest, in (0, 1].
    """

    def __init__(
        self, sample_period_s: float, separation_m: float, command_share: float, breakaway_share: float
    ) -> None:
        self.sample_period_s = sample_period_s
        self.separation_m = separation_m
        self.command_share = command_share
        self.breakaway_share = breakaway_share
        self.reset(BodyLimits())

    def reset(self, body: BodyLimits) -> None:
        """Take the limits of a new path.

        Parameters
        ----------
        body : BodyLimits
            The path's limits on the body's motion.
        """
        share, T, b = self.command_share, self.sample_period_s, self.separation_m
        a, alpha, lateral = body.linear_accel_m_s2, body.angular_accel_rad_s2, body.lateral_accel_m_s2
        self.mean_step_m_s = math.inf if a is None else share * a * T
        """The largest change of the setpoints' mean per sample, m/s (inf: none)."""
        self.difference_step_m_s = math.inf if alpha is None else share * alpha * T * b
        """The largest change of their difference s_r − s_l per sample, m/s (inf: none)."""
        self.lateral_m2_s2 = math.inf if lateral is None else share * lateral * b
        """The largest ``|mean · difference|``, U ω b, m²/s² (inf: none)."""
        self.bounds_rates = not (math.isinf(self.mean_step_m_s) and math.isinf(self.difference_step_m_s))
        """Whether a bound acts on the change of the mean or the difference (what a solver's rate rows bound)."""
        self.active = self.bounds_rates or not math.isinf(self.lateral_m2_s2)
        """Whether any bound acts."""

    def first_steps(self, speed_left_m_s: float, speed_right_m_s: float) -> tuple[float, float]:
        """The largest changes of the mean and the difference from the previous command at this sample.

        Parameters
        ----------
        speed_left_m_s, speed_right_m_s : float
            The measured wheel speeds, m/s.

        Returns
        -------
        tuple of float
            (mean, difference), m/s: the bounds, times ``breakaway_share`` while a wheel is at or near rest.
        """
        scale = 1.0
        if min(abs(speed_left_m_s), abs(speed_right_m_s)) < NEAR_REST_SPEED_M_S:
            scale = self.breakaway_share
        return scale * self.mean_step_m_s, scale * self.difference_step_m_s

    def command(
        self, left: float, right: float, previous: tuple[float, float], wheel_speed_m_s: tuple[float, float]
    ) -> tuple[float, float]:
        """The setpoints (left, right; m/s) brought within the bounds from the previous command.

        Parameters
        ----------
        left, right : float
            The setpoints, m/s.
        previous : tuple of float
            The previous command (left, right), m/s.
        wheel_speed_m_s : tuple of float
            The measured wheel speeds (left, right), m/s.

        Returns
        -------
        tuple of float
            The setpoints, unchanged where no bound acts.
        """
        if not self.active:
            return left, right
        step_mean, step_difference = self.first_steps(*wheel_speed_m_s)
        mean0, difference0 = 0.5 * (previous[0] + previous[1]), previous[1] - previous[0]
        mean = clamp(0.5 * (left + right), mean0 - step_mean, mean0 + step_mean)
        difference = right - left
        if not math.isinf(self.lateral_m2_s2) and mean != 0.0:
            cap = self.lateral_m2_s2 / abs(mean)
            difference = clamp(difference, -cap, cap)
        difference = clamp(difference, difference0 - step_difference, difference0 + step_difference)
        if mean == 0.5 * (left + right) and difference == right - left:
            return left, right
        return mean - 0.5 * difference, mean + 0.5 * difference
