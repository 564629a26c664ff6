"""The friction experiment on the simulator: the PI loops hold constant speeds, then slow DA ramps per side.

Each control sample is one call of :func:`_sample`: measure → controller → actuate → step, recorded as one log
row. The true plant behind the DA converter and amplifier, with its noisy speed sensor, is :class:`_Bench`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agvctl.actuator import Actuator
from agvctl.calibration.friction.log import FrictionLog
from agvctl.config import document_fields
from agvctl.controllers.pi.options import WheelLoopOptions
from agvctl.controllers.pi.tuning import design_pi
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.params import VehicleParams
from agvctl.sim.stepper import PlantStepper

__all__ = ["FRICTION_WHEEL_LOOPS", "SPEED_NOISE_RAD_S", "FrictionExperiment", "simulate_friction_experiment"]

SPEED_NOISE_RAD_S = 0.5
"""Standard deviation of the simulated motor-speed measurement noise at ``noise_scale = 1`` (rad/s; 0.15 % of
the top motor speed, about 1.4 mm/s at the rim)."""

FRICTION_WHEEL_LOOPS = WheelLoopOptions(coulomb_feedforward=False)
"""The loops that hold the speed plateaus: no friction feed-forward, so the friction being identified reaches the
measured current through the loops alone, not through the model's own guess of it."""


