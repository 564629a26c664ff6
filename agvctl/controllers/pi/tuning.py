"""PI wheel-speed loop design from the decoupled model (eqs 60-61), sampled with a zero-order hold.

The loop and its margins are those of :mod:`agvctl.controllers.pi.margins`: L(z) = C(z) · k_chain · G_zoh(z), the
decoupled model sampled with a zero-order hold, the margins taken up to and including the Nyquist frequency.

Design ("as fast as the margins allow"): for a crossover ω_c, the PI that gives exactly the required phase
margin there is unique (solve C(e^{jω_c T}) = e^{j(PM − 180°)} / (k_chain G(e^{jω_c T})) for k_p, k_i). For
a fixed ω_c it also has the best gain margin of all PIs with that crossover and at least that phase margin
(more phase lead means a larger C(−1) = k_p + k_i T_s/2), and its gain margin falls as ω_c rises. So the
fastest design is the largest ω_c at which that PI has k_i > 0 and meets the gain margin: found by a scan
and Brent's method (``scipy.optimize.brentq``). With a crossover demand, the PI with the required phase
margin at that ω_c is checked against the gain margin.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from scipy.optimize import brentq
from scipy.signal import dstep

from agvctl.config import check_fields, document_fields
from agvctl.controllers.pi.margins import (
    GRID_POINTS,
    LoopMargins,
    Polynomials,
    chain_gain,
    frequency_response,
    loop_margins,
    loop_polynomials,
    open_loop_polynomials,
    sampled_wheel_models,
    sampled_wheel_polynomials,
)
from agvctl.controllers.pi.options import PIGains
from agvctl.errors import ConfigError, expect_instance
from agvctl.params import VehicleParams

if TYPE_CHECKING:
    import control

__all__ = [  # the loop's analysis is agvctl.controllers.pi.margins's, and still importable from here
    "LoopMargins",
    "TuningResult",
    "TuningSpec",
    "chain_gain",
    "design_pi",
    "frequency_response",
    "loop_margins",
    "loop_polynomials",
    "sampled_wheel_models",
]

_SEARCH_GRID_POINTS = 2_000
_PM_DESIGN_EXTRA_DEG = 1e-4
"""Designed phase margin above the spec, so the achieved margin is >= the spec despite rounding."""
_CROSSOVER_XTOL_RAD_S, _CROSSOVER_RTOL = 1e-13, 4 * float(np.finfo(float).eps)
"""Brent's method tolerances for the fastest feasible crossover (the smallest relative tolerance it accepts)."""
SPEC_SOURCE = "tuning specification"


@document_fields
@dataclass(frozen=True)
class TuningSpec:
    """What the wheel loops must achieve (``agvctl tune --pm --gm --crossover``).

    Raises
    ------
    ConfigError
        A phase margin outside (0°, 180°), a negative gain margin, or a crossover that is not a positive number.
    """

    phase_margin_deg: float = 60.0
    """Minimum phase margin, °."""
    gain_margin_db: float = 10.0
    """Minimum gain margin (taken up to and including the Nyquist frequency), dB."""
    crossover_rad_s: float | None = None
    """Demanded gain crossover (bandwidth); ``None``: as fast as the margins allow, rad/s."""

    def __post_init__(self) -> None:
        check_fields(self)
        pm, gm, wc = self.phase_margin_deg, self.gain_margin_db, self.crossover_rad_s
        if not (math.isfinite(pm) and 0.0 < pm < 180.0):
            raise ConfigError(SPEC_SOURCE, "phase_margin_deg", f"must be between 0 and 180 degrees (got {pm:g})")
        if not (math.isfinite(gm) and gm >= 0.0):
            raise ConfigError(SPEC_SOURCE, "gain_margin_db", f"must be a finite number >= 0 dB (got {gm:g})")
        if wc is not None and not (math.isfinite(wc) and wc > 0.0):
            raise ConfigError(SPEC_SOURCE, "crossover_rad_s", f"must be a positive number of rad/s (got {wc:g})")


