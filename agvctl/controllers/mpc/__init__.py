"""The MPC pose controllers: a linear time-varying MPC on OSQP (the default) and a nonlinear one on CasADi.

* :mod:`~agvctl.controllers.mpc.config` — their settings, an experiment file's ``[controller]`` keys.
* :mod:`~agvctl.controllers.mpc.common` — the reference on the horizon grid and the step both controllers share.
* :mod:`~agvctl.controllers.mpc.ltv` with :mod:`~agvctl.controllers.mpc.ltv_qp`,
  :mod:`~agvctl.controllers.mpc.osqp_steps` and :mod:`~agvctl.controllers.mpc.matrix_exponential` — the LTV MPC,
  its QP's layout, its per-step OSQP calls and the exact discretisation of its prediction model.
* :mod:`~agvctl.controllers.mpc.nonlinear` — the nonlinear MPC (IPOPT), for comparison.
* :mod:`~agvctl.controllers.mpc.docking` — the final approach beside the end of the path.
* :mod:`~agvctl.controllers.mpc.fallback` — the hard limits on a setpoint and the fallback when a solve fails.
"""

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController

__all__ = ["LtvMpcController", "MpcConfig", "NonlinearMpcController"]
