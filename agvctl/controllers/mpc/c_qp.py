"""The LTV MPC's QP as generated C99: OSQP's own code generation, made warning-free, behind a thin entry point.

:func:`generate_qp_c` sets up OSQP on an assembled :class:`~agvctl.controllers.mpc.qp_blocks.BlockQp` with the
controller's settings and has OSQP generate its embedded solver (``parameters="matrices"``: the vectors and the
matrices' values may change, the sparsity pattern not; printing, profiling and interrupts off; no Python extension,
so nothing is downloaded). The generated files are then made to compile with :data:`STRICT_C_FLAGS`, warnings as
errors, by the source fixes of :data:`~agvctl.controllers.mpc.osqp_fixes.OSQP_FIXES`: exact text substitutions,
each of which must apply as many times as stated, so that an OSQP release whose text differs fails loudly here instead
of silently skipping a fix. Two Jinja2 templates beside this module add the entry point, ``<prefix>.h`` and
``<prefix>.c``: one step loads q, l, u and the values of P's and A's varying entries (the positions
:attr:`~agvctl.controllers.mpc.qp_blocks.BlockQp.p_varying` and
:attr:`~agvctl.controllers.mpc.qp_blocks.BlockQp.a_varying`, baked in as ``static const`` data), solves warm-started,
and returns OSQP's status, the iterations and the solution.

:class:`CompiledQp` is that C compiled by :func:`~agvctl.plant.codegen.compiled_library` and called through ctypes.
"""

from __future__ import annotations

import ctypes
import subprocess
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import osqp
from numpy.typing import NDArray

from agvctl.controllers.mpc.osqp_fixes import OSQP_FIXES, OSQP_VERSION, SourceFix
from agvctl.controllers.mpc.qp_blocks import BlockQp
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS
from agvctl.errors import AgvctlError
from agvctl.plant.codegen import c_templates, compiled_library

__all__ = ["STRICT_C_FLAGS", "CompiledQp", "QpC", "QpSolution", "compile_qp_c", "generate_qp_c", "write_qp_c"]

FloatArray = NDArray[np.float64]

PREFIX = "agv_mpc_qp"
"""The entry point's stem and the prefix of every name the generated files define (OSQP's workspace included)."""

_DROPPED = ("emosqp.c", "Makefile")
"""OSQP's example caller (it prints through stdio) and its Makefile (no flags): not part of the product."""


@dataclass(frozen=True)
class QpC:
    """The generated C of one QP: OSQP's solver and workspace, fixed, and the entry point.

    Parameters
    ----------
    files : dict of str to str
        ``{path relative to the folder: text}``: ``src/*.c``, ``inc/public/*.h``, ``inc/private/*.h``,
        ``osqp_configure.h``, the workspace ``<prefix>_workspace.{c,h}`` and the entry point ``<prefix>.{c,h}``.
    prefix : str
        The entry point's stem and the names' prefix.
    n_variables : int
        The QP's variables, n.
    n_constraints : int
        Its constraint rows, m.
    n_p_varying : int
        The varying entries of P, in the order of :attr:`~agvctl.controllers.mpc.qp_blocks.BlockQp.p_varying`.
    n_a_varying : int
        The varying entries of A, in the order of :attr:`~agvctl.controllers.mpc.qp_blocks.BlockQp.a_varying`.
    """

    files: dict[str, str]
    prefix: str
    n_variables: int
    n_constraints: int
    n_p_varying: int
    n_a_varying: int

    @property
    def sources(self) -> list[str]:
        """The ``.c`` files, sorted: what a build compiles."""
        return sorted(path for path in self.files if path.endswith(".c"))

    @property
    def include_dirs(self) -> list[str]:
        """The folders that hold headers, sorted (``"."`` for the top): a build's include path."""
        return sorted({str(Path(path).parent) for path in self.files if path.endswith(".h")})

    def write(self, folder: str | Path) -> Path:
        """Write the files into ``folder`` (made if missing; files of the same name replaced).

        Parameters
        ----------
        folder : str or Path
            Where.

        Returns
        -------
        Path
            The folder.
        """
        root = Path(folder)
        for path, text in self.files.items():
            target = root / path
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(text, encoding="utf-8")
        return root


def _rows(positions: NDArray[np.int64], per_row: int = 12) -> list[list[int]]:
    values = [int(p) for p in positions]
    return [values[i : i + per_row] for i in range(0, len(values), per_row)]


