"""The LTV MPC's QP solver as generated C, in the loop: OSQP's generated code
(:func:`~agvctl.controllers.mpc.c_qp.generate_qp_c`), compiled and called through ctypes.

:class:`CompiledQp` is one solver of a generated QP. The generated solver's workspace is static data of its library,
which a process loads once; each :class:`CompiledQp` keeps a state of its own (the library's ``<prefix>_state_save``
and ``_state_load``) and swaps it in when it is not the library's last user, so solvers of the same QP (several
controllers in one process, threads of one worker) never see each other's iterates, factorisation or step size. A
new solver starts from the state the library had when it was loaded: a solver just set up, as the Python solver is.

:class:`GeneratedOsqp` stands where the LTV MPC keeps its ``osqp.OSQP`` solver (``qp_solver = "osqp_c"``): the same
calls (``update``, ``solve``, ``warm_start``, ``update_settings``) on the generated solver of the same QP, whose
arithmetic is OSQP's own code: it gives the Python solver's answers bit for bit. The solver's library holds the
controller's step in C as well, which solves with it (:class:`~agvctl.controllers.mpc.c_step_loop.CompiledController`,
under :meth:`CompiledQp.held`); the controller's reset goes through the calls above.
"""

from __future__ import annotations

import ctypes
import dataclasses
import hashlib
import threading
import weakref
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.c_qp import QpC, compile_qp_c, generate_qp_c
from agvctl.controllers.mpc.qp_blocks import BlockQp
from agvctl.errors import AgvctlError

__all__ = ["CompiledQp", "GeneratedOsqp", "QpInfo", "QpSolution", "QpSolverError", "generated_qp"]

FloatArray = NDArray[np.float64]


class QpSolverError(AgvctlError):
    """An OSQP call inside the generated solver returned an error (its exit flag): the solver's own failure."""


class QpInfo(ctypes.Structure):
    """What one solve of the generated solver did (``<prefix>_info``): OSQP's status, the iterations, the exit flag
    of a failed call."""

    _fields_ = [("status", ctypes.c_int), ("iterations", ctypes.c_int), ("error", ctypes.c_int)]


@dataclass(frozen=True)
class QpSolution:
    """What one solve of the generated solver gives.

    Parameters
    ----------
    status : int
        OSQP's status value (``osqp.SolverStatus``: 1 solved, 2 solved inaccurate, 7 iteration limit, …; 0: an
        update failed and nothing was solved).
    iterations : int
        The ADMM iterations of this solve.
    x : ndarray
        The primal solution z, n values (a copy).
    y : ndarray
        The dual solution, m values (a copy).
    """

    status: int
    iterations: int
    x: FloatArray
    y: FloatArray


class _Library:
    """One loaded library of a generated solver: the state it was loaded with, and which solver's state it holds."""

    def __init__(self, lib: ctypes.CDLL, prefix: str) -> None:
        self.lib = lib
        self.lock = threading.RLock()
        self.n_bytes = int(getattr(lib, f"{prefix}_state_bytes")())
        self.save = getattr(lib, f"{prefix}_state_save")
        self.save.argtypes = [ctypes.c_void_p]
        self.save.restype = None
        self.load = getattr(lib, f"{prefix}_state_load")
        self.load.argtypes = [ctypes.c_void_p]
        self.load.restype = None
        self.fresh = np.empty(self.n_bytes, dtype=np.uint8)
        self.save(self.fresh.ctypes.data)  # before any call: the solver just set up
        self.holder: weakref.ref[CompiledQp] | None = None


_LIBRARIES: dict[int, _Library] = {}
_LIBRARIES_LOCK = threading.Lock()


def _library(code: QpC) -> _Library:
    lib = compile_qp_c(code)
    with _LIBRARIES_LOCK:
        library = _LIBRARIES.get(id(lib))
        if library is None:  # a process loads each library once, so its first user here sees it fresh
            library = _LIBRARIES[id(lib)] = _Library(lib, code.prefix)
        return library


