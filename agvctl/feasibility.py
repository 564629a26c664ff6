"""What the actuator chain can deliver to the wheels: reachable rim accelerations, feasible path limits and the
headroom a plan leaves for feedback (eqs 5 and 33 with the amplifier's current limit and full-scale voltage)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.actuator import full_scale_voltage_v
from agvctl.config import document_fields
from agvctl.errors import ConfigError, expect_instance
from agvctl.params import SIDES, VehicleParams

__all__ = [
    "CURRENT_HEADROOM",
    "MIN_HEADROOM",
    "VOLTAGE_HEADROOM",
    "FeasibleLimits",
    "HeadroomWarning",
    "WheelReach",
    "actuator_headroom",
    "feasible_wheel_limits",
    "feedback_accel_m_s2",
    "no_default_limit_reasons",
    "torque_accel_limit_m_s2",
    "wheel_accel_reach_m_s2",
]

CURRENT_HEADROOM = 0.2
"""Fraction of I_max a default path leaves to the feedback (the plan uses at most 80 %)."""
VOLTAGE_HEADROOM = 0.2
"""Fraction of the full-scale amplifier voltage a default path leaves to the feedback."""
MIN_HEADROOM = 0.1
"""Explicit path limits that leave less than this fraction of current or voltage get a :class:`HeadroomWarning`."""


class HeadroomWarning(UserWarning):
    """Explicit path limits the actuator can deliver, but with too little current or voltage left for feedback."""


@dataclass(frozen=True)
class _Side:
    """One side's constants for the straight-line drive model of eq 5 (both wheels alike, J_tot = J + M r²/(2N²))."""

    r_over_n: float
    j_tot: float
    k_t: float
    k_e: float
    resistance: float
    f_m: float
    tau_c: float
    tau_s: float


def _sides(vehicle: VehicleParams) -> tuple[_Side, _Side]:
    mass = vehicle.body.mass_kg
    out = []
    for side in SIDES:
        r, mp = vehicle.wheels.side(side).radius_m, vehicle.motor.side(side)
        n = mp.gear_ratio
        out.append(
            _Side(
                vehicle.rim_per_motor_rad(side),
                mp.inertia_kg_m2 + 0.5 * mass * r**2 / n**2,  # eq 5
                mp.torque_constant_n_m_a,
                mp.voltage_constant_v_s_rad,
                mp.resistance_ohm,
                mp.viscous_friction_n_m_s_rad,
                mp.coulomb_friction_n_m,
                mp.stiction_n_m,
            )
        )
    return out[0], out[1]


