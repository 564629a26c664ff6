"""The pre-velocity friction model of the report's Fig. 3 (eqs 2-4), for numbers and CasADi symbols alike.

The integrator state is the pre-velocity ω̃. The motor speed is a dead zone of it (eq 2 as corrected in
model note 1, docs/model-notes.md), and the friction torque acting on the shaft is τ₁ − τ₂ (eqs 3-4):

* sticking, |ω̃| ≤ τ_s/P: ω_mot = 0 and the friction is P ω̃, a stiff spring that holds any drive torque below
  the break-away torque τ_s;
* sliding: the friction falls from τ_s at ω_mot = 0 to τ_c at |ω_mot| = (τ_s − τ_c)/P and stays there.

The friction is a continuous, piecewise-linear function of ω̃, which is what makes a fixed-step integrator
accurate on it.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

__all__ = ["friction_torque", "motor_speed"]

Num = Any
_SYMBOLIC = (ca.SX, ca.MX, ca.DM)


def _clip(x: Num, limit: Num) -> Num:
    if isinstance(x, _SYMBOLIC) or isinstance(limit, _SYMBOLIC):
        return ca.fmin(ca.fmax(x, -limit), limit)
    if isinstance(x, float) and isinstance(limit, float):  # plain floats: the same value, without numpy's call
        return min(max(x, -limit), limit)
    return np.clip(x, -limit, limit)  # numbers and numpy arrays: the same values, without CasADi's conversions


def motor_speed(omega_pre: Num, tau_s: Num, P: Num) -> Num:
    """The motor speed ω_mot from the pre-velocity ω̃: eq 2, corrected to a dead zone of half-width τ_s/P.

    Parameters
    ----------
    omega_pre : float, ndarray or CasADi symbol
        The pre-velocity ω̃, rad/s.
    tau_s : float, ndarray or CasADi symbol
        The stiction (break-away) torque τ_s, N m.
    P : float, ndarray or CasADi symbol
        The friction model's gain P, N m s/rad (eq 62).

    Returns
    -------
    float, ndarray or CasADi symbol
        ω_mot, rad/s: 0 within the dead zone, ω̃ ∓ τ_s/P outside it.

    Examples
    --------
    >>> motor_speed(0.005, 0.1, 10.0), motor_speed(0.5, 0.1, 10.0)
    (0.0, 0.49)
    """
    return omega_pre - _clip(omega_pre, tau_s / P)  # eq 2: ω̃ ∓ τ_s/P outside the zone, 0 inside


def friction_torque(omega_pre: Num, omega_mot: Num, tau_s: Num, tau_c: Num, P: Num) -> Num:
    """The friction torque opposing the motor, τ₁ − τ₂ (eqs 3-4).

    Parameters
    ----------
    omega_pre : float, ndarray or CasADi symbol
        The pre-velocity ω̃, rad/s.
    omega_mot : float, ndarray or CasADi symbol
        The motor speed ω_mot = :func:`motor_speed` of ``omega_pre``, rad/s.
    tau_s : float, ndarray or CasADi symbol
        The stiction (break-away) torque τ_s, N m.
    tau_c : float, ndarray or CasADi symbol
        The Coulomb friction torque τ_c, N m.
    P : float, ndarray or CasADi symbol
        The friction model's gain P, N m s/rad (eq 62).

    Returns
    -------
    float, ndarray or CasADi symbol
        The friction torque, N m: P ω̃ while sticking, falling from τ_s to τ_c as the motor speeds up.
    """
    tau_1 = _clip(P * omega_pre, tau_s)  # eq 3: ±τ_s while sliding, P ω̃ while sticking (|P ω̃| ≤ τ_s there)
    tau_2 = _clip(P * omega_mot, tau_s - tau_c)  # eq 4: ±(τ_s − τ_c) beyond the band, P ω_mot inside it
    return tau_1 - tau_2
