"""Code generation: an experiment's controllers as dependency-free C99 for the vehicle.

* :mod:`~agvctl.codegen.generate` — ``agvctl codegen``'s API: the experiment's PI wheel loops
  (:mod:`agvctl.controllers.pi.c_loops`) with a README, an example caller and a Makefile, as files to write.
* :mod:`~agvctl.codegen.back_to_back` — the C loops beside the Python ones in the closed loop: their largest DA
  difference on the same inputs and both runs' verdicts; the MPC on its generated QP solver against OSQP in Python.
"""

from agvctl.codegen.back_to_back import BackToBack, QpBackToBack, SideBySideWheelLoops, back_to_back, qp_back_to_back
from agvctl.codegen.generate import GeneratedCode, generate_code

__all__ = [
    "BackToBack",
    "GeneratedCode",
    "QpBackToBack",
    "SideBySideWheelLoops",
    "back_to_back",
    "generate_code",
    "qp_back_to_back",
]
