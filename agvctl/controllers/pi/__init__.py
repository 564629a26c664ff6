"""The PI wheel-speed loops (40 ms) and their design from the decoupled model (eqs 60-61).

* :mod:`~agvctl.controllers.pi.wheel_loop` — the discrete loops with anti-windup on the DA range and the
  amplifier's current limit, and steering priority when both saturate.
* :mod:`~agvctl.controllers.pi.gains_file` — the gains files ``agvctl tune --out`` writes.
* :mod:`~agvctl.controllers.pi.tuning` — gains designed for phase margin and bandwidth with python-control.
"""

from agvctl.controllers.pi.gains_file import PISettings, gains_toml, load_gains
from agvctl.controllers.pi.options import Braking, PIGains, WheelLoopOptions
from agvctl.controllers.pi.tuning import LoopMargins, TuningResult, TuningSpec, default_pi_gains, design_pi
from agvctl.controllers.pi.wheel_loop import PIWheelController

__all__ = [
    "Braking",
    "LoopMargins",
    "PIGains",
    "PISettings",
    "PIWheelController",
    "TuningResult",
    "TuningSpec",
    "WheelLoopOptions",
    "default_pi_gains",
    "design_pi",
    "gains_toml",
    "load_gains",
]
