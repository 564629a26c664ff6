"""TOML files in and out: reading one (one-line errors naming it), a dataclass as plain data and as TOML text, and
the names that become output folders."""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomli_w

from agvctl.errors import ConfigError

__all__ = ["check_plain_name", "dump_toml", "load_toml", "read_text", "to_dict"]


def check_plain_name(name: str, source: str, key: str, folder: str) -> None:
    """Refuse a name that is not one plain folder name.

    Names become default output folders and file names, which must stay under their root whatever the file says.

    Parameters
    ----------
    name : str
        The name to check.
    source : str
        What errors name as the file.
    key : str
        The dotted key the name came from.
    folder : str
        The folder the name becomes, for the message (e.g. ``out/<name>``).

    Raises
    ------
    ConfigError
        An empty name, ``.`` or ``..``, or one holding ``/``, ``\\`` or a control character.
    """
    if name in ("", ".", "..") or any(c in "/\\" or not c.isprintable() for c in name):
        raise ConfigError(
            source,
            key,
            f"must be a plain name, usable as the folder {folder}: no '/' or '\\', not '.' or '..' (got {name!r})",
        )


def read_text(path: str | Path) -> str:
    """A UTF-8 text file's contents, without a leading byte-order mark (Excel's "CSV UTF-8" writes one).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    str
        Its text.

    Raises
    ------
    ConfigError
        A missing or unreadable file, or one that is not UTF-8, in one line naming it.
    """
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ConfigError(str(path), "", "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(str(path), "", f"cannot read: {exc}") from None


def load_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file into its tables.

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    dict
        Its tables as :mod:`tomllib` reads them.

    Raises
    ------
    ConfigError
        An unreadable or malformed file (values nested too deeply for the parser among it), in one line.
    """
    text = read_text(path)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), "", f"malformed TOML: {exc}") from None
    except RecursionError:  # the parser recurses once per level of nested arrays or inline tables
        raise ConfigError(str(path), "", "malformed TOML: values nested too deeply") from None


def to_dict(obj: Any) -> Any:
    """The nested plain-data form of a config dataclass, keys as in the file, for JSON and TOML output.

    Parameters
    ----------
    obj : object
        A dataclass (its ``to_file()`` if it has one), a list or tuple of them, or a plain value.

    Returns
    -------
    object
        Dicts, lists and plain values; ``None`` fields and derived ones are left out.
    """
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
    """Nested plain data as TOML text: numbers at full precision, a dotted key quoted as one key.

    Parameters
    ----------
    data : Mapping
        The tables, e.g. from :func:`to_dict`.
    header : str
        Text written above them as comment lines (``""``: none).

    Returns
    -------
    str
        The TOML text.

    Examples
    --------
    >>> print(dump_toml({"wheels": {"radius_m": 0.1}}, header="made by hand"), end="")
    # made by hand
    [wheels]
    radius_m = 0.1
    """
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    body = tomli_w.dumps(data)
    return "\n".join(lines) + ("\n" if lines else "") + body
