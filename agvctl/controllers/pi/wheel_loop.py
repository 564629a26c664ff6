"""Discrete PI wheel-speed loops with anti-windup for the DA range and the amplifier's current limit, and steering
priority when both saturate.

One loop per motor, run every sample period T_s. Input: the motor-speed error e = ω_ref − ω (rad/s);
output: the motor voltage u (V) the amplifier should apply, which :class:`PIWheelController` divides by the
amplifier gain k_pow to get the DA voltage command (the DA converter and amplifier multiply it back,
:mod:`agvctl.actuator`).

The controller, from error to motor voltage, is

    C(z) = k_p + k_i T_s · z / (z − 1) = ((k_p + k_i T_s) z − k_p) / (z − 1)

(backward-Euler integrator), i.e. ``num = [k_p + k_i T_s, −k_p]``, ``den = [1, −1]`` in descending powers
of z. In the time domain: ``I_k = I_{k−1} + k_i T_s e_k``, ``u_k = k_p e_k + I_k`` (+ the optional
feed-forward).

Anti-windup. The controller knows the voltage it commands and the speed it measures, so it predicts the
armature current of eq 1 (inductance neglected): ``i = (u − k_e ω)/R``. The usable motor voltage is therefore

    [k_e ω − R I_max, k_e ω + R I_max] ∩ [u_min, u_max]

with [u_min, u_max] what the DA converter and amplifier can deliver. The output is clamped to that window
(shrunk by half a DA step so that the DA's rounding cannot push the current past I_max), and when the clamp
is active in the direction the integrator is moving the integrator is stopped (conditional integration),
and it is back-calculated onto the window if it alone lies beyond the clamped edge (e.g. when the window
moves with the speed). Stopping rather than fully back-calculating (I = u_sat − k_p e) keeps the full
current available during a current-limited acceleration: the full back-calculation drops the command below
the limit as soon as the error shrinks, since k_p exceeds k_e. The prediction holds at
the start of the sample; over the sample the speed moves towards the command, so ``|i|`` only decreases.

Standstill: with the setpoint exactly zero and the measured speed below ``standstill_rad_s`` (one encoder count
per sample, the resolution of the measurement), the wheel rests, held by stiction: the loop releases it (0 V, no
armature current at a stopped motor, eq 1) and holds its integrator, so that no current holds the wheels against
friction or each other where stiction holds them for free. It rests until the setpoint leaves zero: an estimated
speed's wander at rest (a Kalman estimate re-learning its load torque once the current is gone) is not motion, and a
pose controller that holds at the end of its path commands exactly zero until it wants the vehicle to move. When
the wheel is asked to move again the loop resumes from its integrator.

Steering priority (:class:`PIWheelController`). Each loop alone clamps its own output; when both ask past their
windows the same way (both accelerating, or both braking, beyond what the amplifier gives), clamping each alone
gives both wheels the limit current, and their speed difference, the turn, is then left to the plant's asymmetries
(unequal radii, friction, a head start from a heading correction): the vehicle drifts off the path's heading while
the pose controller, whose setpoints both wheels lag, cannot steer. Instead the common current gives way: the wheel
asking more gets its limit, the other the current it asked less the same excess, so the difference the two loops ask
for (proportional to the difference of their speed errors, the steering error) survives the saturation. The wheel
held below its own limit stops integrating as it would at that limit.

Coulomb-friction feed-forward: ``u_ff = τ_c R / k_t · sign(ω_ref)`` (the voltage that balances the Coulomb torque
τ_c at standstill, eq 1 with the friction of eqs 2-4), on by default
(:class:`~agvctl.controllers.pi.options.WheelLoopOptions`).

Every choice the loops offer is one field of :class:`~agvctl.controllers.pi.options.WheelLoopOptions`, with its
one default: experiments, gains files, ``agvctl tune``, the calibration experiments and the Python constructors all
read it from there.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from agvctl.actuator import Actuator
from agvctl.controllers.pi.options import FEEDFORWARD_RAMP_RAD_S, Braking, PIGains, WheelLoopOptions
from agvctl.errors import expect_instance
from agvctl.params import SIDES, MotorParams, Side, VehicleParams

__all__ = [
    "LoopDemand",
    "PISpeedLoop",
    "PIWheelController",
]


class LoopDemand(NamedTuple):
    """What a :class:`PISpeedLoop` asks for one sample, before its output is clamped.

    Parameters
    ----------
    voltage_v : float
        The unclamped output k_p·e + I + u_ff (0 at rest), V.
    integrator_v : float
        The integrator if this sample's error is integrated, V.
    feedforward_v : float
        The Coulomb feed-forward in it, V.
    window_v : tuple of float
        The usable motor-voltage window (:meth:`PISpeedLoop.usable_voltage_v`; unbounded without anti-windup), V.
    resting : bool
        Whether the loop rests (releases the wheel to stiction, 0 V).
    """

    voltage_v: float
    integrator_v: float
    feedforward_v: float
    window_v: tuple[float, float]
    resting: bool


class PISpeedLoop:
    """The PI loop of one motor, with current-limit and DA-range anti-windup and optional friction
    feed-forward (see the module notes).

    Parameters
    ----------
    gains : PIGains
        k_p, k_i and the sample period.
    motor : MotorParams
        The motor: k_e, k_t and R predict the armature current, τ_c sizes the feed-forward.
    current_limit_a : float
        I_max, the armature current the output keeps within, A.
    voltage_min_v, voltage_max_v : float
        The motor-voltage range the DA converter and amplifier can deliver, V.
    quantum_v : float
        One DA step in motor volts (k_pow·α), to keep the rounded command inside the current window, V.
    coulomb_feedforward : bool
        Add the Coulomb-friction feed-forward τ_c R/k_t (:attr:`WheelLoopOptions.coulomb_feedforward`).
    anti_windup : bool
        Clamp the output to the current window and the DA range, and stop the integrator there
        (:attr:`WheelLoopOptions.anti_windup`).
    braking_current_limit_a : float or None
        The largest current opposing the motion (None: ``current_limit_a``), A.
    braking_limit_below_rad_s : float
        The braking limit applies only while ``|ω|`` is below this motor speed (inf: always), rad/s.
    standstill_rad_s : float
        Below this measured motor speed, with a zero setpoint, the wheel rests and the loop releases it to
        stiction, 0 V (0: never), rad/s.

    Raises
    ------
    ValueError
        ``voltage_min_v`` not below ``voltage_max_v``.
    """

    def __init__(
        self,
        gains: PIGains,
        motor: MotorParams,
        *,
        current_limit_a: float,
        voltage_min_v: float,
        voltage_max_v: float,
        quantum_v: float = 0.0,
        coulomb_feedforward: bool,
        anti_windup: bool,
        braking_current_limit_a: float | None = None,
        braking_limit_below_rad_s: float = math.inf,
        standstill_rad_s: float = 0.0,
    ) -> None:
        if not voltage_min_v < voltage_max_v:
            raise ValueError(f"voltage_min_v must be below voltage_max_v (got {voltage_min_v}, {voltage_max_v})")
        self.gains = gains
        self.k_e = motor.voltage_constant_v_s_rad
        self.k_t = motor.torque_constant_n_m_a
        self.R = motor.resistance_ohm
        self.tau_c = motor.coulomb_friction_n_m
        self.current_limit_a = current_limit_a
        self.braking_current_limit_a = current_limit_a if braking_current_limit_a is None else braking_current_limit_a
        """Largest current opposing the motion (braking); see :func:`symmetric_braking_current_a`."""
        self.braking_limit_below_rad_s = braking_limit_below_rad_s
        """The braking limit applies only while ``|ω|`` is below this speed (inf: always)."""
        self.voltage_min_v = voltage_min_v
        self.voltage_max_v = voltage_max_v
        self.quantum_v = quantum_v
        self.coulomb_feedforward = coulomb_feedforward
        self.anti_windup = anti_windup
        self.standstill_rad_s = standstill_rad_s
        """Below this measured speed, with a zero setpoint, the wheel rests: 0 V, held by stiction (0: never)."""
        self.integrator_v = 0.0
        """The integrator state I (V of motor voltage)."""
        self._last_v: float | None = None
        self._resting = False
        self.limited = False
        """Whether the last :meth:`update` was clamped by the current window or the DA range."""

    def reset(self) -> None:
        """Zero the integrator."""
        self.integrator_v = 0.0
        self.limited = False
        self._last_v = None
        self._resting = False

    def predicted_current_a(self, motor_voltage_v: float, measured_rad_s: float) -> float:
        """Armature current of eq 1 at the start of the sample: ``(u − k_e ω)/R``."""
        return (motor_voltage_v - self.k_e * measured_rad_s) / self.R

    def usable_voltage_v(self, measured_rad_s: float) -> tuple[float, float]:
        """The motor-voltage window ``[k_e ω − R I_max, k_e ω + R I_max] ∩ [u_min, u_max]`` (less half a DA
        step at the current-limit edges), the side that brakes the motor limited to the braking current.
        If the window is empty (the motor spins faster than the
        amplifier's range can hold within I_max) both ends are the range end nearest to it, which gives the
        smallest current."""
        back_emf_v = self.k_e * measured_rad_s  # eq 1
        margin_v = self.R * self.current_limit_a - 0.5 * self.quantum_v
        brake_v = max(0.0, self.R * self.braking_current_limit_a - 0.5 * self.quantum_v)
        if abs(measured_rad_s) >= self.braking_limit_below_rad_s:
            brake_v = margin_v
        # a current against the motion brakes: friction helps it, so it may be smaller for the same deceleration
        lo = max(back_emf_v - (brake_v if measured_rad_s > 0 else margin_v), self.voltage_min_v)
        hi = min(back_emf_v + (brake_v if measured_rad_s < 0 else margin_v), self.voltage_max_v)
        if lo > hi:
            edge = self.voltage_max_v if back_emf_v > 0 else self.voltage_min_v
            return edge, edge
        return lo, hi

    def feedforward_v(self, setpoint_rad_s: float) -> float:
        """Coulomb-friction feed-forward τ_c R/k_t · sat(ω_ref / ω_ε) if enabled, else 0.

        The sign function is ramped over ``|ω_ref|`` ≤ ω_ε = :data:`FEEDFORWARD_RAMP_RAD_S`: a pose controller
        holding the vehicle still commands setpoints of ±1e-5 rad/s, and a full ±τ_c R/k_t flipping on those
        would break the motors away and chatter at standstill.
        """
        if not self.coulomb_feedforward:
            return 0.0
        ramp = max(-1.0, min(1.0, setpoint_rad_s / FEEDFORWARD_RAMP_RAD_S))
        return self.tau_c * self.R / self.k_t * ramp

    def update(self, setpoint_rad_s: float, measured_rad_s: float) -> float:
        """The motor voltage (V) for this sample (0 at rest: the wheel released to stiction)."""
        demand = self.demand(setpoint_rad_s, measured_rad_s)
        return self.commit(demand, *demand.window_v)

    def demand(self, setpoint_rad_s: float, measured_rad_s: float) -> LoopDemand:
        """What the loop asks for this sample, before its output is clamped (advances nothing)."""
        stopped = self._resting or abs(measured_rad_s) < self.standstill_rad_s
        if setpoint_rad_s == 0.0 and stopped and self._last_v is not None:
            return LoopDemand(0.0, self.integrator_v, 0.0, (0.0, 0.0), True)
        g = self.gains
        e = setpoint_rad_s - measured_rad_s
        ff = self.feedforward_v(setpoint_rad_s)
        integrator = self.integrator_v + g.ki * g.dt_s * e
        window = self.usable_voltage_v(measured_rad_s) if self.anti_windup else (-math.inf, math.inf)
        return LoopDemand(g.kp * e + integrator + ff, integrator, ff, window, False)

    def commit(self, demand: LoopDemand, lo_v: float, hi_v: float) -> float:
        """Apply ``demand`` with its output clamped to ``[lo_v, hi_v]`` (within its own window): the integrator
        stops where the clamp acts in its direction, and never alone asks for more than the clamped edge."""
        self._resting = demand.resting
        if demand.resting:
            self.limited = False
            return demand.voltage_v
        u_raw, integrator, ff = demand.voltage_v, demand.integrator_v, demand.feedforward_v
        u = min(max(u_raw, lo_v), hi_v)
        self.limited = u != u_raw
        if u_raw > hi_v:
            # stop integrating upwards; the integrator alone never asks for more than the window's top
            integrator = min(self.integrator_v, integrator, hi_v - ff)
        elif u_raw < lo_v:
            integrator = max(self.integrator_v, integrator, lo_v - ff)
        self.integrator_v = integrator
        self._last_v = u
        return u


def symmetric_braking_current_a(vehicle: VehicleParams, side: Side) -> float:
    """The braking current that decelerates a wheel no harder than a_lim (eq 5): (a_lim J̃ N/r − τ_c)/k_t, A.

    Accelerating, the motor torque fights the Coulomb friction and I_max gives at most a_lim. Braking, friction
    helps: k_t I_b + τ_c decelerates the wheel's equivalent inertia J̃ (eq 60) at a_lim for the I_b above
    (0.50 A for the IAU AGV, against 5.5 A). Full braking current near a stop would decelerate a wheel at
    (k_t I_max + τ_c)/J̃ ≈ 2.7 a_lim, notably when a wheel is stopped to reverse (spin in place after a line).
    :class:`PIWheelController` applies it always (:attr:`Braking.SYMMETRIC`) or only in the last sample before a
    wheel stops (:attr:`Braking.GENTLE_STOP`), so that braking at speed keeps its full authority.
    """
    m = vehicle.motor.side(side)
    j_eq = vehicle.derived.side(side).inertia_equivalent_kg_m2
    torque = vehicle.to_motor(side, vehicle.derived.accel_limit_m_s2 * j_eq) - m.coulomb_friction_n_m
    return min(vehicle.amplifier.current_limit_a, max(0.0, torque / m.torque_constant_n_m_a))


def gentle_stop_speed_rad_s(vehicle: VehicleParams, side: Side) -> float:
    """Below this motor speed a braking wheel is about to stop (and maybe reverse): the speed a_lim removes in
    one sample, a_lim T_s N / r (9.5 rad/s, 2.6 cm/s at the rim, for the IAU AGV)."""
    return vehicle.to_motor(side, vehicle.derived.accel_limit_m_s2 * vehicle.control.sample_period_s)


class PIWheelController:
    """Both wheels' PI loops: a :class:`~agvctl.controllers.base.WheelSpeedController`.

    ``update`` takes motor-speed setpoints and measurements (rad/s, left and right) and returns DA voltage
    commands (V) = motor voltage / k_pow. Each loop rests (releases its wheel to stiction, 0 V) with a zero setpoint
    and a measured speed below one encoder count per sample (:class:`PISpeedLoop`'s ``standstill_rad_s``).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: per-side motor constants, the DA converter's range and the amplifier's gain and
        voltage and current limits.
    gains : PIGains
        k_p (V s/rad), k_i (V/rad) and the sample period (s) of both loops, from
        :func:`~agvctl.controllers.pi.tuning.design_pi`.
    options : WheelLoopOptions
        The loops' choices (feed-forward, anti-windup, braking, steering priority); default: their defaults.

    Examples
    --------
    >>> import numpy as np
    >>> from agvctl.params import load_vehicle
    >>> from agvctl.controllers.pi import default_pi_gains
    >>> vehicle = load_vehicle()
    >>> loops = PIWheelController(vehicle, default_pi_gains(vehicle).gains)
    >>> loops.update(np.array([10.0, 10.0]), np.array([0.0, 0.0])).round(3)  # DA volts for a 10 rad/s step
    array([0.899, 0.899])

    of which the Coulomb feed-forward τ_c R/k_t, over the amplifier's gain, is

    >>> motor = vehicle.motor.left
    >>> feedforward_v = motor.coulomb_friction_n_m * motor.resistance_ohm / motor.torque_constant_n_m_a
    >>> round(feedforward_v / vehicle.amplifier.gain, 3)
    0.457
    """

    def __init__(
        self,
        vehicle: VehicleParams,
        gains: PIGains,
        options: WheelLoopOptions | None = None,
    ) -> None:
        expect_instance(vehicle, VehicleParams, "PIWheelController", "vehicle")
        expect_instance(gains, PIGains, "PIWheelController", "gains")
        options = WheelLoopOptions() if options is None else options
        expect_instance(options, WheelLoopOptions, "PIWheelController", "options")
        braking = options.braking
        act = Actuator(vehicle)
        self.amplifier_gain = act.gain
        u_max = vehicle.amplifier.voltage_limit_v
        da_min_v = act.mid_v + act.code_min * act.volts_per_code
        v_min = max(act.gain * da_min_v, -u_max)
        v_max = min(act.gain * act.max_da_voltage_v, u_max)
        self.loops = tuple(
            PISpeedLoop(
                gains,
                vehicle.motor.side(side),
                current_limit_a=vehicle.amplifier.current_limit_a,
                voltage_min_v=v_min,
                voltage_max_v=v_max,
                quantum_v=act.gain * act.volts_per_code,
                coulomb_feedforward=options.coulomb_feedforward,
                anti_windup=options.anti_windup,
                braking_current_limit_a=(
                    None if braking is Braking.FULL else symmetric_braking_current_a(vehicle, side)
                ),
                braking_limit_below_rad_s=(
                    gentle_stop_speed_rad_s(vehicle, side) if braking is Braking.GENTLE_STOP else math.inf
                ),
                standstill_rad_s=2.0
                * math.pi
                / vehicle.sensors.encoder_counts_per_rev
                / vehicle.control.sample_period_s,
            )
            for side in SIDES
        )
        self.gains = gains
        self.options = options
        self.steering_priority = options.steering_priority

    def reset(self) -> None:
        """Zero both integrators."""
        for loop in self.loops:
            loop.reset()

    @property
    def limited(self) -> tuple[bool, bool]:
        """Whether each loop's last output (left, right) was clamped to its window: the current limit, the DA
        range, or the steering priority's share of them. The closed loop logs it (``wheel_loop_limited_*``)."""
        left, right = self.loops
        return left.limited, right.limited

    def motor_voltages_v(
        self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """The motor voltages (left, right) in V for one sample (advances the integrators)."""
        sp = np.asarray(setpoint_rad_s, dtype=float).tolist()
        meas = np.asarray(measured_rad_s, dtype=float).tolist()
        left, right = self.loops
        asked = (left.demand(sp[0], meas[0]), right.demand(sp[1], meas[1]))
        windows = self._windows(asked) if self.steering_priority else (asked[0].window_v, asked[1].window_v)
        return np.array([loop.commit(d, *w) for loop, d, w in zip(self.loops, asked, windows, strict=True)])

    def _windows(self, asked: tuple[LoopDemand, LoopDemand]) -> tuple[tuple[float, float], tuple[float, float]]:
        """Each loop's output window with the steering priority: where both ask past their windows the same way,
        the common current gives way by the larger excess (see the module notes)."""
        (lo_l, hi_l), (lo_r, hi_r) = asked[0].window_v, asked[1].window_v
        if asked[0].resting or asked[1].resting:
            return (lo_l, hi_l), (lo_r, hi_r)
        u_l, u_r = asked[0].voltage_v, asked[1].voltage_v
        r_l, r_r = self.loops[0].R, self.loops[1].R
        above_l, above_r = (u_l - hi_l) / r_l, (u_r - hi_r) / r_r  # A past the top
        below_l, below_r = (lo_l - u_l) / r_l, (lo_r - u_r) / r_r  # A past the bottom
        if above_l > 0.0 and above_r > 0.0:
            excess = max(above_l, above_r)
            hi_l, hi_r = max(lo_l, min(hi_l, u_l - r_l * excess)), max(lo_r, min(hi_r, u_r - r_r * excess))
        elif below_l > 0.0 and below_r > 0.0:
            excess = max(below_l, below_r)
            lo_l, lo_r = min(hi_l, max(lo_l, u_l + r_l * excess)), min(hi_r, max(lo_r, u_r + r_r * excess))
        return (lo_l, hi_l), (lo_r, hi_r)

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """DA voltage commands (left, right) in V for one sample: motor voltage / k_pow."""
        return self.motor_voltages_v(setpoint_rad_s, measured_rad_s) / self.amplifier_gain
