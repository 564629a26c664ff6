"""Verification of the wheel-speed loops on the full nonlinear plant: a wheel-speed step through the
DA/amplifier.

Both wheels get the same rim-speed step (straight line), i.e. a motor-speed setpoint ω_ref = v N / r per side.
Every sample (:class:`~agvctl.sim.stepper.PlantStepper`): the motor speeds are measured at the sample time,
the controller returns DA voltage commands, the actuator (12-bit DA, amplifier) turns them into motor voltages
held over the sample, and the compiled full model (friction of eqs 2-4, coupling of eqs 52-59, current limit
inside the right-hand side) advances one sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.controllers.base import WheelSpeedController
from agvctl.controllers.pi.options import PIGains, WheelLoopOptions
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.log import SimLog
from agvctl.params import SIDES, VehicleParams
from agvctl.sim.stepper import PlantStepper

__all__ = ["StepMetrics", "WheelStepResult", "step_metrics", "wheel_step_response"]


@document_fields
@dataclass(frozen=True)
class StepMetrics:
    """Step-response figures, all relative to the setpoint (the step size, from rest)."""

    rise_time_s: float
    """From 10 % to 90 % of the setpoint (first crossings, linearly interpolated between samples), s."""
    overshoot_pct: float
    """(peak − setpoint)/setpoint · 100, or 0 if the response never exceeds the setpoint, %."""
    settling_time_s: float
    """Time after which the response stays within ±2 % of the setpoint (``inf`` if it never does), s."""
    steady_state_error_pct: float
    """``|setpoint − mean over the final window|`` / setpoint · 100, %."""


@document_fields
@dataclass(frozen=True)
class WheelStepResult:
    """A simulated step of both wheel loops. Arrays have one row per sample time (n + 1) or per interval
    (n)."""

    t_s: NDArray[np.float64]
    """Sample times k·T_s, k = 0…n, s."""
    setpoint_rad_s: NDArray[np.float64]
    """Motor-speed setpoints (left, right), rad/s."""
    omega_motor_rad_s: NDArray[np.float64]
    """(n + 1) × 2 measured motor speeds at the sample times, rad/s."""
    da_code: NDArray[np.int64]
    """n × 2 DA codes sent."""
    motor_voltage_v: NDArray[np.float64]
    """n × 2 amplifier output voltages, V."""
    current_a: NDArray[np.float64]
    """(n + 1) × 2 armature currents at the sample times, A."""
    current_peak_a: NDArray[np.float64]
    """n × 2 peak ``|current|`` within each sample interval, A."""
    metrics: StepMetrics
    """The worse of the two wheels for each figure."""
    metrics_left: StepMetrics = field(repr=False)
    """The left wheel's figures."""
    metrics_right: StepMetrics = field(repr=False)
    """The right wheel's figures."""


def step_metrics(
    t_s: NDArray[np.float64],
    y: NDArray[np.float64],
    setpoint: float,
    *,
    settle_band: float = 0.02,
    final_window_s: float = 0.5,
) -> StepMetrics:
    """Rise time (10-90 %), overshoot, settling time and steady-state error of a step response from 0.

    Parameters
    ----------
    t_s : ndarray
        The sample times, s.
    y : ndarray
        The response at each, in the setpoint's unit.
    setpoint : float
        The step's size, not zero.
    settle_band : float
        The band about the setpoint the response settles in, relative (0.02: ±2 %).
    final_window_s : float
        How long before the last sample the steady state is averaged over, s.

    Returns
    -------
    StepMetrics
        The figures.

    Examples
    --------
    >>> t = np.arange(0.0, 3.0, 0.01)
    >>> m = step_metrics(t, 1.0 - np.exp(-t / 0.1), 1.0)  # a first-order lag of 0.1 s
    >>> print(f"rise {m.rise_time_s:.3f} s, settling {m.settling_time_s:.3f} s, overshoot {m.overshoot_pct:g} %")
    rise 0.220 s, settling 0.391 s, overshoot 0 %
    """
    t = np.asarray(t_s, dtype=float)
    r = np.asarray(y, dtype=float) / setpoint  # normalised: the target is 1

    def first_crossing(level: float) -> float:
        above = np.nonzero(r >= level)[0]
        if above.size == 0:
            return math.inf
        k = int(above[0])
        if k == 0:
            return float(t[0])
        return float(t[k - 1] + (level - r[k - 1]) / (r[k] - r[k - 1]) * (t[k] - t[k - 1]))

    rise = first_crossing(0.9) - first_crossing(0.1)
    overshoot = max(0.0, float(np.max(r)) - 1.0) * 100.0
    outside = np.nonzero(np.abs(r - 1.0) > settle_band)[0]
    if outside.size == 0:
        settling = float(t[0])
    elif outside[-1] == len(r) - 1:
        settling = math.inf
    else:
        k = int(outside[-1])  # last sample outside the band; interpolate where it enters the band for good
        edge = 1.0 + math.copysign(settle_band, r[k] - 1.0)
        settling = float(t[k] + (edge - r[k]) / (r[k + 1] - r[k]) * (t[k + 1] - t[k]))
    final = r[t >= t[-1] - final_window_s - 1e-12]
    sse = abs(1.0 - float(np.mean(final))) * 100.0
    return StepMetrics(rise_time_s=rise, overshoot_pct=overshoot, settling_time_s=settling, steady_state_error_pct=sse)


