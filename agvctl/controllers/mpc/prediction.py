"""The LTV MPC's error frame and prediction model, as strategies that supply its matrices.

The error frame (``error_frame``) says in which axes the position error is kept: the reference's path frame
(along, across) or the world's (x, y). It supplies the linearised kinematics (eqs 39-43) about the reference, the
initial position error, the along-track share of the position weight and the direction in which the heading coupling
of the wheel-loop model moves the position error. The prediction model (``prediction_model``) says what drives the
kinematics: the setpoints directly, or the wheel speeds lagging them (v̇ = (s − v)/τ); it supplies the continuous
system over one interval, the wheel-speed errors of the initial state, the heading coupling and the constraint blocks
of its own states and the feed-forward (what makes its wheels follow the reference).

Each is chosen by name from a registry (:data:`ERROR_FRAMES`, :data:`PREDICTION_MODELS`); nothing outside them asks
which one is in use.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.config import MpcConfig, wheel_loop_time_constant_s
from agvctl.controllers.mpc.horizon import HorizonReference
from agvctl.controllers.mpc.ltv_qp import Reach, SpeedBox, StepBlock

__all__ = ["ERROR_FRAMES", "PREDICTION_MODELS", "ErrorFrame", "PredictionModel"]

FloatArray = NDArray[np.float64]
WindowSource = tuple[FloatArray, int, int]

RELINEARISE_RAD = 0.01
"""The heading error about which the position error's response to δU is linearised (see
:meth:`WheelLoopModel.coupling`) is refreshed when the present one has moved more than this (0.57°) from it: a stale
point mispredicts a lateral motion of at most 0.01·δU·t (under 0.1 mm over the horizon for a 1 cm/s correction), and
an unchanged matrix spares OSQP its refactorisation, about a third of a step."""


class ErrorFrame(Protocol):
    """The axes of the position error (see the module notes)."""

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


class PredictionModel(Protocol):
    """What drives the kinematics (see the module notes)."""

    n_states: int
    """nx, the error states per sample: the pose's 3, and the model's own."""
    wheel_columns: tuple[int, int] | None
    """The states of the wheel-speed errors (δv_l, δv_r), None where the setpoints drive the kinematics directly."""

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

    def continuous(self, grid: HorizonReference, frame: ErrorFrame, separation_m: float) -> FloatArray:
        """The continuous system of each interval, augmented with the held setpoints ((nx + 2) square each; its
        exponential times T_s gives A_j and B_j).

        Parameters
        ----------
        grid : HorizonReference
            The reference's grid (its midpoints' U, ω, θ).
        frame : ErrorFrame
            The error frame, which writes the kinematics.
        separation_m : float
            The wheel separation b, m.

        Returns
        -------
        ndarray
            n × (nx + 2) × (nx + 2).
        """
        ...

    def wheel_errors(self, x0: FloatArray, wheel_speed_m_s: FloatArray, reference_m_s: tuple[float, float]) -> None:
        """Write the model's own states of the initial error x_0.

        Parameters
        ----------
        x0 : ndarray
            The initial error (nx).
        wheel_speed_m_s : ndarray
            The measured wheel speeds (left, right), m/s.
        reference_m_s : tuple of float
            The reference's wheel speeds at the governed clock, m/s.
        """
        ...

    def restart(self) -> None:
        """Forget what was linearised about for the previous reference."""
        ...

    def coupling(
        self, frame: ErrorFrame, grid: HorizonReference, k: int, heading_rad: float
    ) -> tuple[float, FloatArray | None]:
        """The heading error the position error's response to δU is linearised about and that response's change
        (first, second) per unit δU for x_0 … x_{N−1} (N × 2), or (0, None) for none.

        Parameters
        ----------
        frame : ErrorFrame
            The error frame, in whose axes the change is.
        grid : HorizonReference
            The reference's grid.
        k : int
            The window's first grid point.
        heading_rad : float
            The present heading error e_θ,0, rad.

        Returns
        -------
        tuple
            The heading linearised about (rad) and the coupling.
        """
        ...

    def constraint_blocks(self, horizon: int, box: SpeedBox) -> list[StepBlock]:
        """The constraint blocks of the model's own states.

        Parameters
        ----------
        horizon : int
            N.
        box : SpeedBox
            The speed box, which a block may tighten for the first sample.

        Returns
        -------
        list of QpBlock
            The blocks, in row order.
        """
        ...


class KinematicModel:
    """The setpoints drive the kinematics directly (δv = δs): the pose error's three states.

    Parameters
    ----------
    config : MpcConfig
        The settings.
    sample_period_s : float
        T_s, s.
    """

    n_states = 3
    wheel_columns: tuple[int, int] | None = None

    def __init__(self, config: MpcConfig, sample_period_s: float) -> None:
        del config, sample_period_s

    def feedforward_m_s(self, wheel_m_s: FloatArray, mid_wheel_m_s: FloatArray) -> FloatArray:
        """See :meth:`PredictionModel.feedforward_m_s`: the midpoint wheel speeds."""
        del wheel_m_s
        return mid_wheel_m_s

    def continuous(self, grid: HorizonReference, frame: ErrorFrame, separation_m: float) -> FloatArray:
        """See :meth:`PredictionModel.continuous`: the frame's kinematics, driven by the setpoints in columns 3-4."""
        m = np.zeros((grid.n_points - 1, 5, 5))
        frame.kinematics(m, grid.mid_speed_m_s, grid.mid_yaw_rate_rad_s, grid.mid_theta_rad, separation_m)
        return m

    def wheel_errors(self, x0: FloatArray, wheel_speed_m_s: FloatArray, reference_m_s: tuple[float, float]) -> None:
        """See :meth:`PredictionModel.wheel_errors`: none."""

    def restart(self) -> None:
        """See :meth:`PredictionModel.restart`: nothing is kept."""

    def coupling(
        self, frame: ErrorFrame, grid: HorizonReference, k: int, heading_rad: float
    ) -> tuple[float, FloatArray | None]:
        """See :meth:`PredictionModel.coupling`: none (the setpoints' columns are B's, not A's)."""
        return 0.0, None

    def constraint_blocks(self, horizon: int, box: SpeedBox) -> list[StepBlock]:
        """See :meth:`PredictionModel.constraint_blocks`: none."""
        return []