@document_fields
@dataclass(frozen=True)
class TuningResult:
    """A PI design and its verification on the sampled linear loops of both wheels."""

    gains: PIGains
    """The designed gains, one set for both wheels."""
    margins: LoopMargins
    """The worse of the two wheels' margins (smallest GM, PM and crossover)."""
    margins_left: LoopMargins
    """The left wheel loop's margins."""
    margins_right: LoopMargins
    """The right wheel loop's margins."""
    spec: TuningSpec
    """What the design was asked for."""
    chain_gain: float
    """Controller output to motor voltage (:func:`~agvctl.controllers.pi.margins.chain_gain`), V/V."""
    plant_left: control.TransferFunction = field(repr=False)
    """ZOH-sampled decoupled model of the left wheel, motor voltage (V) → motor speed (rad/s)."""
    plant_right: control.TransferFunction = field(repr=False)
    """The same of the right wheel."""
    max_crossover_rad_s: float = math.nan
    """The fastest crossover the margins allow (what the design picks when no crossover is demanded), rad/s."""

    def loop(self, side: str = "left") -> control.TransferFunction:
        """The open loop L(z) = C(z) k_chain G_zoh(z) of one wheel as a python-control transfer function."""
        import control

        num, den = loop_polynomials(
            self.gains, self.plant_left if side == "left" else self.plant_right, self.chain_gain
        )
        return control.tf(num, den, self.gains.dt_s)


def _pi_for_crossover(
    plant_z: Polynomials,
    chain: float,
    crossover_rad_s: float,
    phase_margin_deg: float,
    dt_s: float,
) -> PIGains | None:
    """The PI with |L| = 1 and phase margin ``phase_margin_deg`` at ``crossover_rad_s``; None if that needs
    k_i <= 0 (a PI cannot provide the phase lead). Where it would need k_p < 0, the pure integrator (k_p =
    0) instead."""
    theta = crossover_rad_s * dt_s
    g_num, g_den = plant_z
    g = chain * complex(frequency_response(g_num, g_den, dt_s, np.array([crossover_rad_s]))[0])
    c = np.exp(1j * math.radians(phase_margin_deg - 180.0)) / g
    # C(e^{jθ}) = k_p + k_i T (1/2 − j/2 · cot(θ/2)), since z/(z − 1) = 1/(1 − e^{−jθ})
    ki_t = -2.0 * c.imag * math.tan(theta / 2.0)
    kp = c.real - ki_t / 2.0
    if not ki_t > 0.0:
        return None
    if kp < 0.0:
        # the plant lags too little here for this margin even with a pure integrator: use k_p = 0, which gives
        # more phase margin than asked, with |L| = 1 at the crossover
        z = complex(np.exp(1j * theta))
        kp, ki_t = 0.0, 1.0 / abs(g * z / (z - 1.0))
    return PIGains(kp=float(kp), ki=float(ki_t / dt_s), dt_s=float(dt_s))


def _worst(a: LoopMargins, b: LoopMargins) -> LoopMargins:
    ga, gb = (a, b) if a.gain_margin_db <= b.gain_margin_db else (b, a)
    return LoopMargins(
        gain_margin_db=ga.gain_margin_db,
        phase_margin_deg=min(a.phase_margin_deg, b.phase_margin_deg),
        crossover_rad_s=float(np.fmin(a.crossover_rad_s, b.crossover_rad_s)),
        phase_crossover_rad_s=ga.phase_crossover_rad_s,
    )


def _spec_excess(
    plants: tuple[Polynomials, ...],
    chain: float,
    crossover_rad_s: float,
    pm_design_deg: float,
    dt_s: float,
    spec: TuningSpec,
) -> float:
    """> 0 where a PI with crossover ``crossover_rad_s`` meets ``spec`` on both wheels: for the better of the
    sides' designs, its smallest GM − spec (dB) and PM − spec (deg) over the wheels; −1 where no design has
    k_i > 0."""
    best = -1.0
    for plant in plants:
        gains = _pi_for_crossover(plant, chain, crossover_rad_s, pm_design_deg, dt_s)
        if gains is not None:
            m = [
                loop_margins(*open_loop_polynomials(gains, p, chain), dt_s, grid_points=_SEARCH_GRID_POINTS)
                for p in plants
            ]
            best = max(
                best,
                min(min(x.gain_margin_db - spec.gain_margin_db, x.phase_margin_deg - spec.phase_margin_deg) for x in m),
            )
    return best


_Candidate = tuple[PIGains, LoopMargins, LoopMargins]


