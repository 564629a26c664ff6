"""Names in files that stand for code: a registry's built-in entries, installed entry points and import references.

A file names a controller or an estimator by a string, resolved in this order by :class:`Registry`:

1. a built-in name of the registry's table (``"mpc"``);
2. the name of an installed package's entry point in the registry's group (``"pure_pursuit"``, registered under
   ``[project.entry-points."agvctl.pose_controllers"]``, as pytest and Sphinx find their plug-ins);
3. an import reference in Python's entry-point syntax, ``"package.module:Name"`` (as Gymnasium's ``entry_point``),
   or a file relative to the file that names it, ``"controllers/mine.py:Name"``.

Every process resolves the string itself: what travels to a worker process or a Dask worker is the string (in the
file it reads), never the object it stands for, so every worker builds the same thing from the same file. Naming a
module or a file runs its code, as importing it does.

A reference that cannot be used — a module that does not import, a name that is not in it, an object the registry
refuses — is a :class:`~agvctl.errors.ConfigError` naming the file, the key and the reference.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import re
import sys
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from agvctl.config.loading import did_you_mean
from agvctl.errors import ConfigError, exception_line

__all__ = [
    "Registry",
    "absolute_reference",
    "checked_vector",
    "describe_plugin",
    "is_reference",
    "load_reference",
    "made_by",
    "plain_label",
    "plugin_settings",
    "reference_file",
]

K = TypeVar("K")

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def is_reference(text: str) -> bool:
    """Whether ``text`` is an import reference (``module:Name`` or ``file.py:Name``) rather than a name.

    Parameters
    ----------
    text : str
        A value from a file.

    Returns
    -------
    bool
        True when it holds a ``:`` (a name never does).
    """
    return ":" in text


def reference_file(text: str, base_dir: Path) -> Path | None:
    """The Python file a file reference (``"controllers/mine.py:Name"``) names, made absolute against ``base_dir``;
    None for a name or a module reference.

    Parameters
    ----------
    text : str
        A name or a reference.
    base_dir : Path
        The folder of the file that names it.

    Returns
    -------
    Path or None
        The file, absolute.
    """
    where = text.partition(":")[0].strip()
    if not is_reference(text) or not _is_file(where):
        return None
    path = Path(where)
    return (path if path.is_absolute() else base_dir / path).resolve()


def _is_file(where: str) -> bool:
    return where.endswith(".py") or "/" in where or "\\" in where


def absolute_reference(text: str, base_dir: Path) -> str:
    """``text`` with a file reference's file made absolute (a name or a module reference as it is), for a file
    written elsewhere that must name the same code.

    Parameters
    ----------
    text : str
        A name or a reference.
    base_dir : Path
        The folder of the file that names it.

    Returns
    -------
    str
        The reference, usable from any folder.
    """
    file = reference_file(text, base_dir)
    return text if file is None else f"{file.as_posix()}:{text.partition(':')[2].strip()}"


def plain_label(text: str) -> str:
    """``text`` as a plain file-name part: runs of characters other than letters, digits, ``_``, ``.`` and ``-``
    become one ``_`` (``"controllers/pp.py:PurePursuit"`` → ``"controllers_pp.py_PurePursuit"``).

    Parameters
    ----------
    text : str
        A name or a reference.

    Returns
    -------
    str
        The label; a name is its own label.
    """
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "_"


def checked_vector(value: Any, size: int, who: str) -> NDArray[np.float64]:
    """What a user's code returned, as a vector of ``size`` finite floats, or a one-line error naming ``who``.

    Parameters
    ----------
    value : object
        The returned value.
    size : int
        How many numbers it must hold.
    who : str
        The code, as the error names it (``pose estimator 'pkg.mod:Mine'``).

    Returns
    -------
    ndarray
        ``value`` as a float array of shape ``(size,)``.

    Raises
    ------
    TypeError
        Not an array of numbers of that shape (its type and shape named).
    ValueError
        A value that is not finite.
    """
    if isinstance(value, np.ndarray) and value.dtype == np.float64 and value.shape == (size,):
        array = value
    else:
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise TypeError(f"{who} returned a {type(value).__name__}, not {size} numbers") from None
        if array.shape != (size,):
            raise TypeError(f"{who} returned a {type(value).__name__} of shape {array.shape}, expected ({size},)")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{who} returned non-finite values {array.tolist()}")
    return array


def describe_plugin(obj: Any, name: str) -> str:
    """The first line of a user's object's docstring (its name if it has none), for listings.

    Parameters
    ----------
    obj : object
        The class or factory.
    name : str
        Its name or reference.

    Returns
    -------
    str
        One line.
    """
    doc = (inspect.getdoc(obj) or "").strip()
    return doc.splitlines()[0] if doc else name


def plugin_settings(obj: Any, methods: tuple[str, ...], protocol: str) -> type | None:
    """The ``Settings`` dataclass of a user's class or factory (None if it has none), the object checked first.

    Parameters
    ----------
    obj : object
        What a reference names.
    methods : tuple of str
        The methods of the protocol its instances satisfy (checked on a class; a factory's product is checked when
        made, :func:`made_by`).
    protocol : str
        The protocol's name, for messages.

    Returns
    -------
    type or None
        Its ``Settings`` attribute, a dataclass.

    Raises
    ------
    TypeError
        Not callable, not callable as ``Name(vehicle, settings)``, a class without the protocol's methods, or a
        ``Settings`` that is not a dataclass.
    """
    if not callable(obj):
        raise TypeError(f"a {type(obj).__name__}, not a class or a factory called as Name(vehicle, settings)")
    if isinstance(obj, type):
        missing = [m for m in methods if not callable(getattr(obj, m, None))]
        if missing:
            raise TypeError(f"the class has no {', '.join(m + '()' for m in missing)} of the {protocol} protocol")
    try:
        signature: inspect.Signature | None = inspect.signature(obj)
    except (TypeError, ValueError):  # no signature to read (a builtin): called and judged at run time
        signature = None
    if signature is not None:
        try:
            signature.bind(None, None)
        except TypeError as exc:
            raise TypeError(f"cannot be called as Name(vehicle, settings): {exc}") from None
    settings = getattr(obj, "Settings", None)
    if settings is not None and not (isinstance(settings, type) and dataclasses.is_dataclass(settings)):
        raise TypeError(f"its Settings is a {type(settings).__name__}, not a dataclass")
    return settings


def made_by(make: Callable[[Any, Any], Any], vehicle: Any, settings: Any, name: str, methods: tuple[str, ...]) -> Any:
    """``make(vehicle, settings)``, refused unless what it makes has the protocol's methods.

    Parameters
    ----------
    make : callable
        A user's class or factory.
    vehicle : VehicleParams
        The controller's vehicle.
    settings : object
        Its settings (None without a ``Settings``).
    name : str
        Its name or reference, for the error.
    methods : tuple of str
        The protocol's methods.

    Returns
    -------
    object
        What ``make`` made.

    Raises
    ------
    TypeError
        What it made has not every method.
    """
    made = make(vehicle, settings)
    missing = [m for m in methods if not callable(getattr(made, m, None))]
    if missing:
        raise TypeError(f"{name!r} made a {type(made).__name__} without {', '.join(m + '()' for m in missing)}")
    return made


class _Unusable(Exception):
    """Why a reference cannot be used, in words (turned into a one-line ConfigError by the registry)."""


def _module_from_file(path: Path) -> Any:
    """The module of a Python file, imported once per process under a name made from its resolved path."""
    resolved = path.resolve()
    digest = hashlib.sha1(str(resolved).encode()).hexdigest()[:12]
    name = f"agvctl_user_{re.sub(r'[^A-Za-z0-9_]', '_', resolved.stem)}_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    if not resolved.is_file():
        raise _Unusable(f"file not found: {resolved}")
    spec = importlib.util.spec_from_file_location(name, resolved)
    if spec is None or spec.loader is None:
        raise _Unusable(f"not a Python file: {resolved}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def load_reference(reference: str, base_dir: Path | None = None) -> Any:
    """The object an import reference names, its module imported (once per process).

    Parameters
    ----------
    reference : str
        ``"package.module:Name"`` (``Name`` may be dotted, ``Outer.Inner``), or ``"path/to/file.py:Name"``.
    base_dir : Path or None
        What a relative file is relative to (the folder of the file that names it); None: the working folder.

    Returns
    -------
    object
        The named object.

    Raises
    ------
    ConfigError
        ``<reference>: <problem>``: not of the form ``module:Name``, a module that does not import (its error in
        one line), a name that is not in it.
    """
    try:
        return _load(reference, base_dir)
    except _Unusable as exc:
        raise ConfigError(reference, "", str(exc)) from None


def _load(reference: str, base_dir: Path | None) -> Any:
    where, _, attr = reference.partition(":")
    where, attr = where.strip(), attr.strip()
    parts = attr.split(".")
    if not where or not all(_IDENTIFIER.fullmatch(p) for p in parts):
        raise _Unusable("expected package.module:Name or path/to/file.py:Name")
    is_file = _is_file(where)
    if not is_file and not all(_IDENTIFIER.fullmatch(p) for p in where.split(".")):
        raise _Unusable(f"{where!r} is neither a module name nor a .py file")
    try:
        if is_file:
            path = Path(where)
            module = _module_from_file(path if path.is_absolute() or base_dir is None else base_dir / path)
        else:
            module = importlib.import_module(where)
    except _Unusable:
        raise
    except ImportError as exc:  # a module not found: where it was looked for is importlib's, not the user's
        raise _Unusable(f"cannot import {where!r}: {type(exc).__name__}: {exc}") from None
    except Exception as exc:  # the user's module: any error it raises on import is the reference's problem
        raise _Unusable(f"cannot import {where!r}: {exception_line(exc)}") from None
    obj: Any = module
    for depth, part in enumerate(parts):
        if not hasattr(obj, part):
            inside = where if depth == 0 else f"{where}:{'.'.join(parts[:depth])}"
            known = [n for n in dir(obj) if not n.startswith("_")]
            raise _Unusable(f"{inside!r} has no {part!r}" + did_you_mean(part, known, []))
        obj = getattr(obj, part)
    return obj


@functools.lru_cache(maxsize=32)
def _entry_points(group: str, path: tuple[str, ...]) -> dict[str, str]:
    """The installed entry points of ``group``, name → reference (looked up again when ``sys.path`` changes)."""
    del path  # the cache key: importlib.metadata finds distributions on sys.path
    return {ep.name: ep.value for ep in importlib.metadata.entry_points(group=group)}


class Registry(Generic[K]):
    """Names and references → entries (``K``): the built-in table, then the installed entry points of ``group``,
    then import references (see the module notes). Every entry, built-in or not, is used through :meth:`resolve`.

    Parameters
    ----------
    group : str
        The entry-point group installed packages register names in (``agvctl.pose_controllers``).
    what : str
        What an entry is, for messages (``a pose controller``).
    builtins : Mapping
        The built-in entries by name; read at each lookup, so an entry added in Python is found too.
    from_object : callable
        ``from_object(obj, reference)``: the entry for an object an entry point or a reference names; raises
        :class:`ValueError` or :class:`TypeError` with the problem in words if the object cannot be one.
    """

    def __init__(self, group: str, what: str, builtins: Mapping[str, K], from_object: Callable[[Any, str], K]) -> None:
        self.group = group
        self.what = what
        self.builtins = builtins
        self.from_object = from_object

    def installed(self) -> dict[str, str]:
        """The names installed packages register in the group, each with its reference."""
        return dict(_entry_points(self.group, tuple(sys.path)))

    def names(self) -> list[str]:
        """The built-in names, then the installed ones."""
        return [*self.builtins, *(n for n in self.installed() if n not in self.builtins)]

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (name in self.builtins or name in self.installed())

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def resolve(self, name: str, *, source: str, key: str, base_dir: Path | None = None) -> K:
        """The entry ``name`` stands for.

        Parameters
        ----------
        name : str
            A built-in name, an installed entry point's name, or an import reference.
        source : str
            The file (or option) that names it, for errors.
        key : str
            The key that names it, for errors.
        base_dir : Path or None
            What a file reference is relative to (default: the folder of ``source``).

        Returns
        -------
        K
            The entry.

        Raises
        ------
        ConfigError
            ``<source>: <key>: <reference>: <problem>``, or, for an unknown name, the names there are.
        """
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(source, key, f"expected a name or a reference package.module:Name (got {name!r})")
        if name in self.builtins:
            return self.builtins[name]
        installed = self.installed()
        if not is_reference(name) and name not in installed:
            names = ", ".join(map(repr, self.names()))
            raise ConfigError(
                source,
                key,
                f"must be one of {names} or a reference package.module:Name (got {name!r})"
                + did_you_mean(name, self.names(), []),
            )
        reference = installed.get(name, name)
        shown = name if reference == name else f"{name} = {reference}"
        try:
            return self.from_object(_load(reference, Path(source).parent if base_dir is None else base_dir), name)
        except _Unusable as exc:
            raise ConfigError(source, key, f"{shown}: {exc}") from None
        except (TypeError, ValueError) as exc:
            raise ConfigError(source, key, f"{shown}: not {self.what}: {exc}") from None
