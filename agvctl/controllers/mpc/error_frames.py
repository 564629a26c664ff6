"""The LTV MPC's error frames (``error_frame``), as strategies that supply its matrices.

The error frame says in which axes the position error is kept: the reference's path frame (along, across) or the
world's (x, y). It supplies the linearised kinematics (eqs 39-43) about the reference, the initial position error, the
along-track share of the position weight and the direction in which the heading coupling of the wheel-loop model
(:mod:`~agvctl.controllers.mpc.prediction`) moves the position error. Each is chosen by name from
:data:`ERROR_FRAMES`; nothing outside them asks which one is in use.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.config import MpcConfig

if TYPE_CHECKING:
    from agvctl.controllers.mpc.horizon import HorizonReference

__all__ = ["ERROR_FRAMES", "ErrorFrame", "PathFrame", "WorldFrame"]

FloatArray = NDArray[np.float64]
WindowSource = tuple[FloatArray, int, int]


class ErrorFrame(Protocol):
    """The axes of the position error (see the module notes)."""

    c_step: str
    """The frame's part of the QP step in C (the template ``step/<c_step>.c.j2`` of
    :mod:`~agvctl.controllers.mpc.c_step`): its position error and coupling as :meth:`position_error` and
    :meth:`coupling` compute them."""

    def along_track_share(self, config: MpcConfig) -> float:
        """The weight of the first position error relative to the second's.

        Parameters
        ----------
        config : MpcConfig
            The settings.

        Returns
        -------
        float
            The share.
        """
        ...

    def kinematics(
        self,
        m: FloatArray,
        speed_m_s: FloatArray,
        yaw_rate_rad_s: FloatArray,
        theta_rad: FloatArray,
        separation_m: float,
    ) -> None:
        """Write the kinematics linearised about the reference into each ``m[j]``: the pose error's rows 0-2, its own
        columns 0-2 and the wheel speeds' (δv_l, δv_r) columns 3-4.

        Parameters
        ----------
        m : ndarray
            The continuous systems, one per interval (n × d × d, d ≥ 5), zero where not written.
        speed_m_s : ndarray
            The reference's speed U at each interval's midpoint, m/s.
        yaw_rate_rad_s : ndarray
            Its yaw rate ω, rad/s.
        theta_rad : ndarray
            Its heading θ, rad.
        separation_m : float
            The wheel separation b, m.
        """
        ...

    def position_error(self, dx_m: float, dy_m: float, cos_theta: float, sin_theta: float) -> tuple[float, float]:
        """The position error in the frame's axes.

        Parameters
        ----------
        dx_m, dy_m : float
            The position minus the reference's, in world axes, m.
        cos_theta, sin_theta : float
            The reference's heading's cosine and sine.

        Returns
        -------
        tuple of float
            The error's (first, second) component, m.
        """
        ...

    def coupling(self, heading_rad: float, grid: HorizonReference, k: int) -> FloatArray:
        """The change (first, second) of the position error's response per unit δU when driving with the heading error
        ``heading_rad``, first order in T_s, for x_0 … x_{N−1} of the window starting at ``k`` (N × 2).

        Parameters
        ----------
        heading_rad : float
            The heading error linearised about, rad.
        grid : HorizonReference
            The reference's grid.
        k : int
            The window's first grid point.

        Returns
        -------
        ndarray
            N × 2, the frame's own array (valid until the next call).
        """
        ...

    def window_sources(self, grid: HorizonReference) -> list[WindowSource]:
        """What else a window's matrix entries depend on (see
        :func:`~agvctl.controllers.mpc.ltv_qp.window_versions`).

        Parameters
        ----------
        grid : HorizonReference
            The reference's grid.

        Returns
        -------
        list of (ndarray, int, int)
            The sources, with their offsets.
        """
        ...


class PathFrame:
    """The reference's path frame (along, across): ė_along = ω e_across + δU, ė_across = −ω e_along + U e_θ,
    ė_θ = δω, with δU = (δv_l + δv_r)/2 and δω = (δv_r − δv_l)/b.

    Parameters
    ----------
    horizon : int
        N, the horizon in samples.
    sample_period_s : float
        T_s, s.
    """

    c_step = "path_frame"

    def __init__(self, horizon: int, sample_period_s: float) -> None:
        self._half_period_s = 0.5 * sample_period_s
        self._coupling = np.zeros((horizon, 2))
        self._coupling_heading = math.nan
        """The heading the coupling was written for (NaN: none yet)."""

    def along_track_share(self, config: MpcConfig) -> float:
        """``config.along_track_share``: along the path weighs that share of across (see :class:`ErrorFrame`)."""
        return config.along_track_share

    def kinematics(
        self,
        m: FloatArray,
        speed_m_s: FloatArray,
        yaw_rate_rad_s: FloatArray,
        theta_rad: FloatArray,
        separation_m: float,
    ) -> None:
        """See :meth:`ErrorFrame.kinematics`; the heading does not enter."""
        del theta_rad
        m[:, 0, 1], m[:, 1, 0], m[:, 1, 2] = yaw_rate_rad_s, -yaw_rate_rad_s, speed_m_s
        m[:, 0:3, 3:5] = np.array([[0.5, 0.5], [0.0, 0.0], [-1.0 / separation_m, 1.0 / separation_m]])

    def position_error(self, dx_m: float, dy_m: float, cos_theta: float, sin_theta: float) -> tuple[float, float]:
        """See :meth:`ErrorFrame.position_error`: rotated into the path frame."""
        return cos_theta * dx_m + sin_theta * dy_m, -sin_theta * dx_m + cos_theta * dy_m

    def coupling(self, heading_rad: float, grid: HorizonReference, k: int) -> FloatArray:
        """See :meth:`ErrorFrame.coupling`: (cos e_θ − 1, sin e_θ)·T_s/2 alike at every k, written again only for a
        new heading."""
        del grid, k
        if heading_rad != self._coupling_heading:
            half = self._half_period_s
            self._coupling[:, 0], self._coupling[:, 1] = (
                half * (math.cos(heading_rad) - 1.0),
                half * math.sin(heading_rad),
            )
            self._coupling_heading = heading_rad
        return self._coupling

    def window_sources(self, grid: HorizonReference) -> list[WindowSource]:
        """See :meth:`ErrorFrame.window_sources`: none (the coupling is alike along the path)."""
        del grid
        return []


class WorldFrame:
    """World axes (x, y): ė_x = −U sin θ e_θ + cos θ δU, ė_y = U cos θ e_θ + sin θ δU, ė_θ = δω.

    Parameters
    ----------
    horizon : int
        N, the horizon in samples.
    sample_period_s : float
        T_s, s.
    """

    c_step = "world_frame"

    def __init__(self, horizon: int, sample_period_s: float) -> None:
        self._horizon = horizon
        self._half_period_s = 0.5 * sample_period_s
        self._coupling = np.zeros((horizon, 2))

    def along_track_share(self, config: MpcConfig) -> float:
        """1: both world axes weigh alike (an along-track share exists in the path frame only)."""
        del config
        return 1.0

    def kinematics(
        self,
        m: FloatArray,
        speed_m_s: FloatArray,
        yaw_rate_rad_s: FloatArray,
        theta_rad: FloatArray,
        separation_m: float,
    ) -> None:
        """See :meth:`ErrorFrame.kinematics`."""
        del yaw_rate_rad_s
        ct, st = np.cos(theta_rad), np.sin(theta_rad)
        m[:, 0, 2], m[:, 1, 2] = -speed_m_s * st, speed_m_s * ct
        m[:, 0, 3:5] = 0.5 * ct[:, None]
        m[:, 1, 3:5] = 0.5 * st[:, None]
        m[:, 2, 3:5] = (-1.0 / separation_m, 1.0 / separation_m)

    def position_error(self, dx_m: float, dy_m: float, cos_theta: float, sin_theta: float) -> tuple[float, float]:
        """See :meth:`ErrorFrame.position_error`: the world-axes difference itself."""
        del cos_theta, sin_theta
        return dx_m, dy_m

    def coupling(self, heading_rad: float, grid: HorizonReference, k: int) -> FloatArray:
        """See :meth:`ErrorFrame.coupling`: the path frame's rotated by each sample's reference heading."""
        along, across = self._half_period_s * (math.cos(heading_rad) - 1.0), self._half_period_s * math.sin(heading_rad)
        ct_h, st_h = grid.cos_theta[k : k + self._horizon], grid.sin_theta[k : k + self._horizon]
        self._coupling[:, 0] = ct_h * along - st_h * across
        self._coupling[:, 1] = st_h * along + ct_h * across
        return self._coupling

    def window_sources(self, grid: HorizonReference) -> list[WindowSource]:
        """See :meth:`ErrorFrame.window_sources`: the headings θ_k … θ_{k+N−1} the coupling is rotated by."""
        return [(np.column_stack([grid.cos_theta, grid.sin_theta]), 0, self._horizon - 1)]


ERROR_FRAMES: dict[str, type[PathFrame] | type[WorldFrame]] = {"path": PathFrame, "world": WorldFrame}
"""The error frames by their ``error_frame`` name."""
