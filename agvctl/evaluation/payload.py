"""What a payload feels: the body's accelerations at a point of it, as an accelerometer there reads them.

A load on the vehicle slides or tips on the acceleration of the point it rests on, not on a wheel's rim: the rim
sees the stiction break-away and a wheel braked through zero, which the body's inertia smooths. The
accelerometer is a point ``(x, y)`` of the body (x ahead of the axle's midpoint, y to its left, m) and a low-pass
filter of a declared bandwidth:

* the body's motion from the run's true speed U and yaw rate ω at each sample (eqs 39-40; the log's ``speed_m_s``
  and ``yaw_rate_rad_s``), differentiated over each sample interval: U̇ and ω̇ are the mean accelerations of the
  interval that ends at the sample (exact for the simulated motion; 0 at the first sample);
* at the point, in the body's frame (a rigid body turning at ω about the axle's midpoint, which moves at U along
  the heading, eqs 39-41): longitudinal U̇ − ω² x − ω̇ y, lateral U ω + ω̇ x − ω² y (U ω is the centripetal
  acceleration of a curve);
* through two equal first-order lags (exact for inputs held over a sample), whose cascade is −3 dB at
  ``bandwidth_hz``. A critically damped filter never overshoots: a constant acceleration reads as itself and never
  more, so a controller at its limit is not failed by the instrument, while a break-away spike of one sample is
  averaged with its neighbours. At the default 2.5 Hz the reading of a step reaches 90 % in 0.16 s: it averages
  over no more than the 200 ms in which a load slides or tips.

The angular acceleration is ω̇ through the same filter; the jerk is the change of the filtered longitudinal reading
over each sample. The columns (:data:`PAYLOAD_LOG_COLUMNS`) are part of every closed-loop log; an experiment's
``[payload]`` table places the accelerometer (:class:`PayloadAccelerometer`), and its ``[limits]`` and
``[[requirements]]`` judge the readings (``peak_body_linear_accel_m_s2``, …).

A wheel held by stiction (at a start, a stop or a reversal) breaks away with the jolt of the friction's jump, and a
wheel held back by its current limit catches up with setpoints that moved on meanwhile: the accelerometer reads
both on top of what the controller commands. :func:`wheel_held` marks those samples (the signal ``wheel_held`` of
a requirement), so that a requirement can judge the payload's limits where the wheels move freely, and say so:
``always (not wheel_held -> abs(body_linear_accel_m_s2) <= 0.3)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import lfilter

from agvctl.config import check_fields, document_fields, number
from agvctl.log import SimLog

__all__ = [
    "HELD_WHEEL_SPEED_M_S",
    "PAYLOAD_LOG_COLUMNS",
    "PAYLOAD_METRICS",
    "PayloadAccelerometer",
    "RECOVERY_S",
    "wheel_held",
]

PAYLOAD_LOG_COLUMNS = (
    "body_linear_accel_m_s2",
    "body_lateral_accel_m_s2",
    "body_angular_accel_rad_s2",
    "body_linear_jerk_m_s3",
)
"""The log columns of the payload's accelerometer: the longitudinal (forward positive) and lateral (to the left
positive) acceleration at its point, the body's angular acceleration (counter-clockwise positive) and the
longitudinal jerk, each through the accelerometer's filter."""

PAYLOAD_METRICS = {
    "peak_body_linear_speed_m_s": ("speed_m_s", " m/s"),
    "peak_body_angular_speed_rad_s": ("yaw_rate_rad_s", " rad/s"),
    "peak_body_linear_accel_m_s2": ("body_linear_accel_m_s2", " m/s²"),
    "peak_body_lateral_accel_m_s2": ("body_lateral_accel_m_s2", " m/s²"),
    "peak_body_angular_accel_rad_s2": ("body_angular_accel_rad_s2", " rad/s²"),
    "peak_body_linear_jerk_m_s3": ("body_linear_jerk_m_s3", " m/s³"),
}
"""The metrics of the body's motion, each the largest magnitude of a log column (and a limit an experiment may
set): by name, the column and the unit as printed. The speeds are the axle midpoint's (the log's ``speed_m_s`` and
``yaw_rate_rad_s``), the accelerations and the jerk the accelerometer's readings."""

_CASCADE = math.sqrt(math.sqrt(2.0) - 1.0)
"""The −3 dB frequency of two equal first-order lags over that of one: |1/(1 + jω τ)|² = 1/√2 at ω τ = this."""


