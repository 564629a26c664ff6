"""OSQP's per-step calls for a solver set up once and updated every control step.

osqp's public ``OSQP.update``/``OSQP.solve`` wrap the compiled solver's calls in argument checks and build a result
namespace field by field on every solve; for a problem solved in about 0.1 ms that is a few per cent of a step.
:func:`solver_steps` returns the compiled solver itself when this osqp version exposes it, else an adapter over the
public interface with the same methods.
"""

from __future__ import annotations

from typing import Any, Protocol, cast

import numpy as np
import osqp
from numpy.typing import NDArray

__all__ = ["PublicSteps", "SolverSteps", "solver_steps"]

FloatArray = NDArray[np.float64]


class SolverSteps(Protocol):
    """What a step needs of a set-up OSQP solver: osqp's compiled solver object (``osqp.ext_builtin.OSQPSolver``)
    has these, as does :class:`PublicSteps` over the public interface."""

    info: Any
    solution: Any

    def update_data_vec(self, *, q: FloatArray, l: FloatArray, u: FloatArray) -> None: ...  # noqa: E741

    def update_data_mat(self, *, P_x: FloatArray | None, P_i: None, A_x: FloatArray | None, A_i: None) -> None: ...

    def solve(self) -> None: ...

    def warm_start(self, x: FloatArray, y: FloatArray) -> None: ...


class PublicSteps:
    """:class:`SolverSteps` through osqp's public ``OSQP`` methods."""

    def __init__(self, solver: osqp.OSQP) -> None:
        self._solver = solver
        self.info: Any = None
        self.solution: Any = None

    def update_data_vec(self, *, q: FloatArray, l: FloatArray, u: FloatArray) -> None:  # noqa: E741
        self._solver.update(q=q, l=l, u=u)

    def update_data_mat(self, *, P_x: FloatArray | None, P_i: None, A_x: FloatArray | None, A_i: None) -> None:
        self._solver.update(**{name: v for name, v in (("Px", P_x), ("Ax", A_x)) if v is not None})

    def solve(self) -> None:
        result = self._solver.solve(raise_error=False)
        self.solution, self.info = result, result.info

    def warm_start(self, x: FloatArray, y: FloatArray) -> None:
        self._solver.warm_start(x=x, y=y)


def solver_steps(solver: osqp.OSQP) -> SolverSteps:
    """The compiled solver inside ``solver`` when this osqp has it (1.x keeps it as ``_solver``), else the public
    interface. The public ``update``/``solve`` wrap the same calls in argument checks and a result namespace built
    field by field: about 15 µs a step here, 5 % of the MPC's (measured with osqp 1.1). Our bounds are already
    within ±OSQP_INFTY, the one thing the wrapper's ``update`` adjusts."""
    compiled = getattr(solver, "_solver", None)
    needed = ("update_data_vec", "update_data_mat", "solve", "warm_start", "info", "solution")
    if compiled is not None and all(hasattr(compiled, name) for name in needed):
        return cast(SolverSteps, compiled)
    return PublicSteps(solver)
