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

:func:`compile_qp_c` compiles it into the cache of compiled code; :mod:`~agvctl.controllers.mpc.c_solver` calls it
through ctypes, each solver with a state of its own (``<prefix>_state_save`` and ``_state_load``, appended to the
workspace: copies of its objects, so that several solvers share one library).
"""

from __future__ import annotations

import ctypes
import re
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

__all__ = ["STRICT_C_FLAGS", "QpC", "compile_qp_c", "generate_qp_c", "write_qp_c"]

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
    single : bool
        The solver computes in single precision (``float``; the entry point takes and gives ``double``).
    """

    files: dict[str, str]
    prefix: str
    n_variables: int
    n_constraints: int
    n_p_varying: int
    n_a_varying: int
    single: bool = False

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
    qp: BlockQp[Any, Any], settings: Mapping[str, Any], prefix: str, fixes: Sequence[SourceFix], single: bool
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
            use_float=single,
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
    workspace = f"{prefix}_workspace.c"
    files[workspace] += _state_functions(files[workspace], prefix)
    return files


_OBJECT = re.compile(r"^(?!const\b|static\b)[A-Za-z_]\w*\s+([A-Za-z_]\w*)\s*(?:\[\d+\])?\s*[=;]", re.MULTILINE)
"""A definition at file scope of the generated workspace: a type, the object's name, its size if an array, then its
initialiser or the end."""


def _state_functions(workspace: str, prefix: str) -> str:
    """C appended to the workspace's file: its objects' size in bytes, and copies of them to and from a buffer (the
    solver's state, ``<prefix>_state_bytes``, ``_state_save``, ``_state_load``; declared in the entry point's
    header)."""
    names = _OBJECT.findall(workspace)
    if f"{prefix}_solver" not in names or f"{prefix}_work" not in names:
        raise AgvctlError("the generated workspace does not define the solver and its workspace as expected")
    sizes = " +\n        ".join(f"sizeof {name}" for name in names)
    save = "".join(f"    memcpy(to, &{name}, sizeof {name});\n    to += sizeof {name};\n" for name in names)
    load = "".join(f"    memcpy(&{name}, from, sizeof {name});\n    from += sizeof {name};\n" for name in names)
    return (
        "\n/* The solver's state as one block of bytes (appended by agvctl; see the entry point's header). */\n"
        "#include <string.h>\n\n"
        f"unsigned long {prefix}_state_bytes(void);\n"
        f"void {prefix}_state_save(unsigned char *to);\n"
        f"void {prefix}_state_load(const unsigned char *from);\n\n"
        f"unsigned long {prefix}_state_bytes(void)\n{{\n    return (unsigned long)({sizes});\n}}\n\n"
        f"void {prefix}_state_save(unsigned char *to)\n{{\n{save}}}\n\n"
        f"void {prefix}_state_load(const unsigned char *from)\n{{\n{load}}}\n"
    )


def generate_qp_c(
    qp: BlockQp[Any, Any],
    settings: Mapping[str, Any],
    *,
    origin: str,
    generator: str,
    prefix: str = PREFIX,
    fixes: Sequence[SourceFix] = OSQP_FIXES,
    single: bool = False,
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
    single : bool
        Generate the solver in single precision (``float``: for a processor whose floating-point unit has no
        ``double``); the entry point still takes and gives ``double``, rounded on the way in.

    Returns
    -------
    QpC
        The files.

    Raises
    ------
    AgvctlError
        Another OSQP release than ``osqp_fixes.OSQP_VERSION``, or one of the fixes does not apply.
    """
    files = _osqp_files(qp, settings, prefix, fixes, single)
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
        "single": single,
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
    return QpC(files, prefix, n, m, len(qp.p_varying), len(qp.a_varying), single)


def write_qp_c(
    folder: str | Path,
    qp: BlockQp[Any, Any],
    settings: Mapping[str, Any],
    *,
    origin: str,
    generator: str,
    prefix: str = PREFIX,
    fixes: Sequence[SourceFix] = OSQP_FIXES,
    single: bool = False,
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
    single : bool
        Generate the solver in single precision.

    Returns
    -------
    QpC
        The files written.
    """
    code = generate_qp_c(qp, settings, origin=origin, generator=generator, prefix=prefix, fixes=fixes, single=single)
    code.write(folder)
    return code


def compile_qp_c(code: QpC) -> ctypes.CDLL:
    """``code`` compiled with :data:`STRICT_C_FLAGS` and ``-O3`` into the cache of compiled code (once) and loaded.

    ``-O3`` as the ``osqp`` package's own build (the factorisation that most steps of a winding path redo runs about
    a tenth faster than at ``-O2``); without ``-ffast-math`` it computes the same numbers, so the solver in the loop
    answers as the vehicle's ``-O2`` build does.

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
        return compiled_library(code.files, code.prefix, flags=(*STRICT_C_FLAGS, "-O3", "-fPIC", "-shared"))
    except subprocess.CalledProcessError as exc:
        message = (exc.stderr or b"").decode(errors="replace").strip().splitlines()
        raise AgvctlError(f"the generated QP solver does not compile: {message[0] if message else exc}") from None
    except OSError as exc:
        raise AgvctlError(f"the generated QP solver cannot be compiled or loaded: {exc}") from None