@document_fields
@dataclass(frozen=True)
class PayloadAccelerometer:
    """``[payload]``: where on the body the payload's accelerations are read, and the reading's bandwidth."""

    x_m: float = number(ge=-100.0, le=100.0, default=0.0, doc="The point ahead of the axle's midpoint, m.")
    y_m: float = number(ge=-100.0, le=100.0, default=0.0, doc="The point to the left of the axle's midpoint, m.")
    bandwidth_hz: float = number(
        ge=0.1,
        le=100.0,
        default=2.5,
        doc="The −3 dB frequency of the reading's filter (two equal first-order lags), Hz: 2.5 Hz averages over no "
        "more than the 200 ms in which a load slides or tips.",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def time_constant_s(self) -> float:
        """τ of each of the filter's two lags, s."""
        return _CASCADE / (2.0 * math.pi * self.bandwidth_hz)

    def read(
        self, speed_m_s: ArrayLike, yaw_rate_rad_s: ArrayLike, sample_period_s: float
    ) -> dict[str, NDArray[np.float64]]:
        """The accelerometer's readings at each sample of a run.

        Parameters
        ----------
        speed_m_s : array_like
            The axle midpoint's speed U along the heading at each sample, m/s.
        yaw_rate_rad_s : array_like
            The yaw rate ω at each sample, rad/s.
        sample_period_s : float
            T_s, the samples' spacing, s.

        Returns
        -------
        dict of str to ndarray
            The columns of :data:`PAYLOAD_LOG_COLUMNS`, one value per sample, in their units.
        """
        u = np.asarray(speed_m_s, dtype=np.float64)
        w = np.asarray(yaw_rate_rad_s, dtype=np.float64)
        u_dot = np.concatenate(([0.0], np.diff(u) / sample_period_s))
        w_dot = np.concatenate(([0.0], np.diff(w) / sample_period_s))
        longitudinal = self._filtered(u_dot - w * w * self.x_m - w_dot * self.y_m, sample_period_s)
        lateral = self._filtered(u * w + w_dot * self.x_m - w * w * self.y_m, sample_period_s)
        return {
            "body_linear_accel_m_s2": longitudinal,
            "body_lateral_accel_m_s2": lateral,
            "body_angular_accel_rad_s2": self._filtered(w_dot, sample_period_s),
            "body_linear_jerk_m_s3": np.concatenate(([0.0], np.diff(longitudinal) / sample_period_s)),
        }

    def _filtered(self, values: NDArray[np.float64], sample_period_s: float) -> NDArray[np.float64]:
        """``values`` (held over each sample) through the two lags, from rest."""
        pole = math.exp(-sample_period_s / self.time_constant_s)
        once = lfilter([1.0 - pole], [1.0, -pole], values)
        return np.asarray(lfilter([1.0 - pole], [1.0, -pole], once), dtype=np.float64)


HELD_WHEEL_SPEED_M_S = 0.01
"""A wheel whose rim is slower than this (m/s) is held: by stiction at a start, a stop or a reversal."""
RECOVERY_S = 0.4
"""How long a held wheel's recovery lasts after its last held sample, s: the break-away and the catch-up (decision
record 0041 found every excess of the payload's limits it traced within 0.4 s of a held wheel)."""


def wheel_held(log: SimLog, sample_period_s: float) -> NDArray[np.float64]:
    """1 at each sample where a wheel is held or recovering, else 0.

    A wheel is held at a sample where its rim is slower than :data:`HELD_WHEEL_SPEED_M_S` (stiction), or where it is
    held back by a limit: its wheel loop's output was clamped to its window (``wheel_loop_limited_*``: the current
    limit, the DA range) or the amplifier's current limit acted (``current_limited_*``). It recovers for
    :data:`RECOVERY_S` after its last held sample.

    Parameters
    ----------
    log : SimLog
        The run's log: the wheels' rim speeds, and the limits' flags it has.
    sample_period_s : float
        T_s, s.

    Returns
    -------
    ndarray
        1.0 or 0.0 at each sample.
    """
    speed = np.minimum(np.abs(log["wheel_speed_left_m_s"]), np.abs(log["wheel_speed_right_m_s"]))
    held = speed < HELD_WHEEL_SPEED_M_S
    for column in ("current_limited_{}", "wheel_loop_limited_{}"):
        for side in ("left", "right"):
            if column.format(side) in log:
                held |= np.asarray(log[column.format(side)]) > 0
    after = round(RECOVERY_S / sample_period_s)
    index = np.arange(len(held))
    last_held = np.maximum.accumulate(np.where(held, index, -after - 1))  # before any held sample: too long ago
    return (index - last_held <= after).astype(np.float64)
