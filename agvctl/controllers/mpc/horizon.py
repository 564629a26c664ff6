"""The reference on the MPC's control grid, sampled once per reference so that every horizon window is a slice, and
whether the reference turns in place there."""

from __future__ import annotations

from typing import Any, NamedTuple, Protocol, overload

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.planning.reference import Reference

__all__ = ["GridPoint", "HorizonReference", "WheelFeedforward", "heading_direction", "turning_in_place"]

FloatArray = NDArray[np.float64]


class WheelFeedforward(Protocol):
    """What a prediction model says about the feed-forward (the models of
    :mod:`~agvctl.controllers.mpc.prediction`)."""

    def feedforward_m_s(self, wheel_m_s: FloatArray, mid_wheel_m_s: FloatArray) -> FloatArray:
        """The setpoints over each interval that make the model's wheels follow the reference.

        Parameters
        ----------
        wheel_m_s : ndarray
            The reference's wheel speeds at the grid points (n × 2: left, right), m/s.
        mid_wheel_m_s : ndarray
            Its wheel speeds at the intervals' midpoints ((n − 1) × 2), m/s.

        Returns
        -------
        ndarray
            (n − 1) × 2, m/s.
        """
        ...


class GridPoint(NamedTuple):
    """The reference at one grid point in plain floats, for the per-step arithmetic on single points.

    Parameters
    ----------
    x_m, y_m, theta_rad : float
        The reference pose (m, m, rad).
    cos_theta, sin_theta : float
        cos θ and sin θ of the reference heading.
    speed_m_s, yaw_rate_rad_s : float
        The reference's speed U (m/s) and yaw rate ω (rad/s).
    wheel_left_m_s, wheel_right_m_s : float
        The reference's wheel rim speeds (m/s).
    travel_m : float
        The distance the reference point has moved by this grid point (m).
    """

    x_m: float
    y_m: float
    theta_rad: float
    cos_theta: float
    sin_theta: float
    speed_m_s: float
    yaw_rate_rad_s: float
    wheel_left_m_s: float
    wheel_right_m_s: float
    travel_m: float


class HorizonReference:
    """The reference on the control grid t_j = j·T_s, sampled once at reset and padded with the final pose at
    rest so that any horizon window ``[k, k + N]`` is a slice.

    Arrays of length ``n_points`` (grid points, j = 0 … K + N + 1): ``x_m, y_m, theta_rad, speed_m_s,
    yaw_rate_rad_s, wheel_m_s`` (n×2), and the same values per grid point in plain floats, ``points``
    (:class:`GridPoint`). Arrays of length ``n_points − 1`` (intervals [t_j, t_j+1]):
    ``mid_*``, the reference at the midpoint of the interval, and ``feedforward_m_s`` (n×2), the setpoint
    that makes the prediction model follow the reference (the model's
    :meth:`~WheelFeedforward.feedforward_m_s`).

    Parameters
    ----------
    reference : Reference
        The reference to track.
    config : MpcConfig
        Resolved settings (:func:`~agvctl.controllers.mpc.config.resolved_config`): the horizon N, which sets the
        padding.
    sample_period_s : float
        The control sample period T_s, s.
    model : WheelFeedforward
        The prediction model, which sets the feed-forward.
    """

    def __init__(
        self, reference: Reference, config: MpcConfig, sample_period_s: float, model: WheelFeedforward
    ) -> None:
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
        self.feedforward_m_s: FloatArray = np.ascontiguousarray(model.feedforward_m_s(self.wheel_m_s, mid_wheel))
        self.direction: FloatArray = heading_direction(self.feedforward_m_s)
        """Each wheel's direction (+1 forward, −1 backward, 0 none) over each interval: its feed-forward's sign,
        where the feed-forward is zero the sign of its next nonzero one (0 after the last)."""
        columns: list[FloatArray] = [self.x_m, self.y_m, self.theta_rad, self.cos_theta, self.sin_theta]
        columns += [self.speed_m_s, self.yaw_rate_rad_s, self.wheel_m_s[:, 0], self.wheel_m_s[:, 1], self.travel_m]
        self.points: list[GridPoint] = list(map(GridPoint._make, zip(*(c.tolist() for c in columns), strict=True)))
        """The grid points' values in plain floats (numpy's scalars cost more per operation)."""

    def window_start(self, t_s: float) -> int:
        """The grid index of the sample starting at ``t_s`` (rounded), clamped to ``[0, last_start]``."""
        k = round(t_s / self.sample_period_s)
        return min(max(k, 0), self.last_start)


def heading_direction(feedforward_m_s: FloatArray) -> FloatArray:
    """Where each wheel is headed: the sign of its setpoint and, where the setpoint is zero (at rest), the sign of its
    next nonzero one.

    Parameters
    ----------
    feedforward_m_s : ndarray
        The wheels' setpoints (n×2, left and right) along the reference, m/s.

    Returns
    -------
    ndarray
        n×2: +1 forward, −1 backward, 0 after the wheel's last motion.

    Examples
    --------
    >>> import numpy as np
    >>> heading_direction(np.array([[0.0, 0.0], [0.1, -0.1], [0.0, 0.0]])).tolist()
    [[1.0, -1.0], [1.0, -1.0], [0.0, 0.0]]
    """
    n = len(feedforward_m_s)
    sign = np.where(np.abs(feedforward_m_s) > 1e-6, np.sign(feedforward_m_s), 0.0)
    index = np.where(sign != 0.0, np.arange(n)[:, None], n)  # each nonzero entry's own index, n for the zeros
    following = np.minimum.accumulate(index[::-1], axis=0)[::-1]  # the index of the next nonzero entry, or n
    padded = np.vstack([sign, np.zeros((1, sign.shape[1]))])
    return np.take_along_axis(padded, following, axis=0)


@overload
def turning_in_place(yaw_rate_rad_s: float, speed_m_s: float, separation_m: float) -> bool: ...


@overload
def turning_in_place(yaw_rate_rad_s: FloatArray, speed_m_s: FloatArray, separation_m: float) -> NDArray[np.bool_]: ...


def turning_in_place(yaw_rate_rad_s: Any, speed_m_s: Any, separation_m: float) -> Any:
    """Whether the reference turns (almost) in place: its wheels' turning speed ω·b/2 above four times its speed U,
    both in magnitude.

    There the path is a point and "along" it is only where a spinning frame points: the governor measures the
    heading lag instead of the along-path lag, the LTV MPC weighs the position error alike in every direction, and
    :class:`~agvctl.controllers.mpc.shaping.TowardTurningPoint` applies.

    Parameters
    ----------
    yaw_rate_rad_s : float or ndarray
        The reference's yaw rate ω, rad/s.
    speed_m_s : float or ndarray
        The reference's speed U (shaped like ``yaw_rate_rad_s``), m/s.
    separation_m : float
        The wheel separation b, m.

    Returns
    -------
    bool or ndarray of bool
        Whether ``|ω|·b/2 > 4 |U| + 1e-6`` (speeds in m/s), elementwise for arrays.
    """
    return abs(yaw_rate_rad_s) * 0.5 * separation_m > 4.0 * abs(speed_m_s) + 1e-6
