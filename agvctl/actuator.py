"""The actuator chain between a controller and the motors: 12-bit DA converter and power amplifier.

The report's figures 3-4, which would show it, are missing; agvctl's chain is that of model note 9
(docs/model-notes.md):

1. the controller commands a DA voltage v (or a code directly);
2. DA: ``code = clip(round(v / α), code_min, code_max)``, ``v_DA = code · α`` with α = 10 V / 4096 for the
   default ±5 V, 12-bit converter (codes −2048…2047; +5 V itself is not reachable); held over the sample;
3. amplifier: ``u = clip(k_pow · v_DA, −u_max, +u_max)``;
4. the armature current limit ±I_max acts inside the plant's right-hand side (:mod:`agvctl.plant.full`).

Nothing reaches the plant except through :meth:`Actuator.apply` (or :meth:`Actuator.from_codes`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.config import document_fields
from agvctl.params import VehicleParams

__all__ = ["Actuator", "ActuatorOutput", "full_scale_voltage_v"]


@document_fields
@dataclass(frozen=True)
class ActuatorOutput:
    """What the actuator chain did with one command (arrays broadcast like the command)."""

    da_code: NDArray[np.int64]
    """The DA code sent."""
    da_voltage_v: NDArray[np.float64]
    """The DA converter's output voltage, code · α, V."""
    motor_voltage_v: NDArray[np.float64]
    """The amplifier's output, the voltage across the motor: clip(k_pow v_DA, ±u_max), V."""
    da_clipped: NDArray[np.bool_]
    """True where the requested voltage was outside the DA's code range."""
    voltage_limited: NDArray[np.bool_]
    """True where the amplifier's voltage limit was active."""


class Actuator:
    """The DA converter and amplifier of one vehicle (both sides identical).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its DA converter (range, bits) and amplifier (gain, voltage limit).

    Examples
    --------
    >>> from agvctl.params import load_vehicle
    >>> out = Actuator(load_vehicle()).apply([1.0, -9.0])  # the right side asks for more than the DA gives
    >>> out.da_code.tolist(), out.motor_voltage_v.round(4).tolist(), out.da_clipped.tolist()
    ([410, -2048], [2.002, -10.0], [False, True])
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        da = vehicle.da
        self.volts_per_code = da.volts_per_code
        self.mid_v = da.mid_v
        self.code_min, self.code_max = da.code_min, da.code_max
        self.gain = vehicle.amplifier.gain
        self.voltage_limit_v = vehicle.amplifier.voltage_limit_v

    def da_code(self, voltage_v: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """The DA code for a requested voltage (round to nearest, clip) and whether it was clipped."""
        # a request far out of range (1e308 V, say) is first brought to just beyond the codes, so the division
        # cannot overflow; its code and its clipped flag stay what they would be
        lo = self.mid_v + (self.code_min - 1) * self.volts_per_code
        hi = self.mid_v + (self.code_max + 1) * self.volts_per_code
        raw = np.rint((np.clip(np.asarray(voltage_v, dtype=float), lo, hi) - self.mid_v) / self.volts_per_code)
        raw = np.nan_to_num(raw, nan=0.0)
        clipped = (raw < self.code_min) | (raw > self.code_max)
        return np.clip(raw, self.code_min, self.code_max).astype(np.int64), clipped

    def from_codes(self, code: ArrayLike, da_clipped: ArrayLike | None = None) -> ActuatorOutput:
        """The chain's output for given DA codes (codes outside the range are clipped and flagged)."""
        raw = np.asarray(code, dtype=np.int64)
        clipped = (raw < self.code_min) | (raw > self.code_max)
        if da_clipped is not None:
            clipped = clipped | np.asarray(da_clipped, dtype=bool)
        code_c = np.clip(raw, self.code_min, self.code_max)
        v_da: NDArray[np.float64] = self.mid_v + code_c.astype(np.float64) * self.volts_per_code
        amplified = self.gain * v_da
        u: NDArray[np.float64] = np.clip(amplified, -self.voltage_limit_v, self.voltage_limit_v)
        return ActuatorOutput(
            da_code=code_c,
            da_voltage_v=v_da,
            motor_voltage_v=u,
            da_clipped=clipped,
            voltage_limited=np.abs(amplified) > self.voltage_limit_v,
        )

    def apply(self, voltage_v: ArrayLike) -> ActuatorOutput:
        """Send requested DA voltages through the DA converter and the amplifier."""
        requested = np.asarray(voltage_v, dtype=float)
        if requested.shape == (2,):  # one sample's pair (left, right): plain floats, the same values
            return self._apply_pair(*requested.tolist())
        code, clipped = self.da_code(requested)
        return self.from_codes(code, clipped)

    def _side(self, voltage_v: float) -> tuple[int, float, float, bool, bool]:
        """:meth:`apply` for one requested voltage in plain floats (a closed loop's per-sample call, where numpy's
        per-call cost would dominate): the DA code, its voltage, the motor voltage, and whether the DA clipped and
        the amplifier limited."""
        steps = (voltage_v - self.mid_v) / self.volts_per_code
        if not math.isfinite(steps):  # as np.nan_to_num: NaN asks for code 0, ±inf for the largest float
            steps = 0.0 if math.isnan(steps) else math.copysign(sys.float_info.max, steps)
        raw = round(steps)  # to the nearest code, ties to even (np.rint)
        code = min(max(raw, self.code_min), self.code_max)
        v_da = self.mid_v + code * self.volts_per_code
        amplified = self.gain * v_da
        u = min(max(amplified, -self.voltage_limit_v), self.voltage_limit_v)
        return code, v_da, u, code != raw, abs(amplified) > self.voltage_limit_v

    def _apply_pair(self, left_v: float, right_v: float) -> ActuatorOutput:
        """:meth:`apply` for one pair of requested voltages, computed side by side in plain floats."""
        left, right = self._side(left_v), self._side(right_v)
        return ActuatorOutput(
            da_code=np.array([left[0], right[0]], dtype=np.int64),
            da_voltage_v=np.array([left[1], right[1]]),
            motor_voltage_v=np.array([left[2], right[2]]),
            da_clipped=np.array([left[3], right[3]]),
            voltage_limited=np.array([left[4], right[4]]),
        )

    def motor_voltage_v(self, voltage_v: float) -> float:
        """The motor voltage for one requested DA voltage: :meth:`apply` for a single side, in plain floats (a
        per-sample estimator's input, where numpy's per-call cost would dominate)."""
        raw = round((voltage_v - self.mid_v) / self.volts_per_code) if math.isfinite(voltage_v) else 0
        code = min(max(raw, self.code_min), self.code_max)
        amplified = self.gain * (self.mid_v + code * self.volts_per_code)
        return min(max(amplified, -self.voltage_limit_v), self.voltage_limit_v)

    @property
    def max_da_voltage_v(self) -> float:
        """The largest DA output, code_max · α (4.9976 V for the default)."""
        return self.mid_v + self.code_max * self.volts_per_code


def full_scale_voltage_v(vehicle: VehicleParams) -> float:
    """The amplifier's output at the DA's largest code: min(k_pow · v_DA(code_max), u_max) (model note 9).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its DA converter and amplifier.

    Returns
    -------
    float
        The largest motor voltage a command can give, V (9.995 V for the default vehicle).
    """
    da = vehicle.da
    return float(
        min(vehicle.amplifier.gain * abs(da.mid_v + da.code_max * da.volts_per_code), vehicle.amplifier.voltage_limit_v)
    )