def _candidate(
    plants: tuple[Polynomials, ...],
    chain: float,
    wc: float,
    pm_design: float,
    ts: float,
    spec: TuningSpec,
    grid: int,
) -> _Candidate | None:
    """A PI with crossover ``wc`` meeting ``spec`` on both wheels' models (the fastest worst-side crossover of the
    designs on each side), or None."""
    best = None
    for plant in plants:  # design on each side's model, keep one that suits both
        gains = _pi_for_crossover(plant, chain, wc, pm_design, ts)
        if gains is None:
            continue
        m = [loop_margins(*open_loop_polynomials(gains, p, chain), ts, grid_points=grid) for p in plants]
        meets = all(x.phase_margin_deg >= spec.phase_margin_deg and x.gain_margin_db >= spec.gain_margin_db for x in m)
        if meets and (best is None or min(x.crossover_rad_s for x in m) > min(x.crossover_rad_s for x in best[1:])):
            best = (gains, m[0], m[1])
    return best


def _fastest_crossover(
    plants: tuple[Polynomials, ...], chain: float, pm_design: float, ts: float, spec: TuningSpec
) -> float:
    """The fastest crossover at which a PI meets ``spec`` on both wheels: a log-spaced scan down from the Nyquist
    frequency to the first feasible point, then Brent's method between it and the next. Raises
    :class:`ConfigError` when none does."""
    w_nyq = math.pi / ts
    scan = np.geomspace(w_nyq * 1e-4, w_nyq * (1 - 1e-6), 160)
    feasible = (
        i
        for i in reversed(range(len(scan)))
        if _candidate(plants, chain, float(scan[i]), pm_design, ts, spec, _SEARCH_GRID_POINTS) is not None
    )
    last = next(feasible, None)
    if last is None:
        raise ConfigError(
            SPEC_SOURCE,
            "phase_margin_deg",
            f"no PI gives phase margin >= {spec.phase_margin_deg:g} deg and gain margin >= "
            f"{spec.gain_margin_db:g} dB on this vehicle's wheel loop at any crossover up to Nyquist "
            f"({w_nyq:.4g} rad/s)",
        )

    def excess(wc: float) -> float:
        return _spec_excess(plants, chain, wc, pm_design, ts, spec)

    lo = float(scan[last])
    hi = float(scan[last + 1]) if last + 1 < len(scan) else w_nyq
    if not excess(hi) < 0:  # feasible (or undefined) up to the Nyquist frequency: the last scanned point
        return lo
    max_wc = float(brentq(excess, lo, hi, xtol=_CROSSOVER_XTOL_RAD_S, rtol=_CROSSOVER_RTOL))
    if excess(max_wc) < 0:  # Brent's answer lies within its tolerance of the boundary: take the feasible side
        max_wc -= 2.0 * (_CROSSOVER_XTOL_RAD_S + _CROSSOVER_RTOL * max_wc)
    return max_wc


def design_pi(vehicle: VehicleParams, spec: TuningSpec | None = None) -> TuningResult:
    """Design the wheel-speed PI for ``spec`` (default: PM >= 60°, GM >= 10 dB, fastest crossover).

    One gain set serves both wheels; it must meet the spec on each side's model.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its decoupled per-wheel models (eqs 60-61), sampled with a zero-order hold at
        its sample period, and its actuator chain.
    spec : TuningSpec or None
        The margins (degrees, dB) and optionally a demanded crossover (rad/s); None: the defaults.

    Returns
    -------
    TuningResult
        The gains, the margins of each wheel's sampled loop and of the worse of the two, and the sampled plants.

    Raises
    ------
    ConfigError
        One line, when no PI meets the spec.

    Examples
    --------
    >>> from agvctl.params import load_vehicle
    >>> result = design_pi(load_vehicle(), TuningSpec(phase_margin_deg=60.0, gain_margin_db=10.0))
    >>> m = result.margins
    >>> print(f"PM {m.phase_margin_deg:.1f}°, GM {m.gain_margin_db:.1f} dB, crossover {m.crossover_rad_s:.1f} rad/s")
    PM 60.0°, GM 10.0 dB, crossover 17.4 rad/s
    """
    expect_instance(vehicle, VehicleParams, "design_pi", "vehicle")
    spec = TuningSpec() if spec is None else spec
    expect_instance(spec, TuningSpec, "design_pi", "spec")
    (gains, m_left, m_right), max_wc = _design(vehicle, spec)
    plants = sampled_wheel_models(vehicle)
    return TuningResult(
        gains=gains,
        margins=_worst(m_left, m_right),
        margins_left=m_left,
        margins_right=m_right,
        spec=spec,
        chain_gain=chain_gain(vehicle),
        plant_left=plants[0],
        plant_right=plants[1],
        max_crossover_rad_s=max_wc,
    )


