"""The actuator chain between a controller and the motors: 12-bit DA converter and power amplifier.

The report's figures 3-4, which would show it, are missing; agvctl's chain is that of the README's "Model notes",
note 9:

1. the controller commands a DA voltage v (or a code directly);
2. DA: ``code = clip(round(v / α), code_min, code_max)``, ``v_DA = code · α`` with α = 10 V / 4096 for the
   default ±5 V, 12-bit converter (codes −2048…2047; +5 V itself is not reachable); held over the sample;
3. amplifier: ``u = clip(k_pow · v_DA, −u_max, +u_max)``;
4. the armature current limit ±I_max acts inside the plant's right-hand side (:mod:`agvctl.plant.full`).

Nothing reaches the plant except through :meth:`Actuator.apply` (or :meth:`Actuator.from_codes`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.params import VehicleParams

__all__ = ["Actuator", "ActuatorOutput"]


@dataclass(frozen=True)
class ActuatorOutput:
    """What the actuator chain did with one command (arrays broadcast like the command)."""

    da_code: NDArray[np.int64]
    """The DA code sent."""
    da_voltage_v: NDArray[np.float64]
    """The DA converter's output voltage, code · α."""
    motor_voltage_v: NDArray[np.float64]
    """The amplifier's output, the voltage across the motor: clip(k_pow v_DA, ±u_max)."""
    da_clipped: NDArray[np.bool_]
    """True where the requested voltage was outside the DA's code range."""
    voltage_limited: NDArray[np.bool_]
    """True where the amplifier's voltage limit was active."""


class Actuator:
    """The DA converter and amplifier of one vehicle (both sides identical)."""

    def __init__(self, vehicle: VehicleParams) -> None:
        da = vehicle.da
        self.volts_per_code = da.volts_per_code
        self.mid_v = da.mid_v
        self.code_min, self.code_max = da.code_min, da.code_max
        self.gain = vehicle.amplifier.gain
        self.voltage_limit_v = vehicle.amplifier.voltage_limit_v

    def da_code(self, voltage_v: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
        """The DA code for a requested voltage (round to nearest, clip) and whether it was clipped."""
        raw = np.rint((np.asarray(voltage_v, dtype=float) - self.mid_v) / self.volts_per_code)
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
        code, clipped = self.da_code(voltage_v)
        return self.from_codes(code, clipped)

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