@document_fields
@dataclass(frozen=True)
class FrictionExperiment:
    """How the simulated friction experiment is driven (and what a real one should look like).

    Raises
    ------
    ValueError
        A speed, time or rate that is not a positive number, or fewer than one ramp.
    """

    motor_speeds_rad_s: tuple[float, ...] = (50.0, 100.0, 150.0, 200.0)
    """The constant motor speeds the speed loops hold, both sides alike (straight line), rad/s."""
    both_directions: bool = True
    """Hold every speed forward and in reverse (separates τ_c from an offset; averages direction effects)."""
    settle_s: float = 1.5
    """Time given to reach each speed before the steady window, s."""
    hold_s: float = 3.0
    """Length of each steady window, s."""
    rest_s: float = 1.0
    """Standstill between experiments (0 V), s."""
    ramp_rate_da_v_s: float = 0.05
    """DA voltage ramp rate for the break-away experiment (2 mV, under one DA code, per 40 ms sample), V/s."""
    ramp_repeats: int = 1
    """Ramps per side and direction (forward and reverse each)."""
    ramp_stop_speed_rad_s: float = 5.0
    """The simulated experimenter ends a ramp once the measured speed passes this (the wheel clearly turns),
    rad/s."""

    def __post_init__(self) -> None:
        if not self.motor_speeds_rad_s or any(not (math.isfinite(w) and w > 0) for w in self.motor_speeds_rad_s):
            raise ValueError(f"motor_speeds_rad_s must be positive numbers (got {self.motor_speeds_rad_s})")
        for name in ("settle_s", "hold_s", "rest_s", "ramp_rate_da_v_s", "ramp_stop_speed_rad_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"FrictionExperiment.{name} must be > 0 (got {value})")
        if self.ramp_repeats < 1:
            raise ValueError(f"FrictionExperiment.ramp_repeats must be >= 1 (got {self.ramp_repeats})")


class _Bench:
    """The true plant (full nonlinear model) behind the DA converter and amplifier, with a noisy speed sensor.

    The motor voltage is held over each sample; :meth:`measure` sees the state at the start of the sample.
    """

    def __init__(self, vehicle: VehicleParams, speed_noise_rad_s: float, rng: np.random.Generator) -> None:
        self.sample_period_s = vehicle.control.sample_period_s
        self._stepper = PlantStepper(vehicle)
        self.max_da_voltage_v = Actuator(vehicle).max_da_voltage_v
        self._sigma = speed_noise_rad_s
        self._rng = rng

    def measure(self) -> NDArray[np.float64]:
        """The motor speeds (left, right) in rad/s, with the sensor noise."""
        w = self._stepper.measure()
        return np.asarray(w + (self._rng.normal(0.0, self._sigma, 2) if self._sigma > 0 else 0.0), dtype=float)

    def actuate_and_step(self, da_command_v: NDArray[np.float64]) -> NDArray[np.float64]:
        """Send ``da_command_v`` through the DA converter and amplifier, hold it over one sample; return the DA
        output voltages (V)."""
        return np.asarray(self._stepper.step(da_command_v).da_voltage_v, dtype=float)


@dataclass
class _Rows:
    """The log being written, one row per sample."""

    sample_period_s: float
    phase: list[str] = field(default_factory=list)
    setpoint: list[NDArray[np.float64]] = field(default_factory=list)
    omega: list[NDArray[np.float64]] = field(default_factory=list)
    da_voltage: list[NDArray[np.float64]] = field(default_factory=list)

    def log(self) -> FrictionLog:
        return FrictionLog(
            t_s=np.asarray([k * self.sample_period_s for k in range(len(self.phase))], dtype=float),
            phase=tuple(self.phase),
            setpoint_rad_s=np.asarray(self.setpoint, dtype=float),
            omega_motor_rad_s=np.asarray(self.omega, dtype=float),
            da_voltage_v=np.asarray(self.da_voltage, dtype=float),
            source="<simulated friction experiment>",
        )


Controller = Callable[[NDArray[np.float64]], NDArray[np.float64]]
"""Measured motor speeds (rad/s) → DA command (V)."""


def _sample(
    bench: _Bench, rows: _Rows, phase: str, setpoint: NDArray[np.float64], controller: Controller
) -> NDArray[np.float64]:
    """One control sample: measure → controller → actuate → step, recorded as one row; returns the measurement."""
    measured = bench.measure()
    da_v = bench.actuate_and_step(controller(measured))
    rows.phase.append(phase)
    rows.setpoint.append(setpoint)
    rows.omega.append(measured)
    rows.da_voltage.append(da_v)
    return measured


def simulate_friction_experiment(
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    experiment: FrictionExperiment | None = None,
    *,
    noise_scale: float = 0.0,
    seed: int | None = None,
) -> FrictionLog:
    """Run the friction experiment on the full nonlinear plant and return its log.

    Every command goes through the DA converter and amplifier (:class:`~agvctl.actuator.Actuator`). Sequence: the
    speed loops hold each of ``experiment.motor_speeds_rad_s`` (then the same in reverse) for
    ``settle_s + hold_s`` (phase ``hold``); a stop (``idle``); then, one side at a time with the other at 0 V, a
    DA ramp from 0 V at ``ramp_rate_da_v_s`` until the wheel turns (``ramp``), forward then reverse, each
    followed by ``rest_s`` at 0 V (``idle``).

    Parameters
    ----------
    plant_vehicle : VehicleParams
        The truth, whose friction is to be found.
    controller_vehicle : VehicleParams
        What the PI loops are designed for and know (no friction feed-forward).
    experiment : FrictionExperiment or None
        How the experiment is driven (None: the defaults).
    noise_scale : float
        The measured motor speeds' white Gaussian noise in units of :data:`SPEED_NOISE_RAD_S` (0: none); the
        controller sees the noisy speeds, as a real one would.
    seed : int or None
        The noise's seed.

    Returns
    -------
    FrictionLog
        The experiment's log, one row per control sample.

    Raises
    ------
    ValueError
        A negative or non-finite ``noise_scale``.
    """
    exp = experiment or FrictionExperiment()
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be >= 0 (got {noise_scale})")
    bench = _Bench(plant_vehicle, noise_scale * SPEED_NOISE_RAD_S, np.random.default_rng(seed))
    ts = bench.sample_period_s
    rows = _Rows(ts)
    pi = PIWheelController(controller_vehicle, design_pi(controller_vehicle).gains, FRICTION_WHEEL_LOOPS)
    zero = np.zeros(2)

    def hold(setpoint: NDArray[np.float64]) -> Controller:
        return lambda measured: pi.update(setpoint, measured)

    def open_loop(da_command_v: NDArray[np.float64]) -> Controller:
        return lambda _measured: da_command_v

    def samples(duration_s: float) -> int:
        return max(1, int(round(duration_s / ts)))

    speeds = list(exp.motor_speeds_rad_s)
    if exp.both_directions:
        speeds += [-w for w in exp.motor_speeds_rad_s]
    pi.reset()
    for w_ref in speeds:
        sp = np.array([w_ref, w_ref])
        for _ in range(samples(exp.settle_s + exp.hold_s)):
            _sample(bench, rows, "hold", sp, hold(sp))
    for _ in range(samples(exp.rest_s)):  # brake to a stop on the speed loops, then let go
        _sample(bench, rows, "idle", zero, hold(zero))
    for _ in range(samples(exp.rest_s)):
        _sample(bench, rows, "idle", zero, open_loop(zero))

    _ramps(bench, rows, exp, samples(exp.rest_s))
    return rows.log()


def _ramps(bench: _Bench, rows: _Rows, exp: FrictionExperiment, rest_samples: int) -> None:
    """The break-away ramps: one side at a time, forward then reverse, each followed by a rest at 0 V."""
    ts, v_max, zero = bench.sample_period_s, bench.max_da_voltage_v, np.zeros(2)

    def open_loop(da_command_v: NDArray[np.float64]) -> Controller:
        return lambda _measured: da_command_v

    for side in range(2):
        for sign in (1.0, -1.0):
            for _ in range(exp.ramp_repeats):
                k = 0
                while True:
                    cmd = np.zeros(2)
                    cmd[side] = sign * min(exp.ramp_rate_da_v_s * k * ts, v_max)
                    meas = _sample(bench, rows, "ramp", zero, open_loop(cmd))
                    k += 1
                    if sign * meas[side] > exp.ramp_stop_speed_rad_s or abs(cmd[side]) >= v_max:
                        break
                for _ in range(rest_samples):
                    _sample(bench, rows, "idle", zero, open_loop(zero))
