"""The fields of agvctl's frozen dataclasses: bounds, checks and documentation, each declared once with the field.

:func:`number` declares a numeric field's bounds and description; :func:`check_fields` checks a dataclass made in
Python as the loader checks a file; :func:`document_fields` writes the numpydoc ``Parameters`` section of a
dataclass's docstring from its fields, so a field is described where it is declared and nowhere else.
"""

from __future__ import annotations

import ast
import contextlib
import dataclasses
import functools
import inspect
import math
import numbers
import re
import textwrap
import types
import typing
from collections.abc import Mapping
from typing import Any, Literal, TypeVar, Union, get_args, get_origin, get_type_hints

from agvctl.errors import ConfigError

__all__ = ["check_fields", "class_type_hints", "document_fields", "number"]

T = TypeVar("T")


def number(
    *,
    gt: float | None = None,
    ge: float | None = None,
    le: float | None = None,
    default: Any = dataclasses.MISSING,
    doc: str = "",
) -> Any:
    """A dataclass field holding a finite number with optional bounds.

    The loader (:func:`~agvctl.config.build`) and :func:`check_fields` refuse a value outside the bounds with a
    one-line :class:`~agvctl.errors.ConfigError`; :func:`document_fields` shows the bounds and ``doc``.

    Parameters
    ----------
    gt : float or None
        The value must be strictly greater than this (None: no such bound).
    ge : float or None
        The value must be greater than or equal to this.
    le : float or None
        The value must be less than or equal to this.
    default : object
        The field's default; without one the field is required.
    doc : str
        The field's description, in the unit of its name (``"Wheel radius r, m."``); without one,
        :func:`document_fields` takes the docstring written under the field.

    Returns
    -------
    dataclasses.Field
        The field, its bounds and ``doc`` in its metadata.
    """
    metadata = {"gt": gt, "ge": ge, "le": le, "doc": doc}
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def document_fields(cls: type[T]) -> type[T]:
    """Complete a dataclass's docstring with a numpydoc ``Parameters`` section made from its fields.

    Each field the constructor takes is one entry: its name, its annotation (a ``Literal`` as its set of choices),
    the bounds of a :func:`number` field, its default, and its description: the field's ``doc`` (:func:`number`'s
    argument), else the docstring written under the field. A field is so described once, where it is declared, and
    ``help()``, Sphinx and numpydoc read the complete docstring. The section goes before the docstring's first
    section, and is made when the docstring is first read (it parses the class's source), not at import.

    Parameters
    ----------
    cls : type
        A dataclass whose docstring has no ``Parameters`` section; apply the decorator above ``@dataclass``.

    Returns
    -------
    type
        ``cls``, whose ``__doc__`` now includes the section.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @document_fields
    ... @dataclass(frozen=True)
    ... class Wheel:
    ...     '''One driving wheel.'''
    ...
    ...     radius_m: float = number(gt=0, doc="Its radius r, m.")
    ...     tolerance: float = number(ge=0, le=0.2, default=0.01, doc="Relative half-width of its range.")
    >>> print(Wheel.__doc__)
    One driving wheel.
    <BLANKLINE>
    Parameters
    ----------
    radius_m : float > 0
        Its radius r, m.
    tolerance : float in [0, 0.2], default 0.01
        Relative half-width of its range.
    """
    cls.__doc__ = typing.cast(str, _FieldsDocstring(cls))  # a descriptor: the class's __doc__ calls it when read
    return cls


class _FieldsDocstring:
    """The docstring of a :func:`document_fields` class, made the first time it is read."""

    def __init__(self, cls: type) -> None:
        self._cls = cls
        self._head = inspect.cleandoc(cls.__doc__ or "")
        self._text: str | None = None

    def __get__(self, obj: object, owner: type | None = None) -> str:
        if self._text is None:
            section = _parameters_section(self._cls)
            first = re.search(r"^\S.*\n-{3,}$", self._head, flags=re.MULTILINE)  # the first section's header
            at = first.start() if first else len(self._head)
            self._text = f"{self._head[:at].rstrip()}\n\n{section}\n\n{self._head[at:]}".strip()
        return self._text


