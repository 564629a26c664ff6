"""The small protocols every controller satisfies, so the closed loop never changes for a new controller.

The cascade, run every sample period T_s (the report's 40 ms):

    Reference ─► PoseController ─► wheel-speed setpoints (m/s) ─► WheelSpeedController (per motor, rad/s)
              ─► DA voltage command (V) ─► actuator (DA converter, amplifier) ─► plant

Controllers see only what a real one could: the pose estimate, the measured motor speeds and the reference.
They command DA voltages; the actuator chain does the rest.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.planning.reference import Reference

__all__ = [
    "CStep",
    "CompiledStep",
    "LimitReporting",
    "PoseCommand",
    "PoseController",
    "PoseCovarianceObserver",
    "SolveStatus",
    "WheelSpeedController",
]

SolveStatus = Literal["solved", "fallback_shifted", "fallback_feedforward"]


@document_fields
@dataclass(frozen=True)
class PoseCommand:
    """A pose controller's output for one sample."""

    wheel_speed_left_m_s: float
    """The left wheel's speed setpoint for the wheel loop, m/s."""
    wheel_speed_right_m_s: float
    """The right wheel's speed setpoint, m/s."""
    solve_time_s: float = 0.0
    """Wall time of the controller's computation for this sample (the whole step, Python included), s."""
    status: SolveStatus = "solved"
    """``solved``, or the fallback used when the solver failed or ran out of time."""
    reference_done: bool | None = None
    """Whether the controller is done with the reference. None (a controller that tracks the loop's clock): the
    run lasts the reference's duration, then its settling time. True or False (a controller that keeps its own
    clock, e.g. a reference governor that waits for a lagging vehicle): the run ends the settling time after the
    controller is done, at most twice the reference's duration (at least 30 s more) later."""


class PoseController(Protocol):
    """Tracks a :class:`Reference`: pose and wheel speeds in, wheel-speed setpoints out."""

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` from its time 0 (clears warm starts and fallbacks)."""

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """Setpoints for the sample starting at ``t_s``.

        Parameters
        ----------
        t_s : float
            The sample's time on the reference's clock, s.
        pose : ndarray
            The pose the controller is given (x in m, y in m, heading in rad): the estimate, or the truth with
            ``localization = "truth"``.
        wheel_speed_m_s : ndarray
            The measured wheel rim speeds (left, right), m/s.

        Returns
        -------
        PoseCommand
            The wheel-speed setpoints (left, right) in m/s the wheel loops follow over the sample, the controller's
            computing time, its solver status (``"solved"`` or the fallback it used) and, for a controller that keeps
            its own clock, whether it is done with the reference.
        """
        ...


class WheelSpeedController(Protocol):
    """Per-motor speed loops: motor-speed setpoints and measurements in rad/s, DA voltage commands out.

    A wheel controller may also be a :class:`LimitReporting` one.
    """

    def reset(self) -> None:
        """Zero the integrators."""

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """DA voltage commands (left, right) in V for one sample."""
        ...


@runtime_checkable
class PoseCovarianceObserver(Protocol):
    """A pose controller that wants to know how good its pose is (optional; the closed loop checks it once, at
    set-up). Given an estimator with a covariance
    (:class:`~agvctl.estimation.base.PoseCovarianceEstimator`), the loop hands it the estimate's covariance every
    sample, before :meth:`PoseController.update`."""

    def observe_pose_covariance(self, covariance: NDArray[np.float64]) -> None:
        """The pose estimate's 3×3 covariance (m², m rad, rad²) at this sample."""


@runtime_checkable
class LimitReporting(Protocol):
    """A wheel controller that says whether its last output was clamped to what the amplifier and the DA converter
    give (optional; the closed loop checks it once, at set-up). The loop logs it (``wheel_loop_limited_*``), and the
    default gate holds the wheels to their setpoints only where it was not (``wheel_speed_error_max_m_s``); a wheel
    controller that does not say is not judged there."""

    @property
    def limited(self) -> tuple[bool, bool]:
        """Whether each wheel's (left, right) last output was clamped."""
        ...


@document_fields
@dataclass(frozen=True)
class CStep:
    """A controller's step as compiled C, for a closed loop that runs in C: the addresses of its step function and
    of the state it steps (which the controller owns and keeps alive).

    A pose controller's step is ``int step(void *state, long k, const double pose[3], double setpoint_m_s[2])``:
    sample k of the loop's clock, the pose (x in m, y in m, heading in rad) in, the wheel rim-speed setpoints (left,
    right) in m/s out, and 0 when it solved, 1 when it fell back to the reference's wheel speeds. A wheel
    controller's is ``unsigned step(void *state, const double setpoint_rad_s[2], const double measured_rad_s[2],
    double da_v[2])``: motor-speed setpoints and measurements in rad/s in, DA voltages in V out, and a mask of the
    sides whose output was clamped (1 left, 2 right)."""

    function: int
    """The address of the step function."""
    state: int
    """The address of its state."""
    stepped: Callable[[int], None] | None = None
    """Called after a compiled run with the number of samples it stepped that fell back (a pose controller's
    failure count), or None."""


@runtime_checkable
class CompiledStep(Protocol):
    """A controller whose step is compiled C (optional; the closed loop checks it once, at set-up). Where the pose
    and the motor speeds are the truth (``localization = "truth"``, ``wheel_speed = "exact"``), the loop runs in C
    (:mod:`agvctl.sim.compiled_loop`), with the log the loop in Python would write; it calls such a controller's
    step directly, and one in Python through a call back into Python. With both controllers compiled, a run never
    comes back to Python until it ends. A compiled pose controller runs on the loop's clock (its commands'
    ``reference_done`` None)."""

    def compiled_step(self) -> CStep:
        """Its step function and state, after :meth:`PoseController.reset` or :meth:`WheelSpeedController.reset`."""
        ...
