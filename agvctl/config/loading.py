"""Building frozen dataclasses from a file's tables, field by field, with one-line errors naming file and key."""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math
import types
import typing
from collections.abc import Iterable, Iterator, Mapping
from typing import Any, Literal, TypeVar, Union, get_args, get_origin

from agvctl.config.fields import _check_bounds, class_type_hints
from agvctl.errors import ConfigError

__all__ = [
    "as_file_error",
    "build",
    "build_fields",
    "convert_value",
    "did_you_mean",
    "join_key",
    "renamed",
]

T = TypeVar("T")


def renamed(new_key: str) -> str:
    """The problem of a key that has a new name.

    Parameters
    ----------
    new_key : str
        The key's new dotted name.

    Returns
    -------
    str
        ``"renamed; use <new_key>"``.
    """
    return f"renamed; use {new_key}"


def did_you_mean(word: str, choices: Iterable[str], prefix: list[str]) -> str:
    """The hint an unknown key's message ends with: the closest of the keys it may have meant.

    Parameters
    ----------
    word : str
        The misspelt key.
    choices : iterable of str
        The keys allowed in its place.
    prefix : list of str
        The table the key is in, as its dotted parts.

    Returns
    -------
    str
        ``" (did you mean a.b.c?)"``, or ``""`` if no key is close.

    Examples
    --------
    >>> did_you_mean("radius", ["radius_m", "separation_m"], ["wheels"])
    ' (did you mean wheels.radius_m?)'
    """
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    if not close:
        return ""
    return f" (did you mean {'.'.join([*prefix, close[0]])}?)"


def join_key(prefix: str, key: str) -> str:
    """The dotted path of a key in a table, as error messages name it.

    Parameters
    ----------
    prefix : str
        The table's dotted path (``""`` at the top level).
    key : str
        The key in it.

    Returns
    -------
    str
        ``prefix.key``, or ``key`` at the top level.
    """
    return f"{prefix}.{key}" if prefix else key


def build(cls: type[T], data: Any, *, source: str, prefix: str = "") -> T:
    """Build a dataclass from a file's tables strictly: unknown, missing and ill-typed keys are refused.

    Parameters
    ----------
    cls : type
        The dataclass (its fields typed, numbers declared with :func:`~agvctl.config.number`).
    data : object
        The table, as :func:`~agvctl.config.load_toml` reads it.
    source : str
        What errors name as the file.
    prefix : str
        The table's dotted path in the file (``""``: the whole file).

    Returns
    -------
    object
        The instance of ``cls``.

    Raises
    ------
    ConfigError
        ``"<source>: <key.path>: <problem>"``: an unknown key (with a "did you mean"), a missing key, a value of
        the wrong type or out of its bounds.
    """
    value = convert_value(cls, data, source, prefix)
    return typing.cast(T, value)


def _describe(value: Any) -> str:
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, str):
        return f"the string {value!r}"
    return repr(value)


def convert_value(tp: Any, value: Any, source: str, key: str, meta: Mapping[str, Any] | None = None) -> Any:
    """Check and convert one value from a file to a type.

    Parameters
    ----------
    tp : type
        The type: a number, string or boolean, a ``Literal``, a union, a tuple or list, or a dataclass.
    value : object
        The value as TOML reads it.
    source : str
        What errors name as the file.
    key : str
        The value's dotted key.
    meta : Mapping or None
        The field's metadata: the bounds of a :func:`~agvctl.config.number` field.

    Returns
    -------
    object
        The value as ``tp`` (an integer as a float where a number is expected, an array as a tuple).

    Raises
    ------
    ConfigError
        A value of the wrong type, not finite, or out of its bounds.
    """
    origin = get_origin(tp)
    if origin in (Union, types.UnionType):
        args = [a for a in get_args(tp) if a is not type(None)]
        if value is None:
            return None
        last: ConfigError | None = None
        for arg in args:
            try:
                return convert_value(arg, value, source, key, meta)
            except ConfigError as exc:
                last = exc
        assert last is not None
        raise last
    if origin is Literal:
        choices = get_args(tp)
        if value not in choices:
            raise ConfigError(
                source, key, f"must be one of {', '.join(repr(c) for c in choices)} (got {_describe(value)})"
            )
        return value
    if origin in (tuple, list):
        (item_tp, *_rest) = get_args(tp)
        if not isinstance(value, list):
            raise ConfigError(source, key, f"expected an array (got {_describe(value)})")
        items = [convert_value(item_tp, v, source, f"{key}[{i}]") for i, v in enumerate(value)]
        return tuple(items) if origin is tuple else items
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if not isinstance(value, Mapping):
            raise ConfigError(source, key, f"expected a table (got {_describe(value)})")
        return _build_dataclass(tp, value, source, key)
    return _convert_scalar(tp, value, source, key, meta)


