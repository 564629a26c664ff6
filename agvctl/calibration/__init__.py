"""Calibration and identification: the report's appendix A.1 procedures, run as experiments.

* :mod:`~agvctl.calibration.mass`: total mass and centre of mass from three scale readings (eq 63), moment of
  inertia from the frame and battery dimensions (eq 64).
* :mod:`~agvctl.calibration.friction`: viscous and Coulomb friction per side by least squares over
  constant-speed runs on the PI speed loops (eqs 66-69 as corrected in the docs' model notes), stiction
  from a slow voltage ramp (eq 65 corrected).
* :mod:`~agvctl.calibration.umbmark`: wheel-radius ratio and wheel base from Borenstein & Feng's UMBmark.

Each works on a user's measurements (scale readings, a CSV log) or runs the experiment on the simulator, the
plant holding the truth and the controllers only the believed vehicle. Estimates are :class:`Estimate` values
with a standard error; the ``apply_*`` functions (and :meth:`UmbmarkCorrection.apply`) return the vehicle with
the identified values, ready to be written as a vehicle TOML.
"""

from agvctl.calibration.common import Estimate
from agvctl.calibration.friction import (
    FRICTION_LOG_COLUMNS,
    FrictionExperiment,
    FrictionFit,
    FrictionLog,
    SideFriction,
    apply_friction,
    fit_friction,
    read_friction_log,
    simulate_friction_experiment,
    two_speed_friction,
)
from agvctl.calibration.mass import MassFit, apply_mass, identify_mass, simulated_scale_readings
from agvctl.calibration.umbmark import (
    UMBMARK_LOG_COLUMNS,
    UmbmarkConfig,
    UmbmarkCorrection,
    UmbmarkResult,
    drive_square,
    e_max_syst,
    read_umbmark_log,
    simulate_umbmark,
    square_end_errors,
    umbmark_correction,
)

__all__ = [
    "FRICTION_LOG_COLUMNS",
    "UMBMARK_LOG_COLUMNS",
    "Estimate",
    "FrictionExperiment",
    "FrictionFit",
    "FrictionLog",
    "MassFit",
    "SideFriction",
    "UmbmarkConfig",
    "UmbmarkCorrection",
    "UmbmarkResult",
    "apply_friction",
    "apply_mass",
    "drive_square",
    "e_max_syst",
    "fit_friction",
    "identify_mass",
    "read_friction_log",
    "read_umbmark_log",
    "simulate_friction_experiment",
    "simulate_umbmark",
    "simulated_scale_readings",
    "square_end_errors",
    "two_speed_friction",
    "umbmark_correction",
]
