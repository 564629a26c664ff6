"""CasADi functions as compiled C: code generation, the system C compiler, a disk cache, and calls through ctypes.

:func:`native_functions` generates C for a set of CasADi functions, compiles it once into a shared object kept
in :func:`cache_dir` (keyed by a hash of the generated code, the flags, CasADi's version and the platform, so a
changed model never loads a stale library) and returns callables on numpy arrays. Without a working C compiler,
or with ``AGVCTL_NO_COMPILE=1``, the same functions run in CasADi's virtual machine, about ten times slower; a
failed compilation says so with a :class:`RuntimeWarning`.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
from numpy.typing import NDArray

__all__ = ["NumericFunction", "cache_dir", "native_functions"]

NumericFunction = Callable[..., tuple[NDArray[np.float64], ...]]
"""A CasADi function evaluated on numpy arrays: inputs in its order, outputs as 2-D arrays (rows × columns)."""

_COMPILER_FLAGS = ("-O2", "-fPIC", "-shared")


def cache_dir() -> Path:
    """Where compiled plant code is kept: ``$AGVCTL_CACHE_DIR``, else ``$XDG_CACHE_HOME/agvctl``, else
    ``~/.cache/agvctl``."""
    env = os.environ.get("AGVCTL_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "agvctl"


class _VmCall:
    """Evaluate a CasADi function in its virtual machine; outputs as 2-D numpy arrays."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn

    def __call__(self, *inputs: Any) -> tuple[NDArray[np.float64], ...]:
        return tuple(np.asarray(o, dtype=float) for o in self.fn.call(list(inputs)))


class _CCall:
    """Call a function of CasADi-generated C code through ctypes, on numpy buffers without copies.

    CasADi's own Python wrapper converts every output to a ``DM`` and back, which costs more than the
    integration for large batches; here inputs are passed as pointers and outputs written in place.
    """

    def __init__(self, lib: ctypes.CDLL, fn: ca.Function) -> None:
        name = fn.name()
        self._fn = getattr(lib, name)
        self._fn.restype = ctypes.c_int
        sizes = [ctypes.c_longlong() for _ in range(4)]
        work = getattr(lib, f"{name}_work")
        if work(*[ctypes.byref(v) for v in sizes]) != 0:
            raise RuntimeError(f"{name}_work failed")
        self._n_arg, self._n_res, self._n_iw, self._n_w = (int(v.value) for v in sizes)
        getattr(lib, f"{name}_incref")()
        self._in_shapes = [(fn.size1_in(i), fn.size2_in(i)) for i in range(fn.n_in())]
        self._out_shapes = [(fn.size1_out(i), fn.size2_out(i)) for i in range(fn.n_out())]
        self.name = name

    def __call__(self, *inputs: Any) -> tuple[NDArray[np.float64], ...]:
        arg = (ctypes.c_void_p * max(1, self._n_arg))()
        res = (ctypes.c_void_p * max(1, self._n_res))()
        keep = []
        for i, (value, (rows, cols)) in enumerate(zip(inputs, self._in_shapes, strict=True)):
            # CasADi stores column-major: an (rows, cols) matrix is a C-contiguous (cols, rows) array
            a = np.asarray(value, dtype=float)
            if a.shape != (rows, cols) and a.size != rows * cols:
                raise ValueError(f"{self.name}: input {i} has shape {a.shape}, expected ({rows}, {cols})")
            a = np.ascontiguousarray(a.T if a.ndim == 2 else a.reshape(cols, rows))
            keep.append(a)
            arg[i] = a.ctypes.data
        outs = [np.empty((cols, rows)) for rows, cols in self._out_shapes]
        for j, o in enumerate(outs):
            res[j] = o.ctypes.data
        iw = np.empty(max(1, self._n_iw), dtype=np.int64)
        w = np.empty(max(1, self._n_w))
        status = self._fn(arg, res, iw.ctypes.data_as(ctypes.c_void_p), w.ctypes.data_as(ctypes.c_void_p), 0)
        if status != 0:
            raise RuntimeError(f"{self.name} returned {status}")
        return tuple(o.T for o in outs)


def _compile(functions: Sequence[ca.Function], name: str) -> list[NumericFunction]:
    """Generate C for ``functions``, compile it into the cache (unless already there) and load it."""
    cc = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if not cc:
        raise OSError("no C compiler (cc/gcc) found")
    with tempfile.TemporaryDirectory(prefix="agvctl-cg-") as tmp:
        gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for f in functions:
            gen.add(f)
        gen.generate(tmp + os.sep)
        c_file = Path(tmp, f"{name}.c")
        source = c_file.read_bytes()
        key = hashlib.sha256(
            source
            + " ".join(_COMPILER_FLAGS).encode()
            + str(getattr(ca, "__version__", "")).encode()
            + sys.platform.encode()
        ).hexdigest()[:20]
        target = cache_dir() / f"{name}_{key}.so"
        if not target.exists():
            target.parent.mkdir(parents=True, exist_ok=True)
            fd, partial = tempfile.mkstemp(prefix=f".{name}_", suffix=".so", dir=target.parent)
            os.close(fd)
            try:
                cmd = [cc, *_COMPILER_FLAGS, "-o", partial, str(c_file), "-lm"]
                try:
                    subprocess.run([*cmd, "-fopenmp"], check=True, capture_output=True)
                except subprocess.CalledProcessError:
                    subprocess.run(cmd, check=True, capture_output=True)
                os.replace(partial, target)  # atomic: a concurrent process sees the whole library or none
            finally:
                if os.path.exists(partial):
                    os.unlink(partial)
    lib = ctypes.CDLL(str(target))
    return [_CCall(lib, f) for f in functions]


def native_functions(functions: Sequence[ca.Function], name: str) -> list[NumericFunction]:
    """``functions`` as callables on numpy arrays: compiled C (built once, then loaded from the cache), or
    CasADi's virtual machine if ``AGVCTL_NO_COMPILE`` is set or compiling fails (then with a warning).

    Parameters
    ----------
    functions
        The CasADi functions, generated together into one C file.
    name
        Stem of the C file and of the cached shared object (``<name>_<hash>.so``).
    """
    if os.environ.get("AGVCTL_NO_COMPILE", "") not in ("", "0"):
        return [_VmCall(f) for f in functions]
    try:
        return _compile(functions, name)
    except (OSError, subprocess.CalledProcessError, RuntimeError) as exc:
        warnings.warn(
            f"agvctl: compiling {name} failed ({exc}); using CasADi's virtual machine (about 10x slower)",
            RuntimeWarning,
            stacklevel=2,
        )
        return [_VmCall(f) for f in functions]
