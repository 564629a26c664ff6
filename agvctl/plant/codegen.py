"""CasADi functions as compiled C: code generation, the system C compiler, a disk cache, and calls through ctypes.

:func:`native_functions` generates C for a set of CasADi functions, compiles it once into a shared object kept
in :func:`cache_dir` (keyed by a hash of the generated code, the flags, CasADi's version and the platform, so a
changed model never loads a stale library) and returns callables on numpy arrays. Without a working C compiler,
or with ``AGVCTL_NO_COMPILE=1``, the same functions run in CasADi's virtual machine, about ten times slower; a
failed compilation says so with a :class:`RuntimeWarning`.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import casadi as ca
import numpy as np
from numpy.typing import NDArray

__all__ = ["CFunctionAddress", "NumericFunction", "c_compiler", "cache_dir", "compiled_library", "native_functions"]


class NumericFunction(Protocol):
    """A CasADi function evaluated on numpy arrays: compiled C called through ctypes, or CasADi's virtual machine."""

    @property
    def address(self) -> CFunctionAddress | None:
        """The compiled function, for C that calls it directly; None in the virtual machine."""

    def __call__(self, *inputs: Any) -> tuple[NDArray[np.float64], ...]:
        """The function's outputs at ``inputs`` (in its order), as 2-D arrays (rows × columns)."""


_COMPILER_FLAGS = ("-O2", "-fPIC", "-shared")