def _osqp_files(
    qp: BlockQp[Any, Any], settings: Mapping[str, Any], prefix: str, fixes: Sequence[SourceFix]
) -> dict[str, str]:
    """OSQP's generated solver for ``qp`` set up with ``settings``, as ``{relative path: text}``, fixes applied."""
    if osqp.__version__ != OSQP_VERSION:
        raise AgvctlError(f"the QP's C is generated with osqp {OSQP_VERSION}; osqp {osqp.__version__} is installed")
    solver = osqp.OSQP()
    solver.setup(qp.P, qp.q, qp.A, qp.lower, qp.upper, **settings)
    with tempfile.TemporaryDirectory(prefix="agvctl-qp-") as tmp:
        folder = Path(tmp, "qp")
        solver.codegen(
            str(folder),
            parameters="matrices",
            extension_name=None,
            force_rewrite=True,
            use_float=False,
            printing_enable=False,
            profiling_enable=False,
            interrupt_enable=False,
            include_codegen_src=True,
            prefix=f"{prefix}_",
            compile=False,
        )
        files = {
            p.relative_to(folder).as_posix(): p.read_text(encoding="utf-8")
            for p in sorted(folder.rglob("*"))
            if p.is_file() and p.name not in _DROPPED
        }
    for fix in fixes:
        path = fix.path.format(workspace=f"{prefix}_workspace")
        files[path] = fix.apply(files[path])
    return files


def generate_qp_c(
    qp: BlockQp[Any, Any],
    settings: Mapping[str, Any],
    *,
    origin: str,
    generator: str,
    prefix: str = PREFIX,
    fixes: Sequence[SourceFix] = OSQP_FIXES,
) -> QpC:
    """The C99 of ``qp``'s solver: OSQP's generated code for it, fixed to compile warning-free, and the entry point.

    OSQP is set up on ``qp``'s matrices and vectors as they are (P and A with every entry that can ever be nonzero),
    so the generated workspace is the state of a Python solver just set up on the same data with the same settings.

    Parameters
    ----------
    qp : BlockQp
        The assembled QP (``LtvMpcController``'s, after :meth:`~agvctl.controllers.mpc.qp_blocks.BlockQp.retarget`
        or not: only the sparsity pattern and the varying positions must stay those of every step).
    settings : mapping of str to Any
        OSQP's settings, as the controller sets it up (:attr:`LtvMpcController.osqp_settings
        <agvctl.controllers.mpc.ltv.LtvMpcController.osqp_settings>`); ``time_limit`` has no effect in the generated
        solver, which keeps no time.
    origin : str
        What the QP is of (the experiment), written into the entry point's files.
    generator : str
        What wrote them (``"agvctl 0.2.0"``), written into the entry point's files.
    prefix : str
        The entry point's stem and the prefix of every name the files define.
    fixes : sequence of SourceFix
        The source fixes to apply (all of :data:`~agvctl.controllers.mpc.osqp_fixes.OSQP_FIXES`; fewer to see
        what one of them is for).

    Returns
    -------
    QpC
        The files.

    Raises
    ------
    AgvctlError
        Another OSQP release than ``osqp_fixes.OSQP_VERSION``, or one of the fixes does not apply.
    """
    files = _osqp_files(qp, settings, prefix, fixes)
    n, m = qp.layout.n_variables, qp.n_rows
    values = {
        "prefix": prefix,
        "guard": f"{prefix.upper()}_H",
        "macro": prefix.upper(),
        "workspace": f"{prefix}_workspace",
        "solver": f"{prefix}_solver",
        "osqp_version": OSQP_VERSION,
        "origin": origin,
        "generator": generator,
        "n": n,
        "m": m,
        "n_p": len(qp.p_varying),
        "n_a": len(qp.a_varying),
        "p_varying": _rows(qp.p_varying),
        "a_varying": _rows(qp.a_varying),
    }
    env = c_templates("agvctl.controllers.mpc")
    files[f"{prefix}.h"] = env.get_template("mpc_qp.h.j2").render(values)
    files[f"{prefix}.c"] = env.get_template("mpc_qp.c.j2").render(values)
    return QpC(files, prefix, n, m, len(qp.p_varying), len(qp.a_varying))


