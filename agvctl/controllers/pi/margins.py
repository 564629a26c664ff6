"""The sampled PI wheel loop, per wheel, and its stability margins.

The loop, broken at the controller's input::

    L(z) = C(z) · k_chain · G_zoh(z)

* G_zoh(z): the decoupled model ω/u = (k_t/R)/(J̃ s + k_e k_t/R + f_m) (eqs 1, 60-61) sampled with a ZOH at
  T_s (``scipy.signal.cont2discrete``, which python-control's ``sample_system(..., "zoh")`` calls),
  K(1 − a)/(z − a) with a = exp(−T_s/τ_m);
* k_chain: the gain from the controller's output to the motor voltage. The controller outputs a motor
  voltage u_c, :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController` sends the DA the voltage u_c/k_pow,
  the DA outputs that voltage (code·α = u_c/k_pow up to half a step: gain 1 V/V, quantisation neglected) and
  the amplifier multiplies by k_pow: k_chain = k_pow · 1 · (1/k_pow) = 1;
* C(z) = k_p + k_i T_s z/(z − 1) (:class:`~agvctl.controllers.pi.options.PIGains`).

Margins are those of this sampled loop, computed from its frequency response L(e^{jωT_s}) on a dense grid
up to and including the Nyquist frequency ω = π/T_s (z = −1). For a PI on this first-order plant the phase
reaches −180° exactly at z = −1 (both C(−1) and G_zoh(−1) are real), which ``control.margin`` /
``control.stability_margins`` miss (they report an infinite gain margin); here that point is a phase crossing
like any other, and the gain margin there is −20 log10 ``|L(−1)|``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq
from scipy.signal import cont2discrete

from agvctl.actuator import Actuator
from agvctl.config import document_fields
from agvctl.controllers.pi.options import PIGains
from agvctl.params import VehicleParams
from agvctl.plant.decoupled import decoupled_wheel_coefficients, decoupled_wheel_models

if TYPE_CHECKING:
    import control

__all__ = [
    "GRID_POINTS",
    "LoopMargins",
    "chain_gain",
    "frequency_response",
    "loop_margins",
    "loop_polynomials",
    "open_loop_polynomials",
    "sampled_wheel_models",
    "sampled_wheel_polynomials",
    "tf_polynomials",
]

Polynomials = tuple[NDArray[np.float64], NDArray[np.float64]]
"""A transfer function's numerator and denominator, in descending powers of s or z."""

GRID_POINTS = 20_000
"""Frequency points (linear in ω, up to π/T_s inclusive) for the final margins."""


@document_fields
@dataclass(frozen=True)
class LoopMargins:
    """Stability margins of a sampled loop."""

    gain_margin_db: float
    """Smallest −20 log10 ``|L|`` over the phase crossings in (0, π/T_s] (``inf`` if none), dB."""
    phase_margin_deg: float
    """Smallest 180° + ∠L over the gain crossings (``inf`` if ``|L|`` never crosses 1), °."""
    crossover_rad_s: float
    """Gain crossover frequency (the lowest, if several; ``nan`` if none), rad/s."""
    phase_crossover_rad_s: float
    """Frequency where the gain margin is taken (π/T_s for the PI wheel loop; ``nan`` if none), rad/s."""


def chain_gain(vehicle: VehicleParams) -> float:
    """Gain from the controller's motor-voltage output to the motor voltage: (1/k_pow) · 1 · k_pow.

    The controller divides by k_pow to get the DA command; the DA's gain is code·α per requested volt = 1 V/V
    (up to quantisation); the amplifier multiplies by k_pow.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its amplifier's gain.

    Returns
    -------
    float
        k_chain, V/V (1 up to rounding).
    """
    k_pow = Actuator(vehicle).gain
    da_gain_v_v = 1.0  # v_DA = α · round(v/α) ≈ v
    return (1.0 / k_pow) * da_gain_v_v * k_pow


def sampled_wheel_models(vehicle: VehicleParams) -> tuple[control.TransferFunction, control.TransferFunction]:
    """The decoupled models (eqs 60-61) of the left and right wheel, sampled with a zero-order hold.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its equivalent inertias and damping, and its sample period.

    Returns
    -------
    tuple of control.TransferFunction
        (left, right), discrete at the sample period: motor voltage (V) to motor speed (rad/s).
    """
    import control

    ts = vehicle.control.sample_period_s
    models = decoupled_wheel_models(vehicle)
    return (
        control.sample_system(models.left, ts, method="zoh"),
        control.sample_system(models.right, ts, method="zoh"),
    )


def sampled_wheel_polynomials(vehicle: VehicleParams) -> tuple[Polynomials, Polynomials]:
    """The models of :func:`sampled_wheel_models` as polynomials, without python-control.

    Each side's model of eqs 60-61 (:func:`~agvctl.plant.decoupled.decoupled_wheel_coefficients`) sampled with a
    zero-order hold by ``scipy.signal.cont2discrete``, which python-control's ``sample_system`` calls: the same
    coefficients as :func:`tf_polynomials` of :func:`sampled_wheel_models`. The PI design and the wheel loops'
    time constant use these, so a run designs its wheel loops without importing python-control.

    Parameters
    ----------
    vehicle : VehicleParams
        As for :func:`sampled_wheel_models`.

    Returns
    -------
    tuple
        ``((num, den), (num, den))`` of the left and the right wheel, in descending powers of z: motor voltage (V)
        to motor speed (rad/s).
    """
    ts = vehicle.control.sample_period_s
    out = []
    for num, den in decoupled_wheel_coefficients(vehicle):
        num_z, den_z, _ = cont2discrete((num, den), ts, method="zoh")
        out.append(
            (
                np.trim_zeros(np.atleast_1d(np.asarray(num_z[0], dtype=float)), "f"),
                np.atleast_1d(np.asarray(den_z, dtype=float)),
            )
        )
    return out[0], out[1]


