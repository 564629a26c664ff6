"""Plant models of three fidelities (the report's sections 2-4).

* :mod:`agvctl.plant.full` — the nonlinear model (eqs 2-4, 39-43, 47-59), symbolic in CasADi.
* :mod:`agvctl.plant.linear` — the simplified linear model (eqs 35-38) as ``control.StateSpace``.
* :mod:`agvctl.plant.decoupled` — the per-wheel model (eqs 60-61) as ``control.TransferFunction``.
* :mod:`agvctl.plant.friction` — the pre-velocity friction model with stiction (eqs 2-4).
* :mod:`agvctl.plant.codegen` and :mod:`agvctl.plant.integrator` — the full model compiled to C and integrated
  sample by sample with adaptive substeps, the form every simulation steps.
"""

from agvctl.plant.decoupled import decoupled_wheel_models
from agvctl.plant.full import FullModel, PlantOptions, parameter_vector
from agvctl.plant.linear import linear_model, linear_model_speed_yaw_rate

__all__ = [
    "FullModel",
    "PlantOptions",
    "decoupled_wheel_models",
    "linear_model",
    "linear_model_speed_yaw_rate",
    "parameter_vector",
]
