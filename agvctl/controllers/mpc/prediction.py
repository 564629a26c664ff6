"""The LTV MPC's prediction models (``prediction_model``), as strategies that supply its matrices.

The prediction model says what drives the kinematics: the setpoints directly, or the wheel speeds lagging them
(v̇ = (s − v)/τ). It supplies the continuous system over one interval, the wheel-speed errors of the initial state, the
heading coupling, the constraint blocks of its own states and the feed-forward (what makes its wheels follow the
reference).

Each is chosen by name from :data:`PREDICTION_MODELS`; nothing outside them asks which one is in use. The error frame
(:mod:`~agvctl.controllers.mpc.error_frames`) is the other strategy.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.config import MpcConfig, wheel_loop_time_constant_s
from agvctl.controllers.mpc.horizon import WheelFeedforward
from agvctl.controllers.mpc.ltv_qp import SpeedBox, StepBlock
from agvctl.controllers.mpc.reach import Reach

if TYPE_CHECKING:
    from agvctl.controllers.mpc.error_frames import ErrorFrame
    from agvctl.controllers.mpc.horizon import HorizonReference

__all__ = ["PREDICTION_MODELS", "KinematicModel", "PredictionModel", "WheelLoopModel"]

FloatArray = NDArray[np.float64]

RELINEARISE_RAD = 0.01
"""The heading error about which the position error's response to δU is linearised (see
:meth:`WheelLoopModel.coupling`) is refreshed when the present one has moved more than this (0.57°) from it: a stale
point mispredicts a lateral motion of at most 0.01·δU·t (under 0.1 mm over the horizon for a 1 cm/s correction), and
an unchanged matrix spares OSQP its refactorisation, about a third of a step."""


class PredictionModel(WheelFeedforward, Protocol):
    """What drives the kinematics (see the module notes); and, as every prediction model, the feed-forward it needs
    (:class:`~agvctl.controllers.mpc.horizon.WheelFeedforward`)."""

    n_states: int
    """nx, the error states per sample: the pose's 3, and the model's own."""
    wheel_columns: tuple[int, int] | None
    """The states of the wheel-speed errors (δv_l, δv_r), None where the setpoints drive the kinematics directly."""
    time_constant_s: float | None
    """τ of the wheel loops' lag the model predicts, s; None where the setpoints drive the kinematics directly."""
    c_step: str
    """The model's part of the QP step in C (the template ``step/<c_step>.c.j2`` of
    :mod:`~agvctl.controllers.mpc.c_step`): its wheel errors and coupling as :meth:`wheel_errors` and
    :meth:`coupling` compute them."""
    lead_factor_s: float
    """D/a: how far a setpoint may lead its wheel per m/s² of acceleration the wheel can reach, s, scaled by the
    settings' ``reach_lead`` (:class:`~agvctl.controllers.mpc.shaping.ReachWindow`, the ``Reach`` block)."""

    def measured_states(self, wheel_speed_m_s: FloatArray) -> list[float]:
        """The model's own states beyond the pose, from the measured wheel speeds (the nonlinear MPC's x_0).

        Parameters
        ----------
        wheel_speed_m_s : ndarray
            The measured wheel speeds (left, right), m/s.

        Returns
        -------
        list of float
            Its states, none for a model of the pose alone.
        """
        ...

    def reference_states(self, wheel_m_s: FloatArray) -> list[FloatArray]:
        """The rows of the model's own states along the reference (the nonlinear MPC's cold start).

        Parameters
        ----------
        wheel_m_s : ndarray
            The reference's wheel speeds at the horizon's samples (N × 2), m/s.

        Returns
        -------
        list of ndarray
            Its states' rows (each of N values), none for a model of the pose alone.
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
    c_step = "kinematic_model"
    wheel_columns: tuple[int, int] | None = None
    time_constant_s: float | None = None

    def __init__(self, config: MpcConfig, sample_period_s: float) -> None:
        self.lead_factor_s = config.reach_lead * sample_period_s
        """The setpoint is the next sample's speed: D = a·T_s, scaled by ``reach_lead``."""

    def measured_states(self, wheel_speed_m_s: FloatArray) -> list[float]:
        """See :meth:`PredictionModel.measured_states`: none."""
        del wheel_speed_m_s
        return []

    def reference_states(self, wheel_m_s: FloatArray) -> list[FloatArray]:
        """See :meth:`PredictionModel.reference_states`: none."""
        del wheel_m_s
        return []

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
    c_step = "wheel_loop_model"
    wheel_columns: tuple[int, int] | None = (3, 4)

    def __init__(self, config: MpcConfig, sample_period_s: float) -> None:
        tau_s = wheel_loop_time_constant_s(config)
        self.time_constant_s: float | None = tau_s
        self._inv_tau = 1.0 / tau_s
        self._decay = math.exp(-sample_period_s / tau_s)
        self.lead_factor_s = config.reach_lead * sample_period_s / (1.0 - self._decay)
        """The lag's exact discretisation moves the wheel speed by (1 − e^(−T_s/τ))(s − v) in a sample, so a wheel
        that can change its speed by a·T_s in a sample follows a lead D = a·T_s/(1 − e^(−T_s/τ)), scaled by
        ``reach_lead``."""
        self._heading_rad = 0.0

    def measured_states(self, wheel_speed_m_s: FloatArray) -> list[float]:
        """See :meth:`PredictionModel.measured_states`: the two wheel speeds."""
        return [float(wheel_speed_m_s[0]), float(wheel_speed_m_s[1])]

    def reference_states(self, wheel_m_s: FloatArray) -> list[FloatArray]:
        """See :meth:`PredictionModel.reference_states`: the reference's wheel speeds."""
        return [wheel_m_s.T]

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
        """Linearised about the reference, the position error moves with δU along the reference's heading: blind, where
        the reference stands still (the start, a stop), to what driving with the present heading error e_θ,0
        does. About the present error δU moves it along θ_ref + e_θ,0, a change of (cos e_θ,0 − 1, sin e_θ,0) in
        the path frame (the frame's :meth:`~agvctl.controllers.mpc.error_frames.ErrorFrame.coupling`), δU =
        (δv_l + δv_r)/2: first order in T_s, held over the horizon, linearised again when e_θ,0 moved more than
        :data:`RELINEARISE_RAD`."""
        if abs(heading_rad - self._heading_rad) > RELINEARISE_RAD:
            self._heading_rad = heading_rad
        e0 = self._heading_rad
        if abs(e0) < 1e-4:  # below 0.006°: a change under 1e-6 of T_s per m/s, nothing to see
            return 0.0, None
        return e0, frame.coupling(e0, grid, k)

    def constraint_blocks(self, horizon: int, box: SpeedBox) -> list[StepBlock]:
        """See :meth:`PredictionModel.constraint_blocks`: the setpoints' reachable lead over the wheel speeds."""
        return [Reach(horizon, self.n_states, (3, 4), box)]


PREDICTION_MODELS: dict[str, type[KinematicModel] | type[WheelLoopModel]] = {
    "kinematic": KinematicModel,
    "kinematic+wheel_loop": WheelLoopModel,
}
"""The prediction models by their ``prediction_model`` name."""
