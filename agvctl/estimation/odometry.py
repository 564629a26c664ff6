"""The plain pose estimators: the truth, and dead reckoning from the encoder counts (odometry)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from agvctl.errors import expect_instance
from agvctl.params import SIDES, VehicleParams
from agvctl.sensing import Measurements

__all__ = ["OdometryEstimator", "TruthEstimator"]

FloatArray = NDArray[np.float64]


class TruthEstimator:
    """The true pose (``localization = "truth"``): a perfect sensor, handed the truth by the simulator
    (:class:`~agvctl.estimation.base.TruthSensor`).

    Parameters
    ----------
    vehicle : VehicleParams
        Unused: the truth needs no model (the estimators share one constructor).
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        del vehicle  # the truth needs no model
        self._pose = np.zeros(3)

    def reset(self, pose: FloatArray) -> None:
        self._pose = np.array(pose, dtype=float)

    def observe_truth(self, pose: FloatArray, omega_motor_rad_s: FloatArray) -> None:
        del omega_motor_rad_s
        self._pose = np.array(pose, dtype=float)

    def update(self, measurements: Measurements) -> FloatArray:
        return self._pose


class OdometryEstimator:
    """Dead reckoning from the encoder counts with the *believed* wheel radii and base (``localization =
    "odometry"``): each sample's travel Δn·q·r/N per wheel (eqs 26, 29), eqs 39-43 with the midpoint heading.

    Parameters
    ----------
    vehicle
        The controller's vehicle: the believed wheel radii and separation (m), gear ratios and encoder counts per
        revolution.
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        expect_instance(vehicle, VehicleParams, "OdometryEstimator", "vehicle")
        q = 2.0 * math.pi / vehicle.sensors.encoder_counts_per_rev
        self.metres_per_count = np.array([vehicle.to_rim(side, q) for side in SIDES])
        self.separation_m = vehicle.wheels.separation_m
        self._pose = np.zeros(3)
        self._previous: NDArray[np.int64] | None = None

    def reset(self, pose: FloatArray) -> None:
        self._pose = np.array(pose, dtype=float)
        self._previous = None

    def update(self, measurements: Measurements) -> FloatArray:
        counts = measurements.encoder_counts
        if self._previous is not None:
            d_l, d_r = (counts - self._previous) * self.metres_per_count
            ds = 0.5 * (d_l + d_r)  # eq 39
            dtheta = (d_r - d_l) / self.separation_m  # eq 40
            mid = self._pose[2] + 0.5 * dtheta
            self._pose = self._pose + np.array([ds * math.cos(mid), ds * math.sin(mid), dtheta])  # eqs 41-43
        self._previous = counts
        return self._pose
