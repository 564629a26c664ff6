"""Wheel-speed estimators: the motor speeds the wheel loops (and the pose controller) see each sample
(``[controller] wheel_speed``).

* ``exact``: the true motor speeds at t_k (no encoder model; the default, as before sensors were modelled): a
  perfect sensor (:class:`~agvctl.estimation.base.TruthSensor`) that the simulator hands the truth.
* ``count_difference``: the encoder count difference over the last sample, Δn·q/T_s: the mean speed over
  [t_k−1, t_k], half a sample late and quantised to q/T_s.
* ``kalman``: a steady-state Kalman filter per motor on the decoupled model of eqs 60-61,
  ``J̃ ω̇ = k_t/R u − (k_e k_t/R + f_m) ω − τ_d``, with the shaft angle φ (φ̇ = ω, measured by the counts) and a
  random-walk load torque τ_d (friction, eqs 2-4, and the coupling of eqs 56-57 the decoupled model drops).
  The input is the motor voltage the controller commanded through its DA converter and amplifier; when that
  would drive the armature current past I_max (eq 1), the input is the limited current instead. The gain comes
  from python-control's ``dlqe`` (its Riccati solution P, used in the filtered form M = P Cᵀ(C P Cᵀ + R)⁻¹).

A new estimator is a class satisfying :class:`~agvctl.estimation.base.WheelSpeedEstimator`, built from the
controller's vehicle, and one line in :data:`agvctl.estimation.registry.WHEEL_SPEED_ESTIMATORS`.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from agvctl.actuator import Actuator
from agvctl.params import VehicleParams

__all__ = [
    "CountDifference",
    "ExactSpeed",
    "KalmanWheelSpeed",
]

FloatArray = NDArray[np.float64]


class ExactSpeed:
    """The true motor speeds (``wheel_speed = "exact"``): a perfect sensor, handed the truth by the simulator
    (:class:`~agvctl.estimation.base.TruthSensor`).

    Parameters
    ----------
    vehicle : VehicleParams
        Unused: the truth needs no model (the estimators share one constructor).
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        del vehicle
        self._omega = np.zeros(2)

    def reset(self) -> None:
        self._omega = np.zeros(2)

    def observe_truth(self, pose: FloatArray, omega_motor_rad_s: FloatArray) -> None:
        del pose
        self._omega = omega_motor_rad_s

    def update(self, encoder_counts: NDArray[np.int64]) -> FloatArray:
        return self._omega

    def applied(self, da_command_v: FloatArray) -> None:
        del da_command_v


class CountDifference:
    """The count difference over the last sample: Δn·q/T_s (``wheel_speed = "count_difference"``).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its encoders' counts per revolution and its sample period.
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        self.count_rad = 2.0 * math.pi / vehicle.sensors.encoder_counts_per_rev
        self.sample_period_s = vehicle.control.sample_period_s
        self._previous: NDArray[np.int64] | None = None

    def reset(self) -> None:
        self._previous = None

    def update(self, encoder_counts: NDArray[np.int64]) -> FloatArray:
        previous, self._previous = self._previous, encoder_counts
        if previous is None:
            return np.zeros(2)
        return np.asarray((encoder_counts - previous) * (self.count_rad / self.sample_period_s), dtype=float)

    def applied(self, da_command_v: FloatArray) -> None:
        del da_command_v


SPEED_NOISE_RAD_S = 0.2
"""σ of the speed's process noise per sample (rad/s): what eqs 60-61 miss within one sample."""
LOAD_TORQUE_WALK_N_M = 0.005
"""σ of the load torque's random walk per sample (N m): friction and coupling changing."""


def _discrete(a: FloatArray, b: FloatArray, ts: float) -> tuple[FloatArray, FloatArray]:
    """Zero-order-hold discretisation of ẋ = a x + b u over ``ts``."""
    n = a.shape[0]
    m = np.zeros((n + 1, n + 1))
    m[:n, :n], m[:n, n] = a, b
    e = scipy.linalg.expm(m * ts)
    return e[:n, :n], e[:n, n]


Plain = tuple[list[list[float]], list[float]]


