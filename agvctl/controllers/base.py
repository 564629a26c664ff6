"""The small protocols every controller satisfies, so the closed loop never changes for a new controller.

The cascade, run every sample period T_s (the report's 40 ms):

    Reference ─► PoseController ─► wheel-speed setpoints (m/s) ─► WheelSpeedController (per motor, rad/s)
              ─► DA voltage command (V) ─► actuator (DA converter, amplifier) ─► plant

Controllers see only what a real one could: the pose estimate, the measured motor speeds and the reference.
They command DA voltages; the actuator chain does the rest.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from agvctl.planning.reference import Reference

__all__ = [
    "GovernedPoseController",
    "PoseCommand",
    "PoseController",
    "SolveStatus",
    "WheelSpeedController",
]

SolveStatus = Literal["solved", "fallback_shifted", "fallback_feedforward"]


@dataclass(frozen=True)
class PoseCommand:
    """A pose controller's output for one sample."""

    wheel_speed_left_m_s: float
    wheel_speed_right_m_s: float
    solve_time_s: float = 0.0
    """Wall time of the controller's computation for this sample (the whole step, Python included)."""
    status: SolveStatus = "solved"
    """``solved``, or the fallback used when the solver failed or ran out of time."""


class PoseController(Protocol):
    """Tracks a :class:`Reference`: pose and wheel speeds in, wheel-speed setpoints out."""

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` from its time 0 (clears warm starts and fallbacks)."""

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """Setpoints for the sample starting at ``t_s`` given the pose (x_m, y_m, theta_rad) and the measured
        wheel rim speeds (left, right) in m/s."""
        ...


@runtime_checkable
class GovernedPoseController(PoseController, Protocol):
    """A pose controller that tracks the reference at its own clock (a reference governor): the closed loop runs
    until :attr:`reference_time_s` reaches the reference's end (then its settling time), at most twice as long."""

    @property
    def reference_time_s(self) -> float:
        """The reference time being tracked at the last update (s), ≤ the loop's time."""
        ...


class WheelSpeedController(Protocol):
    """Per-motor speed loops: motor-speed setpoints and measurements in rad/s, DA voltage commands out."""

    def reset(self) -> None:
        """Zero the integrators."""

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """DA voltage commands (left, right) in V for one sample."""
        ...
