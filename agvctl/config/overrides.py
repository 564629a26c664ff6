"""``--set KEY=VALUE`` overrides: a dotted key, checked against a file's schema, and a TOML-typed value."""

from __future__ import annotations

import dataclasses
import numbers
import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

from agvctl.config.fields import class_type_hints
from agvctl.config.loading import did_you_mean, renamed
from agvctl.errors import ConfigError

__all__ = ["apply_overrides", "check_key", "override_pairs", "parse_override"]


def parse_override(text: str, source: str = "--set") -> tuple[str, Any]:
    """Split ``"a.b.c=VALUE"`` into the dotted key and a TOML-typed value (bare words become strings).

    Parameters
    ----------
    text : str
        ``KEY=VALUE`` as given on the command line.
    source : str
        What errors name as the file (the option, by default).

    Returns
    -------
    key : str
        The dotted key.
    value : object
        The value as TOML reads it (``0.101`` a float, ``true`` a bool, ``[1, 2]`` a list), or the text itself.

    Raises
    ------
    ConfigError
        No ``=`` or no key, or a value nested too deeply.

    Examples
    --------
    >>> parse_override("wheels.right.radius_m=0.101")
    ('wheels.right.radius_m', 0.101)
    >>> parse_override("controller.pose=mpc")
    ('controller.pose', 'mpc')
    """
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


def override_pairs(overrides: Iterable[Any], source: str = "--set") -> list[tuple[str, Any]]:
    """Overrides in either form, ``"KEY=VALUE"`` strings or ``(key, value)`` pairs, as ``(key, value)`` pairs.

    A numpy scalar (or another ``numbers.Real``) value becomes the Python value it holds (``np.int64(10)`` →
    ``10``), so it is accepted wherever a Python number is.

    Parameters
    ----------
    overrides : iterable
        Each a ``"KEY=VALUE"`` string (:func:`parse_override`) or a ``(key, value)`` pair with a string key.
    source : str
        What errors name as the file (the option, by default).

    Returns
    -------
    list of (str, object)
        The pairs, in order.

    Raises
    ------
    ConfigError
        An override of neither form, naming it.

    Examples
    --------
    >>> import numpy as np
    >>> override_pairs(["da.bits=10", ("da.max_v", np.float64(4.5))])
    [('da.bits', 10), ('da.max_v', 4.5)]
    """
    if isinstance(overrides, (str, bytes)):
        raise ConfigError(source, "", f"expected a list of overrides (got the string {overrides!r})")
    pairs: list[tuple[str, Any]] = []
    for o in overrides:
        if isinstance(o, str):
            pairs.append(parse_override(o, source))
            continue
        if not (isinstance(o, (tuple, list)) and len(o) == 2 and isinstance(o[0], str) and o[0]):
            raise ConfigError(source, repr(o)[:60], 'expected "KEY=VALUE" or a (key, value) pair with a string key')
        key, value = o
        if type(value).__module__ == "numpy" and getattr(value, "ndim", None) == 0:
            value = value.item()  # a numpy scalar (np.int64, np.float64, np.bool_): the Python value it holds
        elif isinstance(value, numbers.Integral) and not isinstance(value, bool):
            value = int(value)
        elif isinstance(value, numbers.Real) and not isinstance(value, (int, float)):
            value = float(value)
        pairs.append((key, value))
    return pairs


def apply_overrides(
    raw: Mapping[str, Any], overrides: Iterable[tuple[str, Any]], schema: type, source: str = "--set"
) -> dict[str, Any]:
    """A deep copy of a file's raw tables with each dotted ``key = value`` set, every key checked against a schema.

    Parameters
    ----------
    raw : Mapping
        The file's tables as TOML reads them.
    overrides : iterable of (str, object)
        Dotted keys and their values, as :func:`parse_override` returns them; later ones win.
    schema : type
        The dataclass the file is built into: each key must name one of its values (:func:`check_key`).
    source : str
        What errors name as the file.

    Returns
    -------
    dict
        The copy, with the overrides set (missing tables made); ``raw`` is left as it was.

    Raises
    ------
    ConfigError
        A key that names no value of ``schema``: unknown (with a "did you mean"), renamed, or a whole table.
    """
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
    """Check that a dotted key names a value of a schema, as :func:`apply_overrides` checks each key.

    Parameters
    ----------
    schema : type
        The dataclass of the file the key is for.
    key : str
        The dotted key, e.g. ``wheels.left.radius_m``.
    source : str
        What errors name as the file.

    Raises
    ------
    ConfigError
        An unknown, renamed or table key, naming ``source`` and the key.
    """
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
    hints = class_type_hints(cls)
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
