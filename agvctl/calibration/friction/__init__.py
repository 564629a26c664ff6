"""Friction identification, the report's appendix A.1 (eqs 65-69, corrected as in the docs' model notes).

Two experiments per side, on the vehicle's own speed loops and DA converter:

1. **Constant speeds.** The PI loops hold both motors at N constant speeds (forward and reverse). In a steady
   window the armature balance (eq 1, inductance neglected) with the friction of eqs 2-4 in sliding reads, per
   side and on average over the window,

       k_pow k_t ū / R − k_e k_t ω̄ / R = f_m ω̄ + τ_c sign(ω̄)                  (steady state, model notes)

   with u the DA voltage (the control input of eqs 65-69, which the amplifier multiplies by k_pow). The left side
   is known from the log and the motor constants; least squares over the windows gives f_m and τ_c. With two
   speeds in one direction this is the report's two-speed formula, eqs 66-67 (68-69 for the right side), as
   corrected in the docs' model notes: ``τ_c = k_pow k_t u₂/R − (k_e k_t/R + f_m) ω₂``
   (:func:`two_speed_friction`).
2. **Slow voltage ramp.** From standstill the DA voltage of one side rises slowly until the wheel turns. While it
   sticks the motor does not move, so the drive torque is k_pow k_t u/R (eq 65 as corrected: the amplifier gain
   multiplies, and the measured torque is the break-away torque τ_s itself, not τ_c + τ_s).

The log format is :data:`FRICTION_LOG_COLUMNS`; :func:`simulate_friction_experiment` produces one on the
simulator, :func:`read_friction_log` reads a user's, :func:`fit_friction` fits either.

* :mod:`~agvctl.calibration.friction.log`: the log (:class:`FrictionLog`), its columns, reading and writing;
* :mod:`~agvctl.calibration.friction.experiment`: the simulated experiment;
* :mod:`~agvctl.calibration.friction.fit`: the fit (least squares, two-speed formula, applying the result);
* :mod:`~agvctl.calibration.friction.breakaway`: finding the break-aways in the ramps.
"""

from agvctl.calibration.friction.experiment import SPEED_NOISE_RAD_S, FrictionExperiment, simulate_friction_experiment
from agvctl.calibration.friction.fit import (
    FrictionFit,
    HoldWindow,
    SideFriction,
    apply_friction,
    fit_friction,
    two_speed_friction,
)
from agvctl.calibration.friction.log import FRICTION_LOG_COLUMNS, SIDES, FrictionLog, Side, read_friction_log

__all__ = [
    "FRICTION_LOG_COLUMNS",
    "SIDES",
    "SPEED_NOISE_RAD_S",
    "FrictionExperiment",
    "FrictionFit",
    "FrictionLog",
    "HoldWindow",
    "Side",
    "SideFriction",
    "apply_friction",
    "fit_friction",
    "read_friction_log",
    "simulate_friction_experiment",
    "two_speed_friction",
]
