"""TOML files in and out: reading one (one-line errors naming it), a dataclass as plain data and as TOML text, and
the names that become output folders."""

from __future__ import annotations

import dataclasses
import os
import stat
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomli_w

from agvctl.errors import ConfigError
from agvctl.fileio import file_kind

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_LOG_BYTES",
    "MAX_NAME_BYTES",
    "check_plain_name",
    "dump_toml",
    "load_toml",
    "read_text",
    "to_dict",
]


MAX_NAME_BYTES = 200
"""The longest name that becomes a folder, bytes of UTF-8: a folder name may have 255 on nearly every file system,
and ``tune`` adds ``_<controller>`` to it."""


def check_plain_name(name: str, source: str, key: str, folder: str) -> None:
    """Refuse a name that is not one plain folder name.

    Names become default output folders and file names, which must stay under their root whatever the file says,
    be visible, and never take the name of the tool's own files there (the marker of an output folder, temporary
    files: both start with ``.``).

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
        An empty name, one starting with ``.`` (``.`` and ``..`` among them) or starting or ending with a space, one
        holding ``/``, ``\\`` or a control character, or one longer than :data:`MAX_NAME_BYTES`.
    """
    if name.startswith(".") or name.strip() != name or not name or any(c in "/\\" or not c.isprintable() for c in name):
        raise ConfigError(
            source,
            key,
            f"must be a plain name, usable as the folder {folder}: no '/' or '\\', not starting with '.', no space "
            f"at either end (got {name!r})",
        )
    if len(name.encode("utf-8")) > MAX_NAME_BYTES:
        raise ConfigError(
            source,
            key,
            f"must be a plain name, usable as the folder {folder}: at most {MAX_NAME_BYTES} bytes "
            f"(got {len(name.encode('utf-8'))})",
        )


MAX_FILE_BYTES = 4 * 2**20
"""The largest settings file read (vehicle, experiment, path, fuzz, gains and settings files), bytes: 4 MiB.

The largest file shipped is under 3 kB; a path of the most segments a file may hold (10 000), written one key a line,
is under 1 MB with comments. Parsing 4 MiB of TOML takes a few seconds and under 100 MB of memory."""

MAX_LOG_BYTES = 64 * 2**20
"""The largest log read (CSV: a measured or simulated log, a DA profile), bytes: 64 MiB.

About 450 000 rows of ten columns at full precision: over an hour of samples at 100 Hz, where a measurement
procedure logs minutes. Reading 64 MiB of CSV takes under 20 s and under 1 GB of memory (the csv module holds each
cell as a string before it is a number)."""


def _refuse(path: Path, problem: str) -> ConfigError:
    return ConfigError(str(path), "", problem)


def read_text(path: str | Path, max_bytes: int = MAX_FILE_BYTES) -> str:
    """A UTF-8 text file's contents, without a leading byte-order mark (Excel's "CSV UTF-8" writes one).

    Every file the package reads is read here: only a regular file, and at most ``max_bytes`` of it. A FIFO, a
    device or a socket is refused without being opened (and, should one be put in the file's place meanwhile,
    without blocking: it is opened non-blocking and checked again on the open descriptor).

    Parameters
    ----------
    path : str or Path
        The file.
    max_bytes : int
        The largest file accepted, bytes (:data:`MAX_FILE_BYTES` for settings files, :data:`MAX_LOG_BYTES` for
        logs).

    Returns
    -------
    str
        Its text.

    Raises
    ------
    ConfigError
        A missing or unreadable file, one that is not a regular file, larger than ``max_bytes`` or not UTF-8, in one
        line naming it.
    """
    path = Path(path)
    try:
        if not stat.S_ISREG(mode := os.stat(path).st_mode):
            raise _refuse(path, f"cannot read: {file_kind(mode)}, not a regular file")
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC)
        with os.fdopen(fd, "rb") as fh:
            opened = os.fstat(fh.fileno())
            if not stat.S_ISREG(opened.st_mode):
                raise _refuse(path, f"cannot read: {file_kind(opened.st_mode)}, not a regular file")
            data = fh.read(max_bytes + 1) if opened.st_size <= max_bytes else b""
            if opened.st_size > max_bytes or len(data) > max_bytes:
                size = max(opened.st_size, len(data))
                raise _refuse(
                    path, f"cannot read: {size / 2**20:.1f} MiB, larger than the {max_bytes / 2**20:g} MiB accepted"
                )
        return data.decode("utf-8-sig")
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