class WheelLoopModel:
    """The wheel speeds lag their setpoints through the closed wheel loop, δv̇ = (δs − δv)/τ: the pose error's three
    states and the two wheel-speed errors.

    Parameters
    ----------
    config : MpcConfig
        The settings (τ, the wheel loop's time constant).
    sample_period_s : float
        T_s, s.
    """

    n_states = 5
    wheel_columns: tuple[int, int] | None = (3, 4)

    def __init__(self, config: MpcConfig, sample_period_s: float) -> None:
        tau_s = wheel_loop_time_constant_s(config)
        self._inv_tau = 1.0 / tau_s
        self._decay = math.exp(-sample_period_s / tau_s)
        self._heading_rad = 0.0

    def feedforward_m_s(self, wheel_m_s: FloatArray, mid_wheel_m_s: FloatArray) -> FloatArray:
        """See :meth:`PredictionModel.feedforward_m_s`: the inverse of the lag's exact discretisation,
        s_j = (v_j+1 − a v_j)/(1 − a) with a = exp(−T_s/τ)."""
        del mid_wheel_m_s
        a = self._decay
        return (wheel_m_s[1:] - a * wheel_m_s[:-1]) / (1.0 - a)

    def continuous(self, grid: HorizonReference, frame: ErrorFrame, separation_m: float) -> FloatArray:
        """See :meth:`PredictionModel.continuous`: the frame's kinematics driven by the wheel-speed states 3-4, which
        follow the setpoints in columns 5-6."""
        m = np.zeros((grid.n_points - 1, 7, 7))
        frame.kinematics(m, grid.mid_speed_m_s, grid.mid_yaw_rate_rad_s, grid.mid_theta_rad, separation_m)
        m[:, 3, 3] = m[:, 4, 4] = -self._inv_tau
        m[:, 3, 5] = m[:, 4, 6] = self._inv_tau
        return m

    def wheel_errors(self, x0: FloatArray, wheel_speed_m_s: FloatArray, reference_m_s: tuple[float, float]) -> None:
        """See :meth:`PredictionModel.wheel_errors`: measured minus reference."""
        v_l, v_r = wheel_speed_m_s.tolist()
        x0[3], x0[4] = v_l - reference_m_s[0], v_r - reference_m_s[1]

    def restart(self) -> None:
        """See :meth:`PredictionModel.restart`: linearise about no heading error again."""
        self._heading_rad = 0.0

    def coupling(
        self, frame: ErrorFrame, grid: HorizonReference, k: int, heading_rad: float
    ) -> tuple[float, FloatArray | None]:
        """Linearised about the reference, the position error moves with δU along the reference's heading: blind,
        where the reference stands still (the start, a stop), to what driving with the present heading error e_θ,0
        does. About the present error δU moves it along θ_ref + e_θ,0, a change of (cos e_θ,0 − 1, sin e_θ,0) in the
        path frame (the frame's :meth:`~ErrorFrame.coupling`), δU = (δv_l + δv_r)/2: first order in T_s, held over
        the horizon, linearised again when e_θ,0 moved more than :data:`RELINEARISE_RAD`."""
        if abs(heading_rad - self._heading_rad) > RELINEARISE_RAD:
            self._heading_rad = heading_rad
        e0 = self._heading_rad
        if abs(e0) < 1e-4:  # below 0.006°: a change under 1e-6 of T_s per m/s, nothing to see
            return 0.0, None
        return e0, frame.coupling(e0, grid, k)

    def constraint_blocks(self, horizon: int, box: SpeedBox) -> list[StepBlock]:
        """See :meth:`PredictionModel.constraint_blocks`: the setpoints' reachable lead over the wheel speeds."""
        return [Reach(horizon, self.n_states, (3, 4), box)]


ERROR_FRAMES: dict[str, type[PathFrame] | type[WorldFrame]] = {"path": PathFrame, "world": WorldFrame}
"""The error frames by their ``error_frame`` name."""

PREDICTION_MODELS: dict[str, type[KinematicModel] | type[WheelLoopModel]] = {
    "kinematic": KinematicModel,
    "kinematic+wheel_loop": WheelLoopModel,
}
"""The prediction models by their ``prediction_model`` name."""
