"""Vehicle parameters (the report's appendix A) and the constants derived from them.

* :mod:`agvctl.params.schema` — the vehicle file's tables as frozen dataclasses, and :func:`load_vehicle`.
* :mod:`agvctl.params.derived` — the derived constants (eqs 5, 47-51, 60-64), each from the equation it names;
  ``vehicle.derived`` computes them once per parameter set.
"""

from agvctl.params.derived import (
    DerivedConstants,
    SideConstants,
    center_of_mass_from_scales,
    coupling_constants,
    derive,
    equivalent_inertias,
    inertia_from_dimensions,
    inertia_rotation_point,
    motor_damping,
)
from agvctl.params.schema import (
    AmplifierParams,
    BatteryParams,
    BodyParams,
    ControlParams,
    DAParams,
    FrameParams,
    FrictionModelParams,
    MotorPair,
    MotorParams,
    SensorParams,
    VehicleParams,
    WheelParams,
    default_vehicle_path,
    load_vehicle,
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
    "SensorParams",
    "SideConstants",
    "VehicleParams",
    "WheelParams",
    "center_of_mass_from_scales",
    "coupling_constants",
    "default_vehicle_path",
    "derive",
    "equivalent_inertias",
    "inertia_from_dimensions",
    "inertia_rotation_point",
    "load_vehicle",
    "motor_damping",
]
