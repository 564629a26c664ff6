"""Code generation: an experiment's controllers as dependency-free C99 for the vehicle.

* :mod:`~agvctl.codegen.generate` — ``agvctl codegen``'s API: the experiment's PI wheel loops
  (:mod:`agvctl.controllers.pi.c_loops`) with a README, an example caller and a Makefile, as files to write.
* :mod:`~agvctl.codegen.back_to_back` — the C loops beside the Python ones in the closed loop: their largest DA
  difference on the same inputs and both runs' verdicts; the MPC on its generated QP solver against OSQP in Python;
  a generated cascade (the Ramsete law and the loops) against the same in Python.
* :mod:`~agvctl.codegen.cascade` — where the pose controller is generated, the whole cascade: the law, the reference
  as data and one step function.
"""

from agvctl.codegen.back_to_back import (
    BackToBack,
    RunsBackToBack,
    SideBySideWheelLoops,
    back_to_back,
    cascade_back_to_back,
    qp_back_to_back,
)
from agvctl.codegen.generate import GeneratedCode, generate_code

__all__ = [
    "BackToBack",
    "GeneratedCode",
    "RunsBackToBack",
    "SideBySideWheelLoops",
    "back_to_back",
    "cascade_back_to_back",
    "generate_code",
    "qp_back_to_back",
]