def tf_polynomials(tf: control.TransferFunction) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The numerator and denominator of a single-input, single-output transfer function.

    Parameters
    ----------
    tf : control.TransferFunction
        The transfer function.

    Returns
    -------
    num, den : ndarray
        Their coefficients, in descending powers of s or z.
    """
    import control

    num, den = control.tfdata(tf)
    return np.atleast_1d(np.asarray(num[0][0], dtype=float)), np.atleast_1d(np.asarray(den[0][0], dtype=float))


def loop_polynomials(
    gains: PIGains, plant_z: control.TransferFunction, chain: float = 1.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The numerator and denominator of the open wheel loop L(z) = C(z) · chain · G(z).

    Parameters
    ----------
    gains : PIGains
        The PI's gains, C(z).
    plant_z : control.TransferFunction
        The sampled wheel model G(z), motor voltage (V) to motor speed (rad/s).
    chain : float
        The chain gain k_chain (:func:`chain_gain`), V/V.

    Returns
    -------
    num, den : ndarray
        Their coefficients, in descending powers of z.
    """
    return open_loop_polynomials(gains, tf_polynomials(plant_z), chain)


def open_loop_polynomials(gains: PIGains, plant: Polynomials, chain: float = 1.0) -> Polynomials:
    """:func:`loop_polynomials` of a plant given as its polynomials.

    Parameters
    ----------
    gains : PIGains
        The PI's gains, C(z).
    plant : tuple of ndarray
        G(z)'s numerator and denominator, in descending powers of z (:func:`sampled_wheel_polynomials`).
    chain : float
        The chain gain k_chain (:func:`chain_gain`), V/V.

    Returns
    -------
    num, den : ndarray
        L(z)'s coefficients, in descending powers of z.
    """
    g_num, g_den = plant
    num = np.asarray(chain * np.polymul(gains.num, g_num), dtype=np.float64)
    return num, np.asarray(np.polymul(gains.den, g_den), dtype=np.float64)


def frequency_response(
    num: NDArray[np.float64], den: NDArray[np.float64], dt_s: float, omega_rad_s: NDArray[np.float64]
) -> NDArray[np.complex128]:
    """The frequency response L(e^{jωT}) of a discrete transfer function.

    Parameters
    ----------
    num, den : ndarray
        Its numerator and denominator, in descending powers of z.
    dt_s : float
        Its sample period T, s.
    omega_rad_s : ndarray
        The frequencies, rad/s.

    Returns
    -------
    ndarray of complex
        L at each frequency.
    """
    z = np.exp(1j * np.asarray(omega_rad_s, dtype=float) * dt_s)
    return np.asarray(np.polyval(num, z) / np.polyval(den, z), dtype=np.complex128)


def loop_margins(
    num: NDArray[np.float64], den: NDArray[np.float64], dt_s: float, *, grid_points: int = GRID_POINTS
) -> LoopMargins:
    """Gain and phase margins of a discrete loop from its frequency response on (0, π/T_s].

    The grid is linear in ω and includes the Nyquist frequency itself; crossings are refined with Brent's
    method. A phase crossing is a zero of Im L with Re L < 0, including ω = π/T_s where Im L = 0 identically.

    Parameters
    ----------
    num, den : ndarray
        The open loop's numerator and denominator, in descending powers of z (:func:`loop_polynomials`).
    dt_s : float
        Its sample period T_s, s.
    grid_points : int
        Frequency points of the grid.

    Returns
    -------
    LoopMargins
        The smallest gain and phase margins and where they are taken.
    """
    w_nyq = math.pi / dt_s
    w = np.linspace(0.0, w_nyq, grid_points + 1)[1:]
    resp = frequency_response(num, den, dt_s, w)

    def at(omega: float) -> complex:
        return complex(frequency_response(num, den, dt_s, np.array([omega]))[0])

    phase = np.unwrap(np.angle(resp))
    # gain crossings: ``|L|`` = 1
    mag_log = np.log(np.abs(resp))
    pms, wcs = [], []
    for i in np.nonzero(np.signbit(mag_log[:-1]) != np.signbit(mag_log[1:]))[0]:
        wc = brentq(lambda om: math.log(abs(at(om))), w[i], w[i + 1], xtol=1e-12)
        ph = math.atan2(at(wc).imag, at(wc).real)
        ph += 2 * math.pi * round((phase[i] - ph) / (2 * math.pi))  # same branch as the unwrapped grid phase
        pms.append(180.0 + math.degrees(ph))
        wcs.append(wc)
    # phase crossings: Im L = 0 with Re L < 0, and z = -1 itself
    gms, wps = [], []
    im = resp.imag
    for i in np.nonzero(np.sign(im[:-1]) * np.sign(im[1:]) < 0)[0]:
        wp = brentq(lambda om: at(om).imag, w[i], w[i + 1], xtol=1e-12)
        if at(wp).real < 0:
            gms.append(-20.0 * math.log10(abs(at(wp))))
            wps.append(wp)
    l_nyq = at(w_nyq)
    if l_nyq.real < 0:
        gms.append(-20.0 * math.log10(abs(l_nyq)))
        wps.append(w_nyq)
    i_gm = int(np.argmin(gms)) if gms else -1
    return LoopMargins(
        gain_margin_db=gms[i_gm] if gms else math.inf,
        phase_margin_deg=min(pms) if pms else math.inf,
        crossover_rad_s=min(wcs) if wcs else math.nan,
        phase_crossover_rad_s=wps[i_gm] if gms else math.nan,
    )