def _design(vehicle: VehicleParams, spec: TuningSpec) -> tuple[_Candidate, float]:
    """:func:`design_pi`'s gains and margins, and the fastest crossover the margins allow (rad/s), on the
    sampled models' polynomials (no python-control)."""
    ts = vehicle.control.sample_period_s
    plants = sampled_wheel_polynomials(vehicle)
    chain = chain_gain(vehicle)
    w_nyq = math.pi / ts
    pm_design = spec.phase_margin_deg + _PM_DESIGN_EXTRA_DEG
    max_wc = _fastest_crossover(plants, chain, pm_design, ts, spec)

    if spec.crossover_rad_s is None:
        wc_target = max_wc
    else:
        wc_target = spec.crossover_rad_s
        if wc_target >= w_nyq:
            problem = f"{wc_target:g} rad/s is at or above the Nyquist frequency pi/T_s = {w_nyq:.4g} rad/s"
            raise ConfigError(SPEC_SOURCE, "crossover_rad_s", problem)
    found = _candidate(plants, chain, wc_target, pm_design, ts, spec, GRID_POINTS)
    if found is None and spec.crossover_rad_s is None:  # rounding at the boundary: back off slightly
        for shrink in (1 - 1e-6, 1 - 1e-4, 1 - 1e-2):
            found = _candidate(plants, chain, wc_target * shrink, pm_design, ts, spec, GRID_POINTS)
            if found is not None:
                break
    if found is None:
        raise ConfigError(
            SPEC_SOURCE,
            "crossover_rad_s",
            f"no PI has crossover {wc_target:g} rad/s with phase margin >= {spec.phase_margin_deg:g} deg and "
            f"gain margin >= {spec.gain_margin_db:g} dB; with these margins the crossover can be at most "
            f"{max_wc:.4g} rad/s",
        )
    return found, max_wc


def closed_loop_time_constant_s(vehicle: VehicleParams, gains: PIGains, horizon_s: float = 0.6) -> float:
    """τ of the first-order lag that best fits (least squares) the step response of the closed wheel loops.

    The MPC's ``kinematic+wheel_loop`` prediction model treats each wheel's closed PI loop as such a lag; this
    is its value for ``gains`` on the sampled linear model (ZOH plant of eqs 60-61, PI, chain gain), the slower
    side. 0.031 s for the default design (whose closed loop reaches 68 % of a step in one 40 ms sample).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.
    gains : PIGains
        The PI's gains.
    horizon_s : float
        How much of the step response the fit covers, s.

    Returns
    -------
    float
        τ of the slower wheel, s.
    """
    ts = gains.dt_s
    n = max(3, int(round(horizon_s / ts)))
    k = np.arange(n)
    chain = chain_gain(vehicle)
    taus = []
    for plant in sampled_wheel_polynomials(vehicle):
        num, den = open_loop_polynomials(gains, plant, chain)
        # the closed loop L/(1 + L) under unit feedback, and its step response from rest
        _, (y,) = dstep((num, np.polyadd(den, num), ts), n=n)
        y = np.asarray(y, dtype=float).ravel()
        poles = np.linspace(1e-3, 0.999, 999)  # a = exp(-T/τ); a first-order step response is 1 − a^k
        errors = [float(np.sum((y - (1.0 - a**k)) ** 2)) for a in poles]
        a_best = float(poles[int(np.argmin(errors))])
        taus.append(-ts / math.log(a_best))
    return max(taus)


class WheelLoopDesign(NamedTuple):
    """The PI gains and the first-order lag τ (s) that best fits their closed loop."""

    gains: PIGains
    loop_time_constant_s: float


@functools.lru_cache(maxsize=32)
def default_pi_gains(vehicle: VehicleParams) -> WheelLoopDesign:
    """The PI designed for the default spec (PM ≥ 60°, GM ≥ 10 dB, fastest) and its closed loop's time constant.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.

    Returns
    -------
    WheelLoopDesign
        The gains and the time constant (s) of the first-order lag that best fits their closed loop (the MPC's
        wheel-loop model); cached per vehicle.
    """
    expect_instance(vehicle, VehicleParams, "default_pi_gains", "vehicle")
    (gains, _, _), _ = _design(vehicle, TuningSpec())
    return WheelLoopDesign(gains, closed_loop_time_constant_s(vehicle, gains))
