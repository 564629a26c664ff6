"""The reference governor: the MPC tracks the reference at its own clock, which waits while the vehicle lags.

The controller tracks the reference at a clock c (in samples), not at t/T_s: every step c advances by σ ∈ [0, 1],
σ = 1 while the vehicle's lag behind the reference point stays under ``governor_lag_start_m`` and falling linearly
to 0 (the reference waits) at ``governor_lag_stop_m``; below ``governor_lag_start_m`` it rises on the same line up to
``governor_catch_up`` while c is behind t/T_s, so a delay (an offset start, a weak stretch) is made up where the
vehicle can, and c never runs ahead of t/T_s. The lag is the along-path error (in the reference's heading frame)
or, in a turn in place, the heading lag times b/2 (the wheels' arc length). So a vehicle weaker than its model, or
starting behind, falls behind *along* the path and stays on it instead of cutting corners after a point that runs
away; the reference never runs more than a few centimetres ahead, and it reaches the end and stops there. While the
vehicle keeps up, c = t/T_s exactly and nothing changes.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.fallback import clamp
from agvctl.controllers.mpc.horizon import HorizonReference, turning_in_place

__all__ = ["ReferenceGovernor"]


class ReferenceGovernor:
    """The governed clock over a :class:`~agvctl.controllers.mpc.horizon.HorizonReference` (see the module notes).

    With ``config.reference_governor`` off the clock is the loop's, t/T_s rounded to the grid.

    Parameters
    ----------
    config : MpcConfig
        Whether to govern, and the lags at which the clock slows and stops (``governor_lag_start_m``,
        ``governor_lag_stop_m``) and its rate while catching up (``governor_catch_up``).
    separation_m : float
        The wheel separation b, m: in a turn in place the lag is the heading lag times b/2.
    """

    def __init__(self, config: MpcConfig, separation_m: float) -> None:
        self.config = config
        self.separation_m = separation_m
        self.clock = -1.0
        """The governed clock in samples (−1: not started)."""
        self.fraction = 0.0
        """The clock's position between grid points k and k + 1, in [0, 1)."""

    def restart(self) -> None:
        """Start again from the next :meth:`advance` (a new reference, or a new manoeuvre)."""
        self.clock = -1.0
        self.fraction = 0.0

    def time_s(self, sample_period_s: float) -> float:
        """The clock in seconds of the reference (0 before the first step)."""
        return max(self.clock, 0.0) * sample_period_s

    def advance(self, grid: HorizonReference, t_s: float, pose: NDArray[np.float64]) -> int:
        """Advance the clock for the sample at ``t_s`` (on the grid's reference) with the vehicle at ``pose``; the
        window start k, the grid point at or before the clock."""
        c = self.config
        if not c.reference_governor:
            self.clock = float(grid.window_start(t_s))
            self.fraction = 0.0
            return int(self.clock)
        if self.clock < 0.0:
            self.clock = float(grid.window_start(t_s))
        else:
            lag = self.lag_m(grid, self.clock + 1.0, pose)
            if not math.isfinite(lag):
                lag = 0.0
            stop = c.governor_lag_stop_m
            band = max(stop - c.governor_lag_start_m, 1e-9)
            sigma = clamp((stop - lag) / band, 0.0, c.governor_catch_up)
            advanced, now = self.clock + sigma, float(grid.window_start(t_s))
            self.clock = now if now < advanced else advanced  # min(advanced, now): never ahead of t
        k = int(self.clock)
        self.fraction = self.clock - k
        return k

    def lag_m(self, grid: HorizonReference, clock: float, pose: NDArray[np.float64]) -> float:
        """How far the vehicle at ``pose`` is behind the reference at ``clock`` (samples), in metres.

        Along the path it is the along-path error, 0 when ahead. In a turn in place it is the heading lag times b/2
        or, if larger, the distance from the turning point (a weak wheel that cannot keep up with the spin pushes
        the vehicle off the point: the reference waits for it to get back). Ahead in the turn it is negative: the
        reference comes to it, at no more than its own pace while the vehicle is off the point (never held there:
        the MPC, predicting the reference turning on, would wait for it while it waited for the vehicle).
        """
        k = min(int(clock), grid.n_points - 2)
        f = clock - k
        here, ahead = grid.points[k], grid.points[k + 1]
        x = here.x_m + f * (ahead.x_m - here.x_m)
        y = here.y_m + f * (ahead.y_m - here.y_m)
        th = here.theta_rad + f * wrap_angle(ahead.theta_rad - here.theta_rad)
        px, py = float(pose[0]), float(pose[1])
        along = math.cos(th) * (px - x) + math.sin(th) * (py - y)
        yaw = here.yaw_rate_rad_s
        if not turning_in_place(yaw, here.speed_m_s, self.separation_m):
            return max(-along, 0.0)
        half_b = 0.5 * self.separation_m
        heading_lag = -math.copysign(1.0, yaw) * wrap_angle(float(pose[2]) - th) * half_b
        off_point = math.hypot(px - x, py - y)
        if heading_lag < 0.0:  # ahead in the turn: the reference comes to it (at its own pace if off the point)
            start = self.config.governor_lag_start_m
            return float(heading_lag if off_point <= start else start)
        return float(max(heading_lag, off_point))
