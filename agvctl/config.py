"""Strict loading of TOML files into frozen dataclasses, with one-line errors.

The public file formats (vehicles, trajectories, experiments) are all read through :func:`build`: unknown keys
are rejected with a "did you mean", missing keys and wrong types are named, numbers are checked for the bounds a
field declares with :func:`number`. Every problem raises :class:`~agvctl.errors.ConfigError` whose message is
``"<file>: <key.path>: <problem>"``.

Plain dataclasses rather than pydantic: the schemas are small, the dependencies fixed, and the loader gives exactly
the one-line messages the CLI promises.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math
import numbers
import tomllib
import types
import typing
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any, Literal, TypeVar, Union, get_args, get_origin, get_type_hints

import tomli_w

from agvctl.errors import ConfigError

T = TypeVar("T")

__all__ = [
    "apply_overrides",
    "build",
    "build_fields",
    "check_fields",
    "check_key",
    "check_plain_name",
    "convert_value",
    "did_you_mean",
    "dump_toml",
    "join_key",
    "load_toml",
    "number",
    "parse_override",
    "read_text",
    "renamed",
    "to_dict",
]


def number(
    *,
    gt: float | None = None,
    ge: float | None = None,
    le: float | None = None,
    default: Any = dataclasses.MISSING,
    doc: str = "",
) -> Any:
    """A dataclass field holding a finite number with optional bounds (``gt``: strictly greater, ``ge``, ``le``)."""
    metadata = {"gt": gt, "ge": ge, "le": le, "doc": doc}
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def check_plain_name(name: str, source: str, key: str, folder: str) -> None:
    """Refuse a ``name`` that is not one plain folder name: empty, ``.`` or ``..``, holding ``/``, ``\\`` or a
    control character. Names become default output folders and file names (``folder`` says which, e.g.
    ``out/<name>``), which must stay under their root whatever the file says."""
    if name in ("", ".", "..") or any(c in "/\\" or not c.isprintable() for c in name):
        raise ConfigError(
            source,
            key,
            f"must be a plain name, usable as the folder {folder}: no '/' or '\\', not '.' or '..' (got {name!r})",
        )


def read_text(path: str | Path) -> str:
    """A UTF-8 text file's contents, without a leading byte-order mark (Excel's "CSV UTF-8" writes one); a missing
    or unreadable file raises a one-line :class:`ConfigError`."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(str(path), "", "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(str(path), "", f"cannot read: {exc}") from None


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; an unreadable or malformed file (values nested too deeply for the parser among it)
    raises a one-line :class:`ConfigError`."""
    text = read_text(path)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), "", f"malformed TOML: {exc}") from None
    except RecursionError:  # the parser recurses once per level of nested arrays or inline tables
        raise ConfigError(str(path), "", "malformed TOML: values nested too deeply") from None


def parse_override(text: str, source: str = "--set") -> tuple[str, Any]:
    """Split ``"a.b.c=VALUE"`` into the dotted key and a TOML-typed value (bare words become strings)."""
    key, sep, value_text = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(source, text, "expected KEY=VALUE, e.g. wheels.right.radius_m=0.101")
    value_text = value_text.strip()
    try:
        value = tomllib.loads(f"v = {value_text}")["v"]
    except tomllib.TOMLDecodeError:
        value = value_text
    except RecursionError:
        raise ConfigError(source, key, "value nested too deeply") from None
    return key, value


def apply_overrides(
    raw: Mapping[str, Any], overrides: Iterable[tuple[str, Any]], schema: type, source: str = "--set"
) -> dict[str, Any]:
    """Return a deep copy of ``raw`` with each dotted ``key = value`` set; keys are checked against ``schema``."""
    result = _deep_copy(raw)
    for key, value in overrides:
        parts = key.split(".")
        _check_path(schema, parts, source, key)
        node = result
        for part in parts[:-1]:
            child = node.get(part)
            if not isinstance(child, dict):
                child = {}
                node[part] = child
            node = child
        node[parts[-1]] = value
    return result


def check_key(schema: type, key: str, source: str) -> None:
    """Check that the dotted ``key`` names a value of ``schema``: an unknown, renamed or table key raises a
    :class:`ConfigError` naming ``source`` and the key."""
    _check_path(schema, key.split("."), source, key)


def _deep_copy(raw: Mapping[str, Any]) -> dict[str, Any]:
    return {k: _deep_copy(v) if isinstance(v, Mapping) else v for k, v in raw.items()}


def _check_path(schema: type, parts: list[str], source: str, key: str) -> None:
    cls: Any = schema
    for depth, part in enumerate(parts):
        if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
            raise ConfigError(source, key, f"'{'.'.join(parts[:depth])}' is a value, not a table")
        names = _file_keys(cls)
        if part not in names:
            new = _renamed_keys(cls).get(part)
            if new is not None:
                raise ConfigError(source, key, renamed(".".join([*parts[:depth], new])))
            raise ConfigError(source, key, "unknown key" + did_you_mean(part, names, parts[:depth]))
        cls = names[part]
    if isinstance(cls, type) and dataclasses.is_dataclass(cls):
        raise ConfigError(source, key, "is a table; set one of its keys")


def _file_keys(cls: type) -> dict[str, Any]:
    """Map of the keys a dataclass accepts in a file to their types (``file_key`` metadata renames a field)."""
    hints = get_type_hints(cls)
    keys: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if f.metadata.get("derived"):
            continue
        keys[f.metadata.get("file_key", f.name)] = hints[f.name]
    extra = getattr(cls, "extra_file_keys", None)
    if extra:
        keys.update(extra())
    return keys


def _renamed_keys(cls: type) -> dict[str, str]:
    """Map of a dataclass's former file keys to their current dotted keys, relative to its table (the class's
    ``renamed_file_keys``)."""
    names = getattr(cls, "renamed_file_keys", None)
    return dict(names()) if names else {}


def renamed(new_key: str) -> str:
    """The problem of a key that has a new name: ``renamed; use <new_key>``."""
    return f"renamed; use {new_key}"


def did_you_mean(word: str, choices: Iterable[str], prefix: list[str]) -> str:
    """`` (did you mean a.b.c?)`` for the closest of ``choices`` to a misspelt ``word``, or ``""``."""
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    if not close:
        return ""
    return f" (did you mean {'.'.join([*prefix, close[0]])}?)"


def build(cls: type[T], data: Any, *, source: str, prefix: str = "") -> T:
    """Build dataclass ``cls`` from the mapping ``data`` strictly; errors name ``source`` and the dotted key."""
    value = convert_value(cls, data, source, prefix)
    return typing.cast(T, value)


def join_key(prefix: str, key: str) -> str:
    """``prefix.key`` (or ``key`` at the top level): the dotted path named in error messages."""
    return f"{prefix}.{key}" if prefix else key


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
    """Check and convert one value from a file to type ``tp`` (bounds from a :func:`number` field's ``meta``)."""
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


_INIT_FIELDS: dict[type, tuple[tuple[str, Any, Mapping[str, Any]], ...]] = {}


def _init_fields(cls: type) -> tuple[tuple[str, Any, Mapping[str, Any]], ...]:
    """``(name, type, metadata)`` of each field a dataclass's constructor takes (worked out once per class)."""
    if cls not in _INIT_FIELDS:
        hints = get_type_hints(cls)
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
            _check_argument(args[1], v, source, join_key(key, str(k)), {})
        return
    if not isinstance(value, (tuple, list)):
        raise ConfigError(source, key, f"expected a tuple or list (got {value!r})")
    fixed = origin is tuple and args[-1] is not Ellipsis
    if fixed and len(value) != len(args):
        raise ConfigError(source, key, f"expected {len(args)} items (got {len(value)})")
    for i, v in enumerate(value):
        _check_argument(args[i] if fixed else args[0], v, source, f"{key}[{i}]", {})


def check_fields(obj: Any) -> None:
    """Check the fields of a dataclass made in Python as :func:`build` checks a file's: numbers finite and within
    their :func:`number` bounds, integers whole, choices among their ``Literal`` values, strings and booleans of
    their type, tuples, lists and dicts item by item; a nested dataclass must be one (it checks itself).

    Raises
    ------
    ConfigError
        ``"<Class>: <argument>: <problem>"``, e.g. ``LineSegment: length_m: must be finite (got nan)``.
    """
    source = type(obj).__name__
    for name, tp, meta in _init_fields(type(obj)):
        _check_argument(tp, getattr(obj, name), source, name, meta)


@contextlib.contextmanager
def as_file_error(cls: type, source: str, prefix: str) -> Iterator[None]:
    """Re-raise a :class:`ConfigError` that ``cls``'s constructor names after itself (``"FuzzSpec: seed: …"``) as
    the file's, its key under ``prefix``: a check made in Python reads, from a file, like the loader's own."""
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
    """Build a dataclass field by field (what :func:`build` does unless the class has ``from_file``)."""
    hints = get_type_hints(cls)
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


def to_dict(obj: Any) -> Any:
    """The nested plain-data form of a config dataclass (keys as in the file), for JSON and TOML output."""
    to_file = getattr(obj, "to_file", None)
    if to_file is not None:
        return to_file()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(obj):
            if f.metadata.get("derived"):
                continue
            value = getattr(obj, f.name)
            if value is None:
                continue
            out[f.metadata.get("file_key", f.name)] = to_dict(value)
        return out
    if isinstance(obj, (list, tuple)):
        return [to_dict(v) for v in obj]
    return obj


def dump_toml(data: Mapping[str, Any], header: str = "") -> str:
    """Write nested plain data as TOML (tomli-w: numbers at full precision, dotted keys quoted as one key),
    behind ``header`` as comment lines."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    body = tomli_w.dumps(data)
    return "\n".join(lines) + ("\n" if lines else "") + body