class CompiledQp:
    """The generated solver of one QP, compiled (:func:`~agvctl.controllers.mpc.c_qp.compile_qp_c`) and called
    through ctypes, with a state of its own (see the module's description); thread-safe.

    Parameters
    ----------
    code : QpC
        The generated C.

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.
    """

    def __init__(self, code: QpC) -> None:
        self._library = library = _library(code)
        lib, p = library.lib, code.prefix
        self.code = code
        self._solve = getattr(lib, f"{p}_solve")
        self._solve.argtypes = [ctypes.c_void_p] * 8
        self._solve.restype = ctypes.c_int
        self._warm_start = getattr(lib, f"{p}_warm_start")
        self._warm_start.argtypes = [ctypes.c_void_p] * 2
        self._warm_start.restype = ctypes.c_int
        self._set_rho = getattr(lib, f"{p}_set_rho")
        self._set_rho.argtypes = [ctypes.c_double]
        self._set_rho.restype = ctypes.c_int
        sizes = [ctypes.c_int() for _ in range(4)]
        getattr(lib, f"{p}_dimensions")(*[ctypes.byref(v) for v in sizes])
        expected = (code.n_variables, code.n_constraints, code.n_p_varying, code.n_a_varying)
        if tuple(v.value for v in sizes) != expected:
            raise AgvctlError(f"the compiled QP solver has sizes {[v.value for v in sizes]}, expected {expected}")
        self._state = library.fresh.copy()
        # buffers allocated once, their addresses taken once (taking a numpy array's address costs microseconds)
        self._sizes = (code.n_variables, code.n_constraints, code.n_constraints, code.n_p_varying, code.n_a_varying)
        self._inputs = [np.empty(max(1, size)) for size in self._sizes]
        self._input_addresses = [int(b.ctypes.data) for b in self._inputs]
        self._x = np.empty(code.n_variables)
        self._y = np.empty(code.n_constraints)
        self._info = QpInfo()
        self._outputs = (int(self._x.ctypes.data), int(self._y.ctypes.data), ctypes.addressof(self._info))

    @property
    def library(self) -> ctypes.CDLL:
        """The loaded library (the solver, and the QP's step where it was generated with it)."""
        return self._library.lib

    @contextmanager
    def held(self) -> Iterator[None]:
        """The library's lock, its solver holding this solver's state: for calls into the library that solve."""
        with self._library.lock:
            self._hold()
            yield

    def _hold(self) -> None:
        """Make the library hold this solver's state (the caller holds the library's lock)."""
        library = self._library
        holder = library.holder() if library.holder is not None else None
        if holder is self:
            return
        if holder is not None:
            library.save(holder._state.ctypes.data)
        library.load(self._state.ctypes.data)
        library.holder = weakref.ref(self)

    def _load(self, i: int, values: FloatArray | None, name: str) -> int | None:
        """``values`` copied into input buffer ``i``; its address (None: a NULL pointer in C)."""
        if values is None:
            return None
        size = self._sizes[i]
        if np.shape(values) != (size,):
            raise ValueError(f"{name} has shape {np.shape(values)}, expected ({size},)")
        self._inputs[i][:size] = values
        return self._input_addresses[i]

    def solve(
        self,
        q: FloatArray,
        lower: FloatArray,
        upper: FloatArray,
        p_values: FloatArray | None = None,
        a_values: FloatArray | None = None,
    ) -> QpSolution:
        """One step: load the vectors and, when given, the varying entries' values; solve warm-started.

        Parameters
        ----------
        q : ndarray
            The cost's linear term, n values.
        lower, upper : ndarray
            The bounds, m values each (clipped to ±1e30 in C, as OSQP's Python interface clips them).
        p_values : ndarray or None
            P's varying entries, in the order of ``BlockQp.p_varying`` (None: P keeps its values).
        a_values : ndarray or None
            A's varying entries, in the order of ``BlockQp.a_varying`` (None: A keeps its values).

        Returns
        -------
        QpSolution
            OSQP's status, the iterations and the solution.

        Raises
        ------
        QpSolverError
            An OSQP call in C returned an error (its exit flag).
        """
        vectors = ((q, "q"), (lower, "lower"), (upper, "upper"), (p_values, "p_values"), (a_values, "a_values"))
        with self._library.lock:
            addresses = [self._load(i, values, name) for i, (values, name) in enumerate(vectors)]
            self._hold()
            error = self._solve(*addresses, *self._outputs)
            solution = QpSolution(int(self._info.status), int(self._info.iterations), self._x.copy(), self._y.copy())
        if error:
            raise QpSolverError(f"the generated QP solver's update or solve failed: OSQP exit flag {error}")
        return solution

    def warm_start(self, x: FloatArray, y: FloatArray) -> None:
        """Start the next solve from ``x`` (n values) and ``y`` (m values).

        Parameters
        ----------
        x : ndarray
            The primal start.
        y : ndarray
            The dual start.
        """
        with self._library.lock:
            addresses = self._load(0, x, "x"), self._load(1, y, "y")  # q's and l's buffers have their sizes
            self._hold()
            refused = self._warm_start(*addresses)
        if refused:
            raise QpSolverError("the generated QP solver refused the warm start")

    def set_rho(self, rho: float) -> None:
        """Set ADMM's step size ρ (the KKT matrix is factorised again).

        Parameters
        ----------
        rho : float
            The step size, > 0.
        """
        with self._library.lock:
            self._hold()
            refused = self._set_rho(float(rho))
        if refused:
            raise QpSolverError(f"the generated QP solver refused rho = {rho}")