def _plain(system: tuple[FloatArray, FloatArray]) -> Plain:
    return system[0].tolist(), system[1].tolist()


class KalmanWheelSpeed:
    """A Kalman filter per motor on eqs 60-61 with a load-torque state (``wheel_speed = "kalman"``).

    Parameters
    ----------
    vehicle : VehicleParams
        The estimator's model: the decoupled wheel model, the actuator chain, the encoders and the sample period.
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        import control

        ts = vehicle.control.sample_period_s
        self.count_rad = 2.0 * math.pi / vehicle.sensors.encoder_counts_per_rev
        self._actuator = Actuator(vehicle)
        self._i_max = vehicle.amplifier.current_limit_a
        g = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
        c = np.array([[1.0, 0.0, 0.0]])
        q = np.diag([SPEED_NOISE_RAD_S**2, LOAD_TORQUE_WALK_N_M**2])
        r = np.array([[self.count_rad**2 / 12.0]])  # uniform quantisation error over one count
        self._sides = []
        gains = []
        for name, consts in (("left", vehicle.derived.left), ("right", vehicle.derived.right)):
            m = vehicle.motor.side(name)  # type: ignore[arg-type]
            j = consts.inertia_equivalent_kg_m2
            # eqs 60-61: J̃ ω̇ = k_t/R u − (k_e k_t/R + f_m) ω − τ_d; with the current i given: J̃ ω̇ = k_t i − f_m ω − τ_d
            a_v = np.array([[0.0, 1.0, 0.0], [0.0, -consts.damping_n_m_s_rad / j, -1.0 / j], [0.0, 0.0, 0.0]])
            a_i = np.array([[0.0, 1.0, 0.0], [0.0, -m.viscous_friction_n_m_s_rad / j, -1.0 / j], [0.0, 0.0, 0.0]])
            voltage = _discrete(a_v, np.array([0.0, m.torque_constant_n_m_a / m.resistance_ohm / j, 0.0]), ts)
            current = _discrete(a_i, np.array([0.0, m.torque_constant_n_m_a / j, 0.0]), ts)
            _l, p, _e = control.dlqe(voltage[0], g, c, q, r)
            p = np.asarray(p, dtype=float)
            gains.append((p @ c.T).ravel() / float((c @ p @ c.T + r)[0, 0]))
            self._sides.append((m, _plain(voltage), _plain(current)))
        self.gain = np.array(gains)
        """The filter gains M (left, right: 3 each) on the angle innovation, from the steady-state Riccati
        solution of ``dlqe``."""
        self._gain: list[list[float]] = self.gain.tolist()
        self._x: list[list[float]] | None = None
        self._u = [0.0, 0.0]

    def reset(self) -> None:
        self._x = None
        self._u = [0.0, 0.0]

    def update(self, encoder_counts: NDArray[np.int64]) -> FloatArray:
        y = ((float(encoder_counts[0]) + 0.5) * self.count_rad, (float(encoder_counts[1]) + 0.5) * self.count_rad)
        if self._x is None:
            self._x = [[y[0], 0.0, 0.0], [y[1], 0.0, 0.0]]
            return np.zeros(2)
        speeds = []
        for s, (m, voltage, current) in enumerate(self._sides):
            x, u = self._x[s], self._u[s]
            i = (u - m.voltage_constant_v_s_rad * x[1]) / m.resistance_ohm  # eq 1
            if abs(i) > self._i_max:
                (a, b), u = current, math.copysign(self._i_max, i)
            else:
                a, b = voltage
            # predict with eqs 60-61 (plain floats: a 3×3 product in numpy costs more than the arithmetic)
            p = [a[r][0] * x[0] + a[r][1] * x[1] + a[r][2] * x[2] + b[r] * u for r in range(3)]
            innovation = y[s] - p[0]
            g = self._gain[s]
            self._x[s] = x = [p[r] + g[r] * innovation for r in range(3)]
            speeds.append(x[1])
        return np.array(speeds)

    def applied(self, da_command_v: FloatArray) -> None:
        self._u = [self._actuator.motor_voltage_v(v) for v in np.asarray(da_command_v, dtype=float).tolist()]