def write_qp_c(
    folder: str | Path,
    qp: BlockQp[Any, Any],
    settings: Mapping[str, Any],
    *,
    origin: str,
    generator: str,
    prefix: str = PREFIX,
    fixes: Sequence[SourceFix] = OSQP_FIXES,
) -> QpC:
    """Write the C99 of ``qp``'s solver (:func:`generate_qp_c`) into ``folder``.

    Parameters
    ----------
    folder : str or Path
        Where (made if missing; files of the same name replaced).
    qp : BlockQp
        The assembled QP.
    settings : mapping of str to Any
        OSQP's settings, as the controller sets it up.
    origin : str
        What the QP is of, written into the entry point's files.
    generator : str
        What wrote them, written into the entry point's files.
    prefix : str
        The entry point's stem and the prefix of every name the files define.
    fixes : sequence of SourceFix
        The source fixes to apply.

    Returns
    -------
    QpC
        The files written.
    """
    code = generate_qp_c(qp, settings, origin=origin, generator=generator, prefix=prefix, fixes=fixes)
    code.write(folder)
    return code


def compile_qp_c(code: QpC) -> ctypes.CDLL:
    """``code`` compiled with :data:`STRICT_C_FLAGS` into the cache of compiled code (once) and loaded.

    Parameters
    ----------
    code : QpC
        The generated C.

    Returns
    -------
    ctypes.CDLL
        The library, with ``<prefix>_solve``, ``<prefix>_warm_start``, ``<prefix>_set_rho`` and
        ``<prefix>_dimensions``.

    Raises
    ------
    AgvctlError
        No C compiler, or the compiler refused the code (its first message line).
    """
    try:
        return compiled_library(code.files, code.prefix, flags=(*STRICT_C_FLAGS, "-fPIC", "-shared"))
    except subprocess.CalledProcessError as exc:
        message = (exc.stderr or b"").decode(errors="replace").strip().splitlines()
        raise AgvctlError(f"the generated QP solver does not compile: {message[0] if message else exc}") from None
    except OSError as exc:
        raise AgvctlError(f"the generated QP solver cannot be compiled or loaded: {exc}") from None


class _Info(ctypes.Structure):
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


class CompiledQp:
    """The generated solver of one QP, compiled (:func:`compile_qp_c`) and called through ctypes.

    The solver's workspace is static data of the library, which a process loads once: every :class:`CompiledQp` of
    the same generated code shares one solver, which continues from where the last solve left it, as on the vehicle
    (a second, independent solver needs code generated with another ``prefix``). Not for two threads at once.

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
        lib = compile_qp_c(code)
        p = code.prefix
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
        # buffers allocated once, their addresses taken once (taking a numpy array's address costs microseconds)
        self._sizes = (code.n_variables, code.n_constraints, code.n_constraints, code.n_p_varying, code.n_a_varying)
        self._inputs = [np.empty(max(1, size)) for size in self._sizes]
        self._input_addresses = [int(b.ctypes.data) for b in self._inputs]
        self._x = np.empty(code.n_variables)
        self._y = np.empty(code.n_constraints)
        self._info = _Info()
        self._outputs = (int(self._x.ctypes.data), int(self._y.ctypes.data), ctypes.addressof(self._info))

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
        AgvctlError
            An OSQP call in C returned an error (its exit flag).
        """
        vectors = ((q, "q"), (lower, "lower"), (upper, "upper"), (p_values, "p_values"), (a_values, "a_values"))
        addresses = [self._load(i, values, name) for i, (values, name) in enumerate(vectors)]
        error = self._solve(*addresses, *self._outputs)
        if error:
            raise AgvctlError(f"the generated QP solver's update or solve failed: OSQP exit flag {error}")
        return QpSolution(int(self._info.status), int(self._info.iterations), self._x.copy(), self._y.copy())

    def warm_start(self, x: FloatArray, y: FloatArray) -> None:
        """Start the next solve from ``x`` (n values) and ``y`` (m values).

        Parameters
        ----------
        x : ndarray
            The primal start.
        y : ndarray
            The dual start.
        """
        if self._warm_start(self._load(0, x, "x"), self._load(1, y, "y")):  # q's and l's buffers have their sizes
            raise AgvctlError("the generated QP solver refused the warm start")

    def set_rho(self, rho: float) -> None:
        """Set ADMM's step size ρ (the KKT matrix is factorised again).

        Parameters
        ----------
        rho : float
            The step size, > 0.
        """
        if self._set_rho(float(rho)):
            raise AgvctlError(f"the generated QP solver refused rho = {rho}")