def _worst(a: StepMetrics, b: StepMetrics) -> StepMetrics:
    return StepMetrics(
        *(
            max(x, y)
            for x, y in zip(
                (a.rise_time_s, a.overshoot_pct, a.settling_time_s, a.steady_state_error_pct),
                (b.rise_time_s, b.overshoot_pct, b.settling_time_s, b.steady_state_error_pct),
                strict=True,
            )
        )
    )


def wheel_step_response(
    vehicle: VehicleParams,
    gains: PIGains | None = None,
    *,
    controller: WheelSpeedController | None = None,
    wheel_speed_step_m_s: float = 0.3,
    duration_s: float = 3.0,
    options: WheelLoopOptions | None = None,
) -> WheelStepResult:
    """Step both wheels' rim-speed setpoints from rest on the full nonlinear plant.

    All commands go through the DA converter and the amplifier (:class:`~agvctl.actuator.Actuator`).

    Parameters
    ----------
    vehicle : VehicleParams
        The simulated vehicle, also the controller's model.
    gains : PIGains or None
        The gains of a :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController`, when no ``controller`` is
        given.
    controller : WheelSpeedController or None
        The wheel loops to step (None: a PI with ``gains`` and ``options``).
    wheel_speed_step_m_s : float
        The step of both rim speeds, finite and not zero, m/s.
    duration_s : float
        How long to simulate, s.
    options : WheelLoopOptions or None
        The PI's options, when no ``controller`` is given (None: their defaults).

    Returns
    -------
    WheelStepResult
        The response of both wheels and its figures.

    Raises
    ------
    ValueError
        Neither gains nor a controller, a step that is zero or not finite, or a duration that is not positive.
    """
    if controller is None:
        if gains is None:
            raise ValueError("wheel_step_response: give gains or a controller")
        controller = PIWheelController(vehicle, gains, options)
    if not (math.isfinite(wheel_speed_step_m_s) and wheel_speed_step_m_s != 0.0):
        raise ValueError(f"wheel_speed_step_m_s must be finite and non-zero (got {wheel_speed_step_m_s})")
    ts = vehicle.control.sample_period_s
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be positive (got {duration_s})")
    n = max(1, int(round(duration_s / ts)))
    setpoint = np.array([vehicle.to_motor(side, wheel_speed_step_m_s) for side in SIDES])
    plant = PlantStepper(vehicle)
    controller.reset()
    for _ in range(n):
        plant.step(controller.update(setpoint, plant.measure()))
    plant.finish()
    return _result(plant.log(), n, ts, setpoint)


def _result(log: SimLog, n: int, ts: float, setpoint: NDArray[np.float64]) -> WheelStepResult:
    """The step's result from the plant's log of its n samples."""

    def sides(name: str, rows: slice = slice(None)) -> NDArray[np.float64]:
        return np.column_stack([log[name.format("left")][rows], log[name.format("right")][rows]])

    omega = sides("omega_motor_{}_rad_s")
    intervals = slice(0, n)
    t = np.asarray(np.arange(n + 1) * ts, dtype=np.float64)
    m_left = step_metrics(t, omega[:, 0], float(setpoint[0]))
    m_right = step_metrics(t, omega[:, 1], float(setpoint[1]))
    return WheelStepResult(
        t_s=t,
        setpoint_rad_s=setpoint,
        omega_motor_rad_s=omega,
        da_code=sides("da_code_{}", intervals).astype(np.int64),
        motor_voltage_v=sides("motor_voltage_{}_v", intervals),
        current_a=sides("current_{}_a"),
        current_peak_a=sides("current_peak_{}_a", intervals),
        metrics=_worst(m_left, m_right),
        metrics_left=m_left,
        metrics_right=m_right,
    )
