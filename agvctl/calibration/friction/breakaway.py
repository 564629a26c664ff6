"""Break-away detection in the friction log's slow DA ramps (eq 65, corrected as in the docs' model notes)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from agvctl.calibration.friction.log import FrictionLog
from agvctl.config import document_fields

__all__ = ["Breakaway", "breakaways", "onset_time_s"]


@document_fields
@dataclass(frozen=True)
class Breakaway:
    """One ramp's break-away, in DA volts."""

    u_still_v: float
    """``|u|`` held over the last sample at whose start the wheel was still (it broke the wheel away), V."""
    resolution_v: float
    """The larger of the ramp's step per sample and one DA code, V."""
    lag_bound_v: float
    """How much later than the break-away the noise let the wheel be seen moving, at most (0 without noise), V."""


def onset_time_s(speed_rad_s: float, accel_gain: float, tau_s: float) -> float:
    """Time after a break-away at which a ramp-driven wheel reaches a speed when τ_s = τ_c (the slowest onset).

    Linear sliding dynamics: ω(t) = g (t − τ (1 − e^(−t/τ))). The root is bracketed by doubling from 1 s and
    found by Brent's method.

    Parameters
    ----------
    speed_rad_s : float
        The motor speed, rad/s.
    accel_gain : float
        g, the speed the ramp adds per second once the wheel slides, in the steady state, rad/s².
    tau_s : float
        τ, the sliding dynamics' time constant J̃/(k_e k_t/R + f_m), s.

    Returns
    -------
    float
        The time, s: 0 for a speed ≤ 0, 10⁴ s if the speed is still not reached then.

    Examples
    --------
    >>> round(onset_time_s(1.0, 10.0, 0.1), 4)  # 0.1 s at 10 rad/s², and the lag of τ = 0.1 s
    0.1841
    """
    if speed_rad_s <= 0:
        return 0.0

    def excess(t: float) -> float:
        return accel_gain * (t - tau_s * (1.0 - math.exp(-t / tau_s))) - speed_rad_s

    hi = 1.0
    while excess(hi) < 0 and hi < 1e4:
        hi *= 2.0
    if excess(hi) < 0:
        return hi
    return float(brentq(excess, 0.0, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps))


def breakaways(
    log: FrictionLog,
    side: int,
    *,
    threshold_rad_s: float,
    volts_per_code: float,
    torque_per_da_v: float,
    damping_n_m_s_rad: float,
    inertia_kg_m2: float,
    smooth: int = 5,
) -> list[Breakaway]:
    """The break-aways of one side, one per ramp block that drives it and sees the wheel move.

    σ, the speed noise, is the RMS speed over the block's samples below half its peak voltage (the wheel surely
    sticks there). Without noise the wheel is moving at the first sample with a speed beyond ``threshold`` in the
    ramp's direction, and was still at the last sample with speed exactly 0 before it. With noise the speed is
    first averaged over ``smooth`` samples (trailing), "moving" means beyond max(threshold, 4σ/√smooth) and
    "still" within 2σ/√smooth; the wheel may then have started up to the time its speed needs to reach that band
    (from linear sliding dynamics with J̃ and the damping k_e k_t/R + f_m, the slowest case τ_s = τ_c) plus the
    averaging delay earlier: the lag bound.

    Parameters
    ----------
    log : FrictionLog
        The friction experiment's log.
    side : int
        0 (left) or 1 (right).
    threshold_rad_s : float
        The motor speed beyond which the wheel counts as moving without noise, rad/s.
    volts_per_code : float
        One DA code, V.
    torque_per_da_v : float
        Motor torque per DA volt, k_pow k_t/R, in N m per V.
    damping_n_m_s_rad : float
        The side's damping k_e k_t/R + f_m, N m s/rad.
    inertia_kg_m2 : float
        The side's equivalent inertia J̃, kg m².
    smooth : int
        Samples the speed is averaged over when it is noisy.

    Returns
    -------
    list of Breakaway
        One per ramp block that drives the side and sees its wheel move.
    """
    n = len(log.t_s)
    found: list[Breakaway] = []
    i = 0
    while i < n:
        if log.phase[i] != "ramp":
            i += 1
            continue
        j = i
        while j < n and log.phase[j] == "ramp":
            j += 1
        block = (log.t_s[i:j], log.da_voltage_v[i:j, side], log.omega_motor_rad_s[i:j, side])
        i = j
        drive = (torque_per_da_v, damping_n_m_s_rad, inertia_kg_m2)
        one = _breakaway(*block, threshold_rad_s, volts_per_code, drive, smooth)
        if one is not None:
            found.append(one)
    return found


def _breakaway(
    t: np.ndarray,
    u: np.ndarray,
    w: np.ndarray,
    threshold_rad_s: float,
    volts_per_code: float,
    drive: tuple[float, float, float],
    smooth: int,
) -> Breakaway | None:
    """One ramp block's break-away (:func:`breakaways`; ``drive``: its torque per DA volt, damping and inertia);
    None if the block ramps the other side or its wheel never moves."""
    u_peak = float(np.max(np.abs(u)))
    if u_peak <= 0.0 or len(u) < 2:
        return None  # this block ramps the other side
    sign = 1.0 if float(np.max(u)) >= -float(np.min(u)) else -1.0
    quiet = np.abs(u) <= 0.5 * u_peak
    sigma = float(np.sqrt(np.mean(w[quiet] ** 2))) if np.count_nonzero(quiet) >= 5 else 0.0
    m = max(1, min(smooth, len(w))) if sigma > 0 else 1
    w_s = np.convolve(w, np.ones(m) / m, mode="valid")  # w_s[k - m + 1] = mean of w[k - m + 1 .. k]
    moving = np.nonzero(sign * w_s > max(threshold_rad_s, 4.0 * sigma / math.sqrt(m)))[0]
    if moving.size == 0:
        return None
    k = int(moving[0])
    still = 2.0 * sigma / math.sqrt(m) if sigma > 0 else 0.0
    while k > 0 and sign * float(w_s[k]) > still:
        k -= 1
    k_still = k + m - 1  # the last sample of the averaging window
    duration = float(t[k_still] - t[0]) if k_still > 0 else 0.0
    rate_v_s = abs(float(u[k_still]) - float(u[0])) / duration if duration > 0 else 0.0
    ts = float(t[1] - t[0])
    lag_v = 0.0
    if sigma > 0:
        torque_per_da_v, damping_n_m_s_rad, inertia_kg_m2 = drive
        accel_gain = torque_per_da_v * rate_v_s / damping_n_m_s_rad
        onset = onset_time_s(still, accel_gain, inertia_kg_m2 / damping_n_m_s_rad)
        lag_v = rate_v_s * (onset + 0.5 * (m - 1) * ts)
    return Breakaway(abs(float(u[k_still])), max(rate_v_s * ts, volts_per_code), lag_v)