def _convert_scalar(tp: Any, value: Any, source: str, key: str, meta: Mapping[str, Any] | None) -> Any:
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(source, key, f"expected a number (got {_describe(value)})")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(source, key, f"must be finite (got {value})")
        _check_bounds(value, meta, source, key)
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(source, key, f"expected an integer (got {_describe(value)})")
        _check_bounds(value, meta, source, key)
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(source, key, f"expected a string (got {_describe(value)})")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(source, key, f"expected true or false (got {_describe(value)})")
        return value
    if tp is Any:
        return value
    raise TypeError(f"config: unsupported field type {tp!r} at {key}")  # a programming error, not user input


@contextlib.contextmanager
def as_file_error(cls: type, source: str, prefix: str) -> Iterator[None]:
    """Re-raise a :class:`~agvctl.errors.ConfigError` a constructor names after its class as the file's.

    A check made in Python (``"FuzzSpec: seed: …"``) so reads, from a file, like the loader's own
    (``"fuzz.toml: seed: …"``).

    Parameters
    ----------
    cls : type
        The class whose constructor runs in the block.
    source : str
        The file.
    prefix : str
        The dotted path of the class's table in the file.

    Yields
    ------
    None
        Run the constructor in the block.

    Raises
    ------
    ConfigError
        The constructor's, naming ``source`` and the key under ``prefix``.
    """
    try:
        yield
    except ConfigError as exc:
        if exc.source != cls.__name__:
            raise
        raise ConfigError(source, join_key(prefix, exc.key), exc.problem) from None


def _build_dataclass(cls: type, data: Mapping[str, Any], source: str, prefix: str) -> Any:
    pre = getattr(cls, "from_file", None)
    if pre is not None:
        return pre(data, source=source, prefix=prefix)
    return build_fields(cls, data, source=source, prefix=prefix)


def build_fields(cls: type, data: Mapping[str, Any], *, source: str, prefix: str) -> Any:
    """Build a dataclass field by field: what :func:`build` does unless the class has ``from_file``.

    A class's ``from_file`` calls it for the part of its table that maps field by field. A field's ``file_key``
    metadata gives its key in the file; ``derived`` metadata leaves it out. After construction the instance's
    ``validate(source=, prefix=)``, if it has one, checks what spans several fields.

    Parameters
    ----------
    cls : type
        The dataclass.
    data : Mapping
        Its table from the file.
    source : str
        What errors name as the file.
    prefix : str
        The table's dotted path in the file.

    Returns
    -------
    object
        The instance of ``cls``.

    Raises
    ------
    ConfigError
        An unknown or missing key, or a value the field or the class refuses.
    """
    hints = class_type_hints(cls)
    fields = {f.metadata.get("file_key", f.name): f for f in dataclasses.fields(cls) if not f.metadata.get("derived")}
    for k in data:
        if k not in fields:
            hint = did_you_mean(k, fields, prefix.split(".") if prefix else [])
            raise ConfigError(source, join_key(prefix, k), "unknown key" + hint)
    kwargs: dict[str, Any] = {}
    for file_key, f in fields.items():
        key = join_key(prefix, file_key)
        if file_key in data:
            kwargs[f.name] = convert_value(hints[f.name], data[file_key], source, key, f.metadata)
        elif f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise ConfigError(source, key, "missing key")
    with as_file_error(cls, source, prefix):
        obj = cls(**kwargs)
    check = getattr(obj, "validate", None)
    if check is not None:
        check(source=source, prefix=prefix)
    return obj