def _parameters_section(cls: type) -> str:
    docstrings: dict[str, str] = {}
    for base in reversed(cls.__mro__):  # a field declared in a base dataclass is described there
        if dataclasses.is_dataclass(base):
            docstrings.update(_field_docstrings(base))
    try:
        hints = get_type_hints(cls)
    except (NameError, TypeError):  # an annotation imported for type checking only: show them as written
        hints = {}
    entries = ["Parameters", "----------"]
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        kind = hints.get(f.name)
        shown = (
            "{" + ", ".join(repr(c) for c in get_args(kind)) + "}"
            if get_origin(kind) is Literal
            else _ARRAYS.sub(_array, f.type)
            if isinstance(f.type, str)
            else getattr(f.type, "__name__", str(f.type))
        )
        entries.append(f"{f.name} : {shown}{_bounds(f.metadata)}{_default(f)}")
        description = f.metadata.get("doc") or docstrings.get(f.name, "")
        entries.append(textwrap.indent(description, "    "))
    return "\n".join(entries)


_ARRAYS = re.compile(r"NDArray\[np\.(\w+)\]|FloatArray|np\.ndarray")


def _array(match: re.Match[str]) -> str:
    """A numpy array annotation as numpydoc writes its type: ``ndarray``, ``ndarray of int`` or ``of bool``."""
    dtype = match.group(1) or "float64"
    return "ndarray" if dtype.startswith("float") else f"ndarray of {dtype.rstrip('_0123456789')}"


def _field_docstrings(cls: type) -> dict[str, str]:
    """The docstrings written under a class's fields (none if its source cannot be read)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):
        return {}
    body = typing.cast(ast.ClassDef, tree.body[0]).body
    return {
        a.target.id: inspect.cleandoc(b.value.value)
        for a, b in zip(body, body[1:], strict=False)
        if isinstance(a, ast.AnnAssign)
        and isinstance(a.target, ast.Name)
        and isinstance(b, ast.Expr)
        and isinstance(b.value, ast.Constant)
        and isinstance(b.value.value, str)
    }


def _bounds(meta: Mapping[str, Any]) -> str:
    gt, ge, le = meta.get("gt"), meta.get("ge"), meta.get("le")
    low = f"[{ge:g}" if ge is not None else f"({gt:g}" if gt is not None else None
    if low is not None and le is not None:
        return f" in {low}, {le:g}]"
    if low is not None:
        return f" > {gt:g}" if ge is None else f" ≥ {ge:g}"
    return f" ≤ {le:g}" if le is not None else ""


def _default(f: dataclasses.Field[Any]) -> str:
    if f.default is dataclasses.MISSING:
        return ", optional" if f.default_factory is not dataclasses.MISSING else ""
    if f.default is None or isinstance(f.default, (bool, int, float, str)):
        return f", default {f.default:g}" if isinstance(f.default, float) else f", default {f.default!r}"
    return ", optional"


def _type_name(tp: Any) -> str:
    if tp is float:
        return "a number"
    if tp is int:
        return "an integer"
    if tp is str:
        return "a string"
    if tp is bool:
        return "true or false"
    if dataclasses.is_dataclass(tp):
        return "a table"
    return str(tp)


def _check_bounds(value: float, meta: Mapping[str, Any] | None, source: str, key: str) -> None:
    if not meta:
        return
    gt, ge, le = meta.get("gt"), meta.get("ge"), meta.get("le")
    if gt is not None and not value > gt:
        raise ConfigError(source, key, f"must be > {gt:g} (got {value:g})")
    if ge is not None and not value >= ge:
        raise ConfigError(source, key, f"must be >= {ge:g} (got {value:g})")
    if le is not None and not value <= le:
        raise ConfigError(source, key, f"must be <= {le:g} (got {value:g})")


@functools.cache
def class_type_hints(cls: type) -> Mapping[str, Any]:
    """A dataclass's fields' types, their annotations evaluated (``typing.get_type_hints``), once per class: a file's
    every table is built through them, and evaluating them costs more than the building.

    Parameters
    ----------
    cls : type
        The class.

    Returns
    -------
    Mapping
        ``{attribute: type}``, read-only.
    """
    return types.MappingProxyType(get_type_hints(cls))


_INIT_FIELDS: dict[type, tuple[tuple[str, Any, Mapping[str, Any]], ...]] = {}


def _init_fields(cls: type) -> tuple[tuple[str, Any, Mapping[str, Any]], ...]:
    """``(name, type, metadata)`` of each field a dataclass's constructor takes (worked out once per class)."""
    if cls not in _INIT_FIELDS:
        hints = class_type_hints(cls)
        _INIT_FIELDS[cls] = tuple((f.name, hints[f.name], f.metadata) for f in dataclasses.fields(cls) if f.init)
    return _INIT_FIELDS[cls]


