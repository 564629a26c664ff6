"""Vehicle parameters (the report's appendix A) and the constants derived from them.

* :mod:`agvctl.params.schema` — the vehicle of all the file's tables, :func:`load_vehicle`, and
  :func:`derive`, which computes a vehicle's derived constants (eqs 5, 47-51, 60-64) once per parameter set
  (``vehicle.derived``).
* :mod:`agvctl.params.tables` — the tables that come once per vehicle (frame, body, amplifier, …) as frozen
  dataclasses.
* :mod:`agvctl.params.sides` — the tables that come once per side, wheels and motors: common values with
  ``left`` / ``right`` overrides.
* :mod:`agvctl.params.derived` — the equations of the derived constants, for numbers and CasADi symbols alike,
  and their records. It knows nothing of the tables.
"""

from agvctl.params.derived import (
    DerivedConstants,
    Side,
    SideConstants,
    center_of_mass_from_scales,
    coupling_constants,
    equivalent_inertias,
    motor_damping,
    motor_from_rim,
    rim_from_motor,
)
from agvctl.params.schema import VehicleParams, default_vehicle_path, derive, load_vehicle
from agvctl.params.sides import SIDES, MotorPair, MotorParams, WheelParams, WheelSide
from agvctl.params.tables import (
    AmplifierParams,
    BatteryParams,
    BodyParams,
    ControlParams,
    DAParams,
    FrameParams,
    FrictionModelParams,
    SensorParams,
    inertia_from_dimensions,
    inertia_rotation_point,
)

__all__ = [
    "AmplifierParams",
    "BatteryParams",
    "BodyParams",
    "ControlParams",
    "DAParams",
    "DerivedConstants",
    "FrameParams",
    "FrictionModelParams",
    "MotorPair",
    "MotorParams",
    "SIDES",
    "SensorParams",
    "Side",
    "SideConstants",
    "VehicleParams",
    "WheelParams",
    "WheelSide",
    "center_of_mass_from_scales",
    "coupling_constants",
    "default_vehicle_path",
    "derive",
    "equivalent_inertias",
    "inertia_from_dimensions",
    "inertia_rotation_point",
    "load_vehicle",
    "motor_damping",
    "motor_from_rim",
    "rim_from_motor",
]
