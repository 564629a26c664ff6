"""agvctl: control design and trajectory planning for the IAU differential-drive AGV.

The physics is that of the technical report "Models for IAU's Autonomous Guided Vehicle" (IMM-REP-1997-15),
with the corrections listed in the README's model notes. Data flows one way::

    vehicles/*.toml ─► params ─► plant (full | linear | decoupled) ◄─ actuator (DA 12-bit, amplifier)
    trajectories/*.toml ─► planning (Ruckig) ─► Reference
                         Reference ─► controllers (MPC pose ─► PI wheel) ─► actuator ─► plant
    experiments/*.toml ─► sim loop ─► SimLog ─► checks (limits, JUnit) / plots / identify ─► cli

Start with :func:`agvctl.params.load_vehicle` and :class:`agvctl.sim.Simulator`.
"""

from agvctl.errors import AgvctlError, ConfigError, PlanningError
from agvctl.params import VehicleParams, load_vehicle

__version__ = "0.1.0"

__all__ = ["AgvctlError", "ConfigError", "PlanningError", "VehicleParams", "load_vehicle", "__version__"]
