"""Sensor models of the true vehicle (``[sensors]`` of its file), seeded: what the estimators read every sample.

* **Encoders** on the motor shafts: ``encoder_counts_per_rev`` counts per revolution after quadrature, latched at
  each sample t_k from the shaft angle the plant turned (:attr:`~agvctl.sim.stepper.PlantStepper.motor_angle_rad`,
  the RK4 quadrature of ω_mot, eq 2). Counts are ``floor(φ/q + phase)``, q = 2π/counts, with a random initial
  phase in [0, 1) per shaft: the quantisation error is uniform over one count.
* **Rate gyro** (optional): the mean yaw rate over the last sample (eq 40 integrated: Δθ/T_s) plus a constant bias
  and white noise, rounded to the reading's resolution.
* **Position fixes** from a beacon/laser system: the pose at a sample instant with Gaussian noise (σ in x and y,
  σ in heading; the heading wrapped to [−π, π)), ``position_fix_rate_hz`` on average (each fix at the first
  sample on or after its nominal time), delivered ``position_fix_latency_s`` later, at the first sample on or
  after its arrival, stamped with the time it was measured.

Noise streams are independent per sensor (``seed`` with a stream index), so enabling the gyro does not change
the fixes' noise.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.config import document_fields
from agvctl.params import VehicleParams

__all__ = [
    "Measurements",
    "PositionFix",
    "SENSOR_READING_COLUMNS",
    "Sensors",
    "fix_delay_samples",
]

SENSOR_READING_COLUMNS = (
    "encoder_count_left",
    "encoder_count_right",
    "gyro_rate_rad_s",
    "fix_x_m",
    "fix_y_m",
    "fix_theta_rad",
    "fix_measured_t_s",
)
"""The log columns of what the sensors read at each sample: latched encoder counts, the gyro (NaN without one) and
the last position fix arriving (NaN when none) with its measurement time."""

FloatArray = NDArray[np.float64]


@document_fields
@dataclass(frozen=True)
class PositionFix:
    """One absolute fix: the pose measured at a sample."""

    measured_sample: int
    """The sample k it was measured at."""
    measured_t_s: float
    """The time it was measured, k·T_s, s."""
    pose: FloatArray
    """The measured pose: x (m), y (m), heading (rad, in [−π, π))."""


@document_fields
@dataclass(frozen=True)
class Measurements:
    """What an estimator sees at sample k."""

    sample: int
    """The sample k."""
    t_s: float
    """Its time t_k = k·T_s, s."""
    wheel_speed_m_s: FloatArray
    """The rim speeds (left, right) the wheel loops measured (exact, or estimated from the counts), m/s."""
    encoder_counts: NDArray[np.int64]
    """Counts latched at t_k (left, right), since the start."""
    gyro_rate_rad_s: float = math.nan
    """The gyro's mean yaw rate over [t_k−1, t_k] (NaN without a gyro, and at k = 0), rad/s."""
    fixes: tuple[PositionFix, ...] = field(default_factory=tuple)
    """The fixes arriving at t_k, oldest first."""


def fix_delay_samples(vehicle: VehicleParams) -> int:
    """Samples from a fix's measurement to the sample at which it is delivered: ⌈latency/T_s⌉.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its fixes' latency and its sample period.

    Returns
    -------
    int
        The delay in samples (0: a fix arrives at the sample it is measured).
    """
    ts = vehicle.control.sample_period_s
    return int(math.ceil(vehicle.sensors.position_fix_latency_s / ts - 1e-9))


class Sensors:
    """The true vehicle's sensors, read once per sample.

    Parameters
    ----------
    vehicle
        The true vehicle (its ``sensors`` table and sample period T_s in s).
    seed
        The noise seed (encoder phases, gyro noise, fix noise).
    """

    def __init__(self, vehicle: VehicleParams, *, seed: int) -> None:
        s = vehicle.sensors
        self.params = s
        self.sample_period_s = vehicle.control.sample_period_s
        self.count_rad = 2.0 * math.pi / s.encoder_counts_per_rev
        self._phase = np.random.default_rng([seed, 0]).uniform(0.0, 1.0, 2)
        self._gyro_rng = np.random.default_rng([seed, 1])
        self._fix_rng = np.random.default_rng([seed, 2])
        self._fix_sigma = np.array(
            [s.position_fix_sigma_m, s.position_fix_sigma_m, math.radians(s.heading_fix_sigma_deg)]
        )
        self._delay = fix_delay_samples(vehicle)
        self._pending: deque[tuple[int, PositionFix]] = deque()
        self._previous_theta = math.nan

    def fix_due(self, k: int) -> bool:
        """Whether a fix is measured at sample k: at k = 0 and whenever ⌊t_k·rate⌋ steps."""
        rate = self.params.position_fix_rate_hz
        if rate <= 0:
            return False
        if k == 0:
            return True
        ts = self.sample_period_s
        return math.floor(k * ts * rate + 1e-9) > math.floor((k - 1) * ts * rate + 1e-9)

    def encoder_counts(self, motor_angle_rad: FloatArray) -> NDArray[np.int64]:
        """The counts latched from the true shaft angles (left, right, rad turned since the start)."""
        return np.floor(np.asarray(motor_angle_rad) / self.count_rad + self._phase).astype(np.int64)

    def read(
        self, k: int, encoder_counts: NDArray[np.int64], pose: FloatArray, wheel_speed_m_s: FloatArray
    ) -> Measurements:
        """The readings at sample k: the latched counts, the gyro and the fixes arriving (from the true pose),
        with the rim speeds the wheel loops measured."""
        gyro = math.nan
        theta = float(pose[2])
        s = self.params
        if s.gyro_enabled and k > 0:
            rate = (theta - self._previous_theta) / self.sample_period_s  # eq 40, mean over the sample
            rate += s.gyro_bias_rad_s + s.gyro_sigma_rad_s * float(self._gyro_rng.standard_normal())
            q = s.gyro_quantum_rad_s
            gyro = round(rate / q) * q if q > 0 else rate
        self._previous_theta = theta
        if self.fix_due(k):
            noisy = np.asarray(pose, dtype=float) + self._fix_sigma * self._fix_rng.standard_normal(3)
            noisy[2] = wrap_angle(float(noisy[2]))  # a beacon system reports the heading in [−π, π)
            self._pending.append((k + self._delay, PositionFix(k, k * self.sample_period_s, noisy)))
        arrived = []
        while self._pending and self._pending[0][0] <= k:
            arrived.append(self._pending.popleft()[1])
        return Measurements(
            sample=k,
            t_s=k * self.sample_period_s,
            wheel_speed_m_s=wheel_speed_m_s,
            encoder_counts=encoder_counts,
            gyro_rate_rad_s=gyro,
            fixes=tuple(arrived),
        )