_GENERATED: dict[str, QpC] = {}
_GENERATED_LOCK = threading.Lock()


def generated_qp(
    qp: BlockQp[Any, Any], settings: Mapping[str, Any], *, single: bool = False, files: Mapping[str, str] | None = None
) -> QpC:
    """The generated solver of ``qp`` set up with ``settings`` (and ``files`` with it), generated once per process for
    the same data.

    Parameters
    ----------
    qp : BlockQp
        The assembled QP, as the controller sets its solver up on it.
    settings : mapping of str to Any
        OSQP's settings.
    single : bool
        In single precision.
    files : mapping of str to str or None
        More C compiled into the same library, ``{name: text}`` (the QP's step,
        :func:`~agvctl.controllers.mpc.c_step.generate_step_c`, and the controller's,
        :func:`~agvctl.controllers.mpc.c_update.generate_update_c`).

    Returns
    -------
    QpC
        The generated C (:func:`~agvctl.controllers.mpc.c_qp.generate_qp_c`).
    """
    step_files = sorted(files.items()) if files is not None else []
    digest = hashlib.sha256(repr((single, sorted(settings.items()), step_files)).encode())
    for matrix in (qp.P, qp.A):
        for part in (matrix.indptr, matrix.indices, matrix.data):
            digest.update(np.ascontiguousarray(part).tobytes())
    for vector in (qp.q, qp.lower, qp.upper, qp.p_varying, qp.a_varying):
        digest.update(np.ascontiguousarray(vector).tobytes())
    key = digest.hexdigest()
    with _GENERATED_LOCK:
        code = _GENERATED.get(key)
        if code is None:
            origin = "an LTV MPC in the closed loop"
            code = generate_qp_c(qp, settings, origin=origin, generator="agvctl", single=single)
            if files is not None:
                code = dataclasses.replace(code, files={**code.files, **files})
            _GENERATED[key] = code
        return code


@dataclass(frozen=True)
class _SolveInfo:
    status_val: int
    iter: int


@dataclass(frozen=True)
class _SolveResult:
    x: FloatArray
    y: FloatArray
    info: _SolveInfo


class GeneratedOsqp:
    """The generated C solver of a QP behind the calls the LTV MPC makes of ``osqp.OSQP`` (see the module's
    description).

    Parameters
    ----------
    qp : BlockQp
        The assembled QP, in the state the solver is set up on.
    settings : mapping of str to Any
        OSQP's settings (``time_limit`` has no effect: the generated solver keeps no time).
    single : bool
        Generate the solver in single precision (``qp_solver = "osqp_c_float"``).
    files : mapping of str to str or None
        More C compiled into the solver's library: the QP's step and the controller's
        (:class:`~agvctl.controllers.mpc.c_step_loop.CompiledController` calls them).

    Raises
    ------
    AgvctlError
        Another OSQP release than the generator's, no C compiler, or the code does not compile.
    """

    def __init__(
        self,
        qp: BlockQp[Any, Any],
        settings: Mapping[str, Any],
        *,
        single: bool = False,
        files: Mapping[str, str] | None = None,
    ) -> None:
        self.solver = CompiledQp(generated_qp(qp, settings, single=single, files=files))
        self._vectors: dict[str, Any] = {}

    def update(self, **arguments: Any) -> None:
        """Keep this step's data for :meth:`solve`: ``q``, ``l``, ``u`` and, where they changed, ``Px`` and ``Ax``
        (every varying entry, as :meth:`~agvctl.controllers.mpc.qp_blocks.BlockQp.matrix_update` gives them).

        Parameters
        ----------
        **arguments
            ``osqp.OSQP.update``'s keywords.
        """
        self._vectors = arguments

    def solve(self, raise_error: bool = False) -> _SolveResult:
        """Solve with the data of the last :meth:`update`.

        Parameters
        ----------
        raise_error : bool
            Unused: a failed solve is its status, an error of OSQP's is :class:`QpSolverError`.

        Returns
        -------
        object
            ``x``, ``y`` and ``info.status_val``, ``info.iter``, as ``osqp.OSQP.solve`` gives them.
        """
        u = self._vectors
        solution = self.solver.solve(u["q"], u["l"], u["u"], u.get("Px"), u.get("Ax"))
        return _SolveResult(solution.x, solution.y, _SolveInfo(solution.status, solution.iterations))

    def warm_start(self, *, x: FloatArray, y: FloatArray) -> None:
        """Start the next solve from ``x`` and ``y``.

        Parameters
        ----------
        x : ndarray
            The primal start.
        y : ndarray
            The dual start.
        """
        self.solver.warm_start(x, y)

    def update_settings(self, *, rho: float) -> None:
        """Set the step size ρ, the one setting the controller changes during a run.

        Parameters
        ----------
        rho : float
            The step size.
        """
        self.solver.set_rho(rho)