def cache_dir() -> Path:
    """Where compiled plant code is kept.

    Returns
    -------
    Path
        ``$AGVCTL_CACHE_DIR``, else ``$XDG_CACHE_HOME/agvctl``, else ``~/.cache/agvctl`` (not made here).
    """
    env = os.environ.get("AGVCTL_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "agvctl"


class _VmCall:
    """Evaluate a CasADi function in its virtual machine; outputs as 2-D numpy arrays."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn

    @property
    def address(self) -> None:
        """None: a function in the virtual machine has no address for C to call."""
        return None

    def __call__(self, *inputs: Any) -> tuple[NDArray[np.float64], ...]:
        return tuple(np.asarray(o, dtype=float) for o in self.fn.call(list(inputs)))


class _Buffers:
    """One thread's argument buffers for a compiled function: inputs, outputs and work arrays allocated once, with
    their addresses taken once (getting a numpy array's address costs more than a small call)."""

    def __init__(
        self,
        in_shapes: Sequence[tuple[int, int]],
        out_shapes: Sequence[tuple[int, int]],
        sizes: tuple[int, int, int, int],
    ) -> None:
        n_arg, n_res, n_iw, n_w = sizes
        # CasADi stores column-major: an (rows, cols) matrix is a C-contiguous (cols, rows) array
        self.inputs = [np.empty(rows * cols) for rows, cols in in_shapes]
        self.outputs = [np.empty((cols, rows)) for rows, cols in out_shapes]
        self.iw = np.empty(max(1, n_iw), dtype=np.int64)
        self.w = np.empty(max(1, n_w))
        self.input_addresses: list[ctypes.c_void_p | int | None] = [a.ctypes.data for a in self.inputs]
        self.output_addresses: list[ctypes.c_void_p | int | None] = [o.ctypes.data for o in self.outputs]
        # the generated code may use the slots past the inputs and outputs as scratch for nested calls
        self.arg = (ctypes.c_void_p * max(1, n_arg))()
        self.res = (ctypes.c_void_p * max(1, n_res))()
        self.iw_ptr = self.iw.ctypes.data_as(ctypes.c_void_p)
        self.w_ptr = self.w.ctypes.data_as(ctypes.c_void_p)


@dataclass(frozen=True)
class CFunctionAddress:
    """A compiled CasADi function, for C that calls it: ``int f(const double **arg, double **res, long long *iw,
    double *w, int mem)``.

    Parameters
    ----------
    address : int
        The function's address.
    sizes : tuple of int
        The lengths its ``arg``, ``res``, ``iw`` and ``w`` arrays must have.
    """

    address: int
    sizes: tuple[int, int, int, int]


class _CCall:
    """Call a function of CasADi-generated C code through ctypes, on numpy buffers.

    CasADi's own Python wrapper converts every output to a ``DM`` and back, which costs more than the
    integration for large batches; here inputs are copied into buffers allocated once per thread (the call
    releases the GIL, so threads may call at once), outputs written there and returned as copies.
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
        if self._n_arg < fn.n_in() or self._n_res < fn.n_out():
            raise RuntimeError(f"{name}: fewer argument slots than inputs or outputs")
        getattr(lib, f"{name}_incref")()
        self._in_shapes = [(fn.size1_in(i), fn.size2_in(i)) for i in range(fn.n_in())]
        self._out_shapes = [(fn.size1_out(i), fn.size2_out(i)) for i in range(fn.n_out())]
        self._local = threading.local()
        self.name = name

    @property
    def address(self) -> CFunctionAddress:
        """The function's address and work sizes, for C that calls it directly."""
        address = ctypes.cast(self._fn, ctypes.c_void_p).value
        assert address is not None
        return CFunctionAddress(address, (self._n_arg, self._n_res, self._n_iw, self._n_w))

    def _buffers(self) -> _Buffers:
        buffers: _Buffers | None = getattr(self._local, "buffers", None)
        if buffers is None:
            sizes = (self._n_arg, self._n_res, self._n_iw, self._n_w)
            buffers = _Buffers(self._in_shapes, self._out_shapes, sizes)
            self._local.buffers = buffers
        return buffers

    def __call__(self, *inputs: Any) -> tuple[NDArray[np.float64], ...]:
        buffers = self._buffers()
        for i, (value, (rows, cols), buffer) in enumerate(zip(inputs, self._in_shapes, buffers.inputs, strict=True)):
            a = np.asarray(value, dtype=float)
            if a.shape != (rows, cols) and a.size != rows * cols:
                raise ValueError(f"{self.name}: input {i} has shape {a.shape}, expected ({rows}, {cols})")
            buffer[:] = (a.T if a.ndim == 2 else a).reshape(-1)  # column-major: a matrix's columns one by one
        buffers.arg[: len(inputs)] = buffers.input_addresses
        buffers.res[: len(buffers.outputs)] = buffers.output_addresses
        status = self._fn(buffers.arg, buffers.res, buffers.iw_ptr, buffers.w_ptr, 0)
        if status != 0:
            raise RuntimeError(f"{self.name} returned {status}")
        return tuple(o.copy().T for o in buffers.outputs)


def c_double(value: float) -> str:
    """A double as a C literal that parses back to the same bits (Python's shortest round-trip repr).

    Parameters
    ----------
    value : float
        The number (finite or infinite).

    Returns
    -------
    str
        Its C literal (``INFINITY`` and ``-INFINITY`` from ``<math.h>`` for the infinities).

    Raises
    ------
    ValueError
        ``value`` is NaN.

    Examples
    --------
    >>> c_double(0.1), c_double(float("-inf"))
    ('0.1', '-INFINITY')
    """
    x = float(value)
    if math.isnan(x):
        raise ValueError("a NaN constant cannot be generated")
    if math.isinf(x):
        return "INFINITY" if x > 0 else "-INFINITY"
    return repr(x)


@functools.cache
def c_templates(package: str) -> Any:
    """The Jinja environment of the C templates in ``package``'s ``templates`` folder: an undefined name refused,
    the text rendered as written (no escaping, the last newline kept), and the filter ``c`` writing a double as a
    C literal of the same bits (:func:`c_double`). The shared templates of ``agvctl.plant`` can be included from any
    package's (``python_float.c.j2``: Python's and numpy's float arithmetic in C).

    Parameters
    ----------
    package : str
        The package that holds the ``templates`` folder (``"agvctl.controllers.pi"``).

    Returns
    -------
    jinja2.Environment
        The environment, one per package.
    """
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.ChoiceLoader(
            [jinja2.PackageLoader(package, "templates"), jinja2.PackageLoader("agvctl.plant", "templates")]
        ),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["c"] = c_double
    return env


def c_compiler() -> str | None:
    """The system C compiler: ``$CC``, else ``cc``, else ``gcc`` on the path.

    Returns
    -------
    str or None
        Its command, or None when there is none.
    """
    return os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")


_LIBRARIES: dict[Path, ctypes.CDLL] = {}
_LIBRARIES_LOCK = threading.Lock()


def compiled_library(
    source: str | bytes | Mapping[str, str | bytes],
    name: str,
    *,
    flags: Sequence[str] = _COMPILER_FLAGS,
    try_openmp: bool = False,
    key: str = "",
) -> ctypes.CDLL:
    """C source compiled into a shared object in :func:`cache_dir` (unless already there) and loaded.

    The library's name carries a hash of the source, the flags, ``key`` and the platform, so a changed source never
    loads a stale library; it is compiled into a temporary file beside its place and moved there atomically, so
    processes that compile the same source at once each see the whole library or none. A process loads each
    library once.

    Parameters
    ----------
    source : str, bytes or mapping of str to str or bytes
        The C file's text (UTF-8); or a source tree, ``{relative path: text}``, whose ``.c`` files are compiled
        together, each folder that holds a ``.h`` file on the include path.
    name : str
        Stem of the C file and of the cached shared object (``<name>_<hash>.so``).
    flags : sequence of str
        The compiler's flags; they must make a shared object (``-fPIC -shared``).
    try_openmp : bool
        Compile with ``-fopenmp`` first, and without it if that fails.
    key : str
        More text the cache key depends on (the version of the generator that wrote the source).

    Returns
    -------
    ctypes.CDLL
        The loaded library.

    Raises
    ------
    OSError
        No C compiler, or the library cannot be written or loaded.
    subprocess.CalledProcessError
        The compiler refused the source (its messages in ``stderr``).
    """
    cc = c_compiler()
    if not cc:
        raise OSError("no C compiler (cc/gcc) found")
    files = _source_tree(source, name)
    if isinstance(source, Mapping):
        data = b"".join(path.encode() + b"\0" + text + b"\0" for path, text in sorted(files.items()))
    else:
        data = files[f"{name}.c"]  # one file: the key it always had
    digest = hashlib.sha256(
        data + " ".join(flags).encode() + str(try_openmp).encode() + key.encode() + sys.platform.encode()
    ).hexdigest()[:20]
    target = cache_dir() / f"{name}_{digest}.so"
    with _LIBRARIES_LOCK:
        lib = _LIBRARIES.get(target)
        if lib is not None:
            return lib
        if not target.exists():
            target.parent.mkdir(parents=True, exist_ok=True)
            _build(cc, files, flags, try_openmp, target)
        lib = ctypes.CDLL(str(target))
        _LIBRARIES[target] = lib
        return lib


def _build(cc: str, files: Mapping[str, bytes], flags: Sequence[str], try_openmp: bool, target: Path) -> None:
    """Compile ``files``' C sources into ``target``: in a temporary folder, linked beside ``target``, moved in."""
    with tempfile.TemporaryDirectory(prefix="agvctl-cg-") as tmp:
        for path, text in files.items():
            Path(tmp, path).parent.mkdir(parents=True, exist_ok=True)
            Path(tmp, path).write_bytes(text)
        includes = sorted({f"-I{Path(tmp, path).parent}" for path in files if path.endswith(".h")})
        c_files = [str(Path(tmp, path)) for path in sorted(files) if path.endswith(".c")]
        fd, partial = tempfile.mkstemp(prefix=f".{target.stem}_", suffix=".so", dir=target.parent)
        os.close(fd)
        try:
            cmd = [cc, *flags, *includes, "-o", partial, *c_files, "-lm"]
            try:
                subprocess.run([*cmd, "-fopenmp"] if try_openmp else cmd, check=True, capture_output=True)
            except subprocess.CalledProcessError:
                if not try_openmp:
                    raise
                subprocess.run(cmd, check=True, capture_output=True)
            os.replace(partial, target)  # atomic: a concurrent process sees the whole library or none
        finally:
            if os.path.exists(partial):
                os.unlink(partial)


def _source_tree(source: str | bytes | Mapping[str, str | bytes], name: str) -> dict[str, bytes]:
    """``{relative path: bytes}`` of ``source`` (one text: ``<name>.c``); a path that leaves its folder is refused."""
    tree = source if isinstance(source, Mapping) else {f"{name}.c": source}
    files: dict[str, bytes] = {}
    for path, text in tree.items():
        parts = Path(path).parts
        if not parts or Path(path).is_absolute() or ".." in parts:
            raise ValueError(f"compiled_library: {path!r} is not a path inside the source tree")
        files[Path(path).as_posix()] = text.encode("utf-8") if isinstance(text, str) else text
    return files


def _compile(functions: Sequence[ca.Function], name: str) -> list[NumericFunction]:
    """Generate C for ``functions``, compile it into the cache (unless already there) and load it."""
    with tempfile.TemporaryDirectory(prefix="agvctl-cg-") as tmp:
        gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for f in functions:
            gen.add(f)
        gen.generate(tmp + os.sep)
        source = Path(tmp, f"{name}.c").read_bytes()
    lib = compiled_library(source, name, try_openmp=True, key=str(getattr(ca, "__version__", "")))
    return [_CCall(lib, f) for f in functions]


def native_functions(functions: Sequence[ca.Function], name: str) -> list[NumericFunction]:
    """``functions`` as callables on numpy arrays: compiled C (built once, then loaded from the cache), or
    CasADi's virtual machine if ``AGVCTL_NO_COMPILE`` is set or compiling fails (then with a warning).

    Parameters
    ----------
    functions : sequence of casadi.Function
        The CasADi functions, generated together into one C file.
    name : str
        Stem of the C file and of the cached shared object (``<name>_<hash>.so``).

    Returns
    -------
    list of NumericFunction
        One callable per function, in their order: inputs as numpy arrays, outputs as 2-D arrays.

    Warns
    -----
    RuntimeWarning
        When compiling fails and the functions run in CasADi's virtual machine instead.
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