def _check_headroom(value: object, source: str, argument: str) -> float:
    """A headroom fraction: a real number in [0, 1)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(source, argument, f"expected a number (got {value!r})")
    if not 0.0 <= float(value) < 1.0:
        raise ConfigError(source, argument, f"must be in [0, 1) (got {value!r})")
    return float(value)


class WheelReach:
    """The largest rim accelerations each wheel can reach at its rim speed.

    From eq 33 with the current limit and the full-scale voltage: i = min(I_max, (u_fs − k_e ω)/R) (not below 0),
    J_tot ω̇ = k_t i − f_m ω − τ_c sign(ω) (τ_s from rest), J_tot of eq 5 (both wheels alike). Constants are gathered
    once; a call is a few array operations.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: each side's motor constants, gear ratio and wheel radius, its mass, the amplifier's current limit
        I_max and the full-scale motor voltage u_fs.
    """

    def __init__(self, vehicle: VehicleParams) -> None:
        expect_instance(vehicle, VehicleParams, "WheelReach", "vehicle")
        sides = _sides(vehicle)

        def field(name: str) -> NDArray[np.float64]:
            return np.array([getattr(side, name) for side in sides], dtype=np.float64)

        self._r_over_n, self._j_tot, self._k_t = field("r_over_n"), field("j_tot"), field("k_t")
        self._k_e, self._resistance, self._f_m = field("k_e"), field("resistance"), field("f_m")
        self._tau_c, self._tau_s = field("tau_c"), field("tau_s")
        self._u_fs, self._i_max = full_scale_voltage_v(vehicle), vehicle.amplifier.current_limit_a
        pair = tuple((s.r_over_n, s.k_e, s.resistance, s.k_t, s.f_m, s.tau_c, s.tau_s, s.j_tot) for s in sides)
        self._way_constants = pair + pair
        """Each side's constants for :meth:`accel_pair_m_s2`'s four ways (up left, up right, down left, down right)."""

    @property
    def constants(self) -> tuple[float, float, tuple[float, ...], tuple[float, ...]]:
        """What :meth:`accel_pair_m_s2` computes from: u_fs (V), I_max (A), and each side's r/n (m/rad), k_e, R, k_t,
        f_m, τ_c, τ_s and J_tot (SI units), left then right (what a generated controller takes)."""
        left, right = self._way_constants[0], self._way_constants[1]
        return self._u_fs, self._i_max, left, right

    def _up(self, v: NDArray[np.float64]) -> NDArray[np.float64]:
        omega = v / self._r_over_n
        current = np.clip((self._u_fs - self._k_e * omega) / self._resistance, 0.0, self._i_max)
        friction = np.where(omega > 0, self._tau_c, np.where(omega < 0, -self._tau_c, self._tau_s))
        accel = (self._k_t * current - self._f_m * omega - friction) / self._j_tot * self._r_over_n
        return np.asarray(np.maximum(accel, 0.0), dtype=np.float64)

    def accel_pair_m_s2(self, left_m_s: float, right_m_s: float) -> tuple[float, float, float, float]:
        """(up_left, up_right, down_left, down_right) of :meth:`accel_m_s2` for one pair of rim speeds, in plain
        floats (a controller's per-sample call: no array overhead)."""
        out = []
        u_fs, i_max = self._u_fs, self._i_max
        ways = zip((left_m_s, right_m_s, -left_m_s, -right_m_s), self._way_constants, strict=True)  # down(v) = up(−v)
        for v, (r_n, k_e, resistance, k_t, f_m, tau_c, tau_s, j_tot) in ways:
            omega = v / r_n
            # min(max(·, 0), I_max) and max(·, 0) as the comparisons the builtins make: the same, per call cheaper
            current = (u_fs - k_e * omega) / resistance
            current = 0.0 if current < 0.0 else current
            current = i_max if i_max < current else current
            friction = tau_c if omega > 0 else (-tau_c if omega < 0 else tau_s)
            accel = (k_t * current - f_m * omega - friction) / j_tot * r_n
            out.append(0.0 if accel < 0.0 else accel)
        return out[0], out[1], out[2], out[3]

    def accel_m_s2(self, wheel_speed_m_s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(up, down) ≥ 0 in m/s², shaped like ``wheel_speed_m_s`` (…, 2: left, right): towards +v and towards −v
        (the mirror image, down(v) = up(−v))."""
        v = np.asarray(wheel_speed_m_s, dtype=np.float64)
        return self._up(v), self._up(-v)


def wheel_accel_reach_m_s2(
    vehicle: VehicleParams, wheel_speed_m_s: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The largest rim accelerations the wheels of ``vehicle`` can reach at the given rim speeds.

    :meth:`WheelReach.accel_m_s2` for a vehicle whose reach is asked once.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle.
    wheel_speed_m_s : array_like
        Rim speeds, shape (…, 2): left, right, m/s.

    Returns
    -------
    up_m_s2 : ndarray
        The largest acceleration towards +v, at least 0, shaped like ``wheel_speed_m_s``, m/s².
    down_m_s2 : ndarray
        The largest acceleration towards −v, at least 0: the mirror image, down(v) = up(−v), m/s².
    """
    expect_instance(vehicle, VehicleParams, "wheel_accel_reach_m_s2", "vehicle")
    return WheelReach(vehicle).accel_m_s2(wheel_speed_m_s)


@document_fields
@dataclass(frozen=True)
class FeasibleLimits:
    """Wheel limits a path can be planned at with headroom left for feedback (nominal vehicle)."""

    wheel_speed_m_s: float
    """The speed at which accelerating at ``wheel_accel_m_s2`` still leaves ``voltage_headroom`` of u_fs, m/s."""
    wheel_accel_m_s2: float
    """The acceleration that leaves ``current_headroom`` of I_max (eq 5 with (1 − headroom) I_max), m/s²."""
    current_headroom: float
    """The fraction of the current limit I_max left to the feedback."""
    voltage_headroom: float
    """The fraction of the full-scale motor voltage u_fs left to the feedback."""


def feasible_wheel_limits(
    vehicle: VehicleParams, current_headroom: float = CURRENT_HEADROOM, voltage_headroom: float = VOLTAGE_HEADROOM
) -> FeasibleLimits:
    """The default path limits: the wheel speed and acceleration a plan may use, leaving headroom for feedback.

    The acceleration is eq 5's with (1 − ``current_headroom``)·I_max; the speed is the one at which that acceleration
    needs (1 − ``voltage_headroom``)·u_fs: u = R i + k_e ω with k_t i = J_tot a N/r + τ_c + f_m ω (eq 33 at the current
    limit's share). Each is the smaller of the two sides'.

    Parameters
    ----------
    vehicle : VehicleParams
        The nominal vehicle.
    current_headroom : float
        The fraction of the current limit I_max to leave to the feedback.
    voltage_headroom : float
        The fraction of the full-scale motor voltage u_fs to leave to the feedback.

    Returns
    -------
    FeasibleLimits
        The limits, zero where the vehicle cannot meet them (:func:`no_default_limit_reasons` says why), and the
        headrooms.

    Raises
    ------
    ConfigError
        ``feasible_wheel_limits: <argument>: <problem>``: a vehicle that is not a :class:`VehicleParams`, or a
        headroom that is not a number in [0, 1).
    """
    expect_instance(vehicle, VehicleParams, "feasible_wheel_limits", "vehicle")
    current_headroom = _check_headroom(current_headroom, "feasible_wheel_limits", "current_headroom")
    voltage_headroom = _check_headroom(voltage_headroom, "feasible_wheel_limits", "voltage_headroom")
    u_fs, i_max = full_scale_voltage_v(vehicle), vehicle.amplifier.current_limit_a
    accels, speeds = [], []
    for s in _sides(vehicle):
        torque = (1.0 - current_headroom) * i_max * s.k_t - s.tau_c
        a = max(torque, 0.0) / s.j_tot * s.r_over_n
        accel_torque = s.j_tot * a / s.r_over_n + s.tau_c
        omega = ((1.0 - voltage_headroom) * u_fs - s.resistance * accel_torque / s.k_t) / (
            s.k_e + s.resistance * s.f_m / s.k_t
        )
        accels.append(a)
        speeds.append(max(omega, 0.0) * s.r_over_n)
    return FeasibleLimits(min(speeds), min(accels), current_headroom, voltage_headroom)


def _full_scale_source(vehicle: VehicleParams) -> str:
    """The vehicle keys that set the full-scale motor voltage u_fs = min(k_pow · v_DA(code_max), u_max)."""
    amp, da = vehicle.amplifier, vehicle.da
    if amp.voltage_limit_v <= amp.gain * abs(da.mid_v + da.code_max * da.volts_per_code):
        return f"amplifier.voltage_limit_v = {amp.voltage_limit_v:g} V"
    return f"da.max_v = {da.max_v:g} V through amplifier.gain = {amp.gain:g}"


def no_default_limit_reasons(vehicle: VehicleParams, limits: FeasibleLimits) -> dict[str, str]:
    """Why a limit of :func:`feasible_wheel_limits` is zero: the vehicle cannot move, or not with the headroom.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle the limits are for.
    limits : FeasibleLimits
        Its limits, from :func:`feasible_wheel_limits`.

    Returns
    -------
    dict of str to str
        A sentence for each zero limit, naming the vehicle keys behind it, by the path-file key the limit is the
        default of (``wheel_speed_m_s``, ``wheel_accel_m_s2``); empty when both are positive.
    """
    expect_instance(vehicle, VehicleParams, "no_default_limit_reasons", "vehicle")
    expect_instance(limits, FeasibleLimits, "no_default_limit_reasons", "limits")
    reasons: dict[str, str] = {}
    u_fs, i_max = full_scale_voltage_v(vehicle), vehicle.amplifier.current_limit_a
    sides = _sides(vehicle)
    if limits.wheel_accel_m_s2 <= 0:
        share = 1.0 - limits.current_headroom
        torque = min(share * i_max * s.k_t for s in sides)
        tau_c = max(s.tau_c for s in sides)
        reasons["wheel_accel_m_s2"] = (
            f"the wheels cannot accelerate: {share:.0%} of the current limit (amplifier.current_limit_a = "
            f"{i_max:g} A) gives {torque:.3g} N·m, not above the Coulomb friction {tau_c:.3g} N·m"
        )
    if limits.wheel_speed_m_s <= 0:
        breakaway = max(s.tau_s * s.resistance / s.k_t for s in sides)
        u_share, i_share = 1.0 - limits.voltage_headroom, 1.0 - limits.current_headroom
        r_i = max(s.resistance for s in sides) * i_share * i_max
        if u_fs < breakaway:
            why = (
                f"the vehicle cannot move: its full-scale motor voltage {u_fs:.3g} V ({_full_scale_source(vehicle)})"
                f" is below the break-away voltage τ_s R/k_t = {breakaway:.3g} V"
            )
        else:
            why = (
                f"{u_share:.0%} of the full-scale motor voltage {u_fs:.3g} V ({_full_scale_source(vehicle)}) is used "
                f"up by R·i = {r_i:.3g} V at the default acceleration ({i_share:.0%} of I_max): none is left for speed"
            )
        reasons["wheel_speed_m_s"] = why
    return reasons


def actuator_headroom(
    vehicle: VehicleParams, wheel_speed_m_s: ArrayLike, wheel_accel_m_s2: ArrayLike
) -> tuple[float, float]:
    """The smallest fractions of the current limit and of the full-scale voltage that driving a plan leaves unused.

    The nominal vehicle on the straight-line model of eq 5 (both wheels alike): the current from
    k_t i = J_tot a N/r + τ_c sign(ω) + f_m ω and the voltage u = R i + k_e ω (eq 33), at every sample and on either
    side.

    Parameters
    ----------
    vehicle : VehicleParams
        The nominal vehicle.
    wheel_speed_m_s : array_like
        The plan's rim speeds, shape (…, 2): left, right, m/s.
    wheel_accel_m_s2 : array_like
        The rim accelerations at those speeds, the same shape, m/s².

    Returns
    -------
    current : float
        1 − max ``|i|``/I_max (negative: the amplifier cannot deliver the current).
    voltage : float
        1 − max ``|u|``/u_fs (negative: the amplifier cannot deliver the voltage).
    """
    expect_instance(vehicle, VehicleParams, "actuator_headroom", "vehicle")
    v = np.asarray(wheel_speed_m_s, dtype=np.float64)
    a = np.asarray(wheel_accel_m_s2, dtype=np.float64)
    u_fs, i_max = full_scale_voltage_v(vehicle), vehicle.amplifier.current_limit_a
    worst_i, worst_u = 0.0, 0.0
    for j, s in enumerate(_sides(vehicle)):
        omega = v[..., j] / s.r_over_n
        torque = s.j_tot * a[..., j] / s.r_over_n + s.tau_c * np.sign(omega) + s.f_m * omega
        current = torque / s.k_t
        voltage = s.resistance * current + s.k_e * omega
        worst_i = max(worst_i, float(np.max(np.abs(current), initial=0.0)) / i_max)
        worst_u = max(worst_u, float(np.max(np.abs(voltage), initial=0.0)) / u_fs)
    return 1.0 - worst_i, 1.0 - worst_u


def feedback_accel_m_s2(vehicle: VehicleParams, current_headroom: float = CURRENT_HEADROOM) -> float:
    """The rim acceleration the current a plan leaves to the feedback gives a wheel: eq 5's drive with
    ``current_headroom``·I_max (friction is already paid by the plan's share), the smaller of the two sides'.

    A plan at the acceleration a_p leaves the feedback this much more, a_p + this, up to eq 5's a_lim: for the
    default limits of :func:`feasible_wheel_limits` the two add up to a_lim (0.42 + 0.23 = 0.66 m/s² for the IAU AGV).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: each side's motor constants, gear ratio and wheel radius, its mass and the current limit I_max.
    current_headroom : float
        The fraction of I_max left to the feedback.

    Returns
    -------
    float
        The acceleration, m/s².

    Raises
    ------
    ConfigError
        ``feedback_accel_m_s2: <argument>: <problem>``: a vehicle that is not a :class:`VehicleParams`, or a
        headroom that is not a number in [0, 1).
    """
    expect_instance(vehicle, VehicleParams, "feedback_accel_m_s2", "vehicle")
    share = _check_headroom(current_headroom, "feedback_accel_m_s2", "current_headroom")
    i_max = vehicle.amplifier.current_limit_a
    return min(share * i_max * s.k_t / s.j_tot * s.r_over_n for s in _sides(vehicle))


def torque_accel_limit_m_s2(vehicle: VehicleParams) -> float:
    """The largest rim acceleration the motors' torque at the current limit gives either wheel in any manoeuvre,
    friction aside.

    The coupled dynamics of eqs 58-59 at rest, M ω̇ = k_t i with M = [[J_l + k_ll, k_lr], [k_lr, J_r + k_rr]]
    (eqs 47-49), are linear in the currents, so the largest rim acceleration r/N·ω̇ in magnitude over the currents
    within ±I_max lies at a corner: both wheels alike (eq 5's drive, less friction), one wheel alone, or the wheels
    opposed, which is the largest, since turning in place moves less inertia than driving straight. Only friction
    helping a wheel brake takes it further (by τ_c r/(J̃ N), eqs 60-61); a wheel past this bound over a whole sample is
    one slammed against the current limit in reverse, which tracking a planned path never needs.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its motors' inertias and torque constants, the coupling constants, the gear ratios and wheel
        radii, and the amplifier's current limit I_max.

    Returns
    -------
    float
        The bound, m/s².
    """
    expect_instance(vehicle, VehicleParams, "torque_accel_limit_m_s2", "vehicle")
    d, m = vehicle.derived, vehicle.motor
    mass = np.array([[m.left.inertia_kg_m2 + d.k_ll, d.k_lr], [d.k_lr, m.right.inertia_kg_m2 + d.k_rr]])
    torque = np.array([m.left.torque_constant_n_m_a, m.right.torque_constant_n_m_a]) * vehicle.amplifier.current_limit_a
    rim = np.array([vehicle.rim_per_motor_rad("left"), vehicle.rim_per_motor_rad("right")])
    corners = np.array([[1.0, 1.0], [1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    accel = np.linalg.solve(mass, (corners * torque).T).T * rim
    return float(np.max(np.abs(accel)))
