"""Rest when done: at the end of the path, a vehicle whose pose error is within what its estimate knows holds still.

On estimates, the end pose the controller sees moves with every fix: the estimate's correction (a few mm at 4 Hz
with 1 cm fixes) looks like a pose error, and a tracking controller chases it — tens of DA code changes per second
at standstill, a vehicle that twitches at its docking station. A correction within the estimate's uncertainty is
no evidence that the vehicle is off. :class:`Rest` holds the wheels (setpoints zero, the wheel loops then rest on
stiction) once the controller is done with its references, the wheels have stopped and the estimated error e
(x, y, θ) from the path's end pose is within the estimate's covariance P (eᵀ(P + T)⁻¹e ≤ the chi-square quantile
``enter_probability``, 3 degrees of freedom; T = diag(``tolerance_m``², ``tolerance_m``², ``heading_tolerance_rad``²),
the tolerance of a perfect estimate) and within ``max_error_m``. It lets go when the error leaves it at
``release_probability`` or grows beyond ``max_error_m``: a push, or an error the later fixes have made certain (at
rest they keep coming, and an estimate that was a few mm off when the vehicle stopped is corrected; whatever its
σ, a vehicle that knows it is that far off moves).

The covariance comes from the closed loop (:meth:`Rest.observe`, for an estimator that has one); without it
(``localization = "truth"`` or odometry) P is zero and the tolerances alone decide.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtri

from agvctl.angles import wrap_angle
from agvctl.config import check_fields, document_fields, number
from agvctl.controllers.ranges import MAX_DISTANCE_M, MAX_WHEEL_SPEED_M_S
from agvctl.planning.reference import Reference

__all__ = ["Rest", "RestConfig"]

FloatArray = NDArray[np.float64]


@document_fields
@dataclass(frozen=True)
class RestConfig:
    """When to hold at the end of the path (SI units): an experiment file's ``[controller.rest]`` table.

    With P the estimate's pose covariance and T = diag(t², t², t_θ²) of the tolerances t = ``tolerance_m`` and
    t_θ = ``heading_tolerance_rad``, the error e from the end pose is within the estimate's uncertainty when
    eᵀ(P + T)⁻¹e is below the chi-square quantile (3 degrees of freedom) of a probability (see the module notes).
    """

    enabled: bool = True
    """Hold the wheels at the end when the error is within the estimate's uncertainty."""
    tolerance_m: float = number(
        gt=0, le=MAX_DISTANCE_M, default=0.001, doc="The position tolerance of a perfect estimate, m."
    )
    heading_tolerance_rad: float = number(
        gt=0, le=math.pi, default=0.003, doc="The heading tolerance of a perfect estimate, rad."
    )
    enter_probability: float = number(
        gt=0, le=0.999999, default=0.5, doc="The probability whose quantile the error must be within to start holding."
    )
    release_probability: float = number(
        gt=0,
        le=0.999999,
        default=0.9999,
        doc="The probability whose quantile the error must leave to let go (at least ``enter_probability``).",
    )
    stopped_m_s: float = number(
        gt=0,
        le=MAX_WHEEL_SPEED_M_S,
        default=0.01,
        doc="The wheel speed below which both wheels count as stopped, to start holding, m/s.",
    )
    max_error_m: float = number(
        gt=0,
        le=MAX_DISTANCE_M,
        default=0.005,
        doc="The largest estimated position error from the end to hold at, whatever P, m.",
    )

    def __post_init__(self) -> None:
        check_fields(self)


class Rest:
    """Decides, each sample, whether the controller holds the wheels at the end of the path (see the module notes).

    Parameters
    ----------
    config
        When to hold and when to let go.
    """

    def __init__(self, config: RestConfig | None = None) -> None:
        self.config = c = config if config is not None else RestConfig()
        self._enter = float(chdtri(3, 1.0 - c.enter_probability))
        self._release = float(chdtri(3, 1.0 - max(c.release_probability, c.enter_probability)))
        self._tolerance = np.diag([c.tolerance_m**2] * 2 + [c.heading_tolerance_rad**2])
        self._end = np.zeros(3)
        self._covariance = np.zeros((3, 3))
        self.holding = False
        """Whether the wheels are held."""

    @property
    def constants(self) -> tuple[float, float, tuple[float, float, float], tuple[float, float, float]]:
        """The chi-square quantiles to start holding and to let go, T's diagonal (t², t², t_θ²) and the end pose (x, y,
        θ) of the present path (what a generated controller takes)."""
        t = self._tolerance
        end = self._end
        return self._enter, self._release, (t[0, 0], t[1, 1], t[2, 2]), (end[0], end[1], end[2])

    def reset(self, reference: Reference) -> None:
        """Start a run on ``reference``: its final pose is where to rest."""
        end = reference.final_pose
        self._end = np.array([end.x_m, end.y_m, end.theta_rad])
        self._covariance = np.zeros((3, 3))
        self.holding = False

    def observe(self, covariance: FloatArray) -> None:
        """The pose estimate's 3×3 covariance (m², m rad, rad²) at this sample."""
        self._covariance = np.asarray(covariance, dtype=np.float64)

    def distance(self, pose: FloatArray) -> float:
        """eᵀ(P + T)⁻¹e of the estimated pose against the end pose (dimensionless, chi-square with 3 dof when the
        vehicle is at the end)."""
        e = np.asarray(pose, dtype=np.float64) - self._end
        e[2] = wrap_angle(float(e[2]))
        return float(e @ np.linalg.solve(self._covariance + self._tolerance, e))

    def __call__(self, pose: FloatArray, wheel_speed_m_s: FloatArray, done: bool) -> bool:
        """Whether to hold at this sample, given the estimated pose, the measured wheel speeds (m/s) and whether the
        controller is done with its references."""
        if not (self.config.enabled and done):
            self.holding = False
            return False
        near = math.hypot(float(pose[0]) - self._end[0], float(pose[1]) - self._end[1]) <= self.config.max_error_m
        if self.holding:
            self.holding = near and self.distance(pose) <= self._release
        else:
            stopped = max(abs(float(v)) for v in wheel_speed_m_s) < self.config.stopped_m_s
            self.holding = stopped and near and self.distance(pose) <= self._enter
        return self.holding
