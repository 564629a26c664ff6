"""Wheel radii and wheel base by Borenstein & Feng's UMBmark (1996, IEEE Trans. Robotics and Automation 12(6)).

The vehicle drives a square of side L on its own odometry, n times clockwise (cw) and n times counter-clockwise
(ccw), from the same start pose. Each run's return-position error ε = (x_true − x_odometry, y_true − y_odometry)
is measured at the end; the centre of gravity of each direction's error cluster gives the systematic error,
E_max,syst = max(|c_cw|, |c_ccw|).

Conventions (this package's): the start is the origin with heading θ = 0 along +x, y to the left, θ positive
counter-clockwise; ccw turns are +90° (left), cw turns −90°; yaw rate ω = (v_r − v_l)/b (eq 40).

Two systematic errors, first order in small angles:

* type A, the wheel base: the odometry believes b̂, so a turn the odometry counts as 90° is in truth
  90° · b̂/b: every corner turns by α too little (α > 0: the true wheel base is larger);
* type B, unequal wheel diameters: a leg the odometry sees as straight is an arc turning by β (β > 0: to the
  left, the right wheel effectively larger than believed).

Summing the four legs (each a chord of heading θ_k + β/2) gives, for the ccw square,
x_ccw = 2L(β − α), y_ccw = −2L(β − α), and for the cw square x_cw = y_cw = −2L(β + α); hence Borenstein &
Feng's formulas, which hold unchanged in these conventions:

    α = (x_cw + x_ccw)/(−4L) = (y_cw − y_ccw)/(−4L),      β = (x_cw − x_ccw)/(−4L) = (y_cw + y_ccw)/(−4L).

The first-order formulas lose a few per cent of α at the IAU AGV's sizes (second-order terms in β·L), so by
default α and β are refined by least squares on the exact geometry of the same model (arcs and corners), starting
from the first-order values; ``method="first_order"`` uses the four formulas above (each pair averaged).

Corrections (B&F): R = (L/2)/sin(β/2), the radius of a leg's arc; the wheel-diameter ratio
E_d = D_r/D_l = (R + b/2)/(R − b/2); the wheel base b_actual = 90°/(90° − α) · b_nominal. Here b in E_d is the
corrected wheel base (B&F use the nominal; the difference is second order). The corrected radii keep the believed
mean radius: r_l = 2r̄/(E + 1), r_r = 2r̄E/(E + 1), with E the corrected ratio r_r/r_l.

The return-position errors cannot see the mean wheel radius (a square scaled up or down still closes), so it is
kept, and the corrected wheel base is the one consistent with it: b · r̄_believed/r̄_true. That is the
geometry the odometry needs to turn right; calibrate the mean radius by a measured straight run.

* :mod:`~agvctl.calibration.umbmark.model`: the error model (:func:`square_end_errors`) and the correction
  (:func:`umbmark_correction`);
* :mod:`~agvctl.calibration.umbmark.experiment`: the squares driven on the simulator;
* :mod:`~agvctl.calibration.umbmark.log`: reading measured end positions.
"""

from agvctl.calibration.umbmark.experiment import (
    POSITION_NOISE_M,
    Direction,
    UmbmarkConfig,
    UmbmarkResult,
    drive_square,
    simulate_umbmark,
)
from agvctl.calibration.umbmark.log import UMBMARK_LOG_COLUMNS, read_umbmark_log
from agvctl.calibration.umbmark.model import (
    Method,
    UmbmarkCorrection,
    e_max_syst,
    square_end_errors,
    umbmark_correction,
)

__all__ = [
    "POSITION_NOISE_M",
    "UMBMARK_LOG_COLUMNS",
    "Direction",
    "Method",
    "UmbmarkConfig",
    "UmbmarkCorrection",
    "UmbmarkResult",
    "drive_square",
    "e_max_syst",
    "read_umbmark_log",
    "simulate_umbmark",
    "square_end_errors",
    "umbmark_correction",
]