def _check_argument(tp: Any, value: Any, source: str, key: str, meta: Mapping[str, Any]) -> None:
    origin = get_origin(tp)
    if origin in (Union, types.UnionType):
        if value is None and type(None) in get_args(tp):
            return
        args = [a for a in get_args(tp) if a is not type(None)]
        for arg in args[:-1]:
            with contextlib.suppress(ConfigError):
                _check_argument(arg, value, source, key, meta)
                return
        _check_argument(args[-1], value, source, key, meta)
    elif origin is Literal:
        if value not in get_args(tp):
            choices = ", ".join(repr(c) for c in get_args(tp))
            raise ConfigError(source, key, f"must be one of {choices} (got {value!r})")
    elif tp is float:
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ConfigError(source, key, f"expected a number (got {value!r})")
        if not math.isfinite(value):
            raise ConfigError(source, key, f"must be finite (got {value})")
        _check_bounds(float(value), meta, source, key)
    elif tp is int:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise ConfigError(source, key, f"expected an integer (got {value!r})")
        _check_bounds(int(value), meta, source, key)
    elif tp in (str, bool) and not isinstance(value, tp):
        raise ConfigError(source, key, f"expected {_type_name(tp)} (got {value!r})")
    elif origin in (tuple, list, dict):
        _check_items(origin, get_args(tp), value, source, key)
    elif isinstance(tp, type) and dataclasses.is_dataclass(tp) and not isinstance(value, tp):
        raise ConfigError(source, key, f"expected a {tp.__name__} (got {value!r})")


def _check_items(origin: Any, args: tuple[Any, ...], value: Any, source: str, key: str) -> None:
    """A tuple, list or dict argument: its container kind, its length when fixed, and each item's type."""
    if origin is dict:
        if not isinstance(value, Mapping):
            raise ConfigError(source, key, f"expected a mapping (got {value!r})")
        for k, v in value.items():
            _check_argument(args[0], k, source, key, {})
            _check_argument(args[1], v, source, f"{key}.{k}", {})
        return
    if not isinstance(value, (tuple, list)):
        raise ConfigError(source, key, f"expected a tuple or list (got {value!r})")
    fixed = origin is tuple and args[-1] is not Ellipsis
    if fixed and len(value) != len(args):
        raise ConfigError(source, key, f"expected {len(args)} items (got {len(value)})")
    for i, v in enumerate(value):
        _check_argument(args[i] if fixed else args[0], v, source, f"{key}[{i}]", {})


def check_fields(obj: Any) -> None:
    """Check the fields of a dataclass made in Python as :func:`~agvctl.config.build` checks a file's.

    Numbers must be finite and within their :func:`number` bounds, integers whole, choices among their ``Literal``
    values, strings and booleans of their type, tuples, lists and dicts right item by item; a nested dataclass
    must be one (it checks itself). A dataclass calls it from ``__post_init__``.

    Parameters
    ----------
    obj : object
        The dataclass instance to check.

    Raises
    ------
    ConfigError
        ``"<Class>: <argument>: <problem>"``, e.g. ``LineSegment: length_m: must be finite (got nan)``.
    """
    source = type(obj).__name__
    for name, tp, meta in _init_fields(type(obj)):
        _check_argument(tp, getattr(obj, name), source, name, meta)
