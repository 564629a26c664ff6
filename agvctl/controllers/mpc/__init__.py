"""The MPC pose controllers: a linear time-varying MPC on OSQP (the default) and a nonlinear one on CasADi.

* :mod:`~agvctl.controllers.mpc.config` — their settings, an experiment file's ``[controller]`` keys.
* :mod:`~agvctl.controllers.mpc.common` — the step both controllers share: the cascade of the parts below.
* :mod:`~agvctl.controllers.mpc.horizon` — the reference on the horizon grid.
* :mod:`~agvctl.controllers.mpc.governor` — the reference governor: the reference's clock slowed while the
  vehicle lags it.
* :mod:`~agvctl.controllers.mpc.shaping` — the command filter: the reach window and the start and turn rules.
* :mod:`~agvctl.controllers.mpc.ltv` with :mod:`~agvctl.controllers.mpc.ltv_qp`,
  :mod:`~agvctl.controllers.mpc.ltv_qp_model`, :mod:`~agvctl.controllers.mpc.qp_blocks`,
  :mod:`~agvctl.controllers.mpc.error_frames`, :mod:`~agvctl.controllers.mpc.prediction` and
  :mod:`~agvctl.controllers.mpc.matrix_exponential` — the LTV MPC, its QP's blocks, the builder that assembles them,
  the error frames and prediction models that supply its matrices, and the exact discretisation.
* :mod:`~agvctl.controllers.mpc.nonlinear` — the nonlinear MPC (IPOPT), for comparison.
* :mod:`~agvctl.controllers.mpc.docking` — the final approach beside the end of the path.
* :mod:`~agvctl.controllers.mpc.fallback` — the hard limits on a setpoint and the fallback when a solve fails.
"""

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController

__all__ = ["LtvMpcController", "MpcConfig", "NonlinearMpcController"]
