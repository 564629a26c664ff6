"""Writing output files atomically (no half-written file on error) and at full precision."""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = ["CSV_FLOAT_FORMAT", "atomic_open", "json_safe", "write_csv", "write_json", "write_text"]

CSV_FLOAT_FORMAT = "%.12g"
"""Twelve significant digits: every CSV the package writes carries at least nine."""


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; it replaces ``path`` only if the block completes.

    An :class:`OSError` of the temporary file (it cannot be made, written or moved into place) is raised as one of
    ``path``: errors name the file the caller asked for, never the temporary one.

    Parameters
    ----------
    path : str or Path
        The file to write; its folder is made if missing.
    mode : str
        ``"w"`` for text (UTF-8, no newline translation) or ``"wb"`` for bytes.

    Yields
    ------
    file object
        The temporary file, open for writing.

    Raises
    ------
    OSError
        Naming ``path``, when the temporary file cannot be made, written or moved into place.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(path)) from None
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the permissions open() would
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8", newline=None if "b" in mode else "") as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and exc.filename in (None, tmp):
            raise OSError(exc.errno, exc.strerror, str(path)) from None
        raise


def json_safe(values: Mapping[str, float]) -> dict[str, float | None]:
    """A mapping with every NaN and infinity as None (JSON ``null``).

    JSON has no NaN or infinity; :func:`json.dumps` would write the non-standard ``NaN`` that strict readers
    reject.

    Parameters
    ----------
    values : Mapping of str to float
        The values.

    Returns
    -------
    dict
        A copy, NaN and infinities as None, other values unchanged.
    """
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in values.items()}


def write_text(path: str | Path, text: str) -> None:
    """Write a text file (UTF-8) atomically: no half-written file on error.

    Parameters
    ----------
    path : str or Path
        The file.
    text : str
        Its contents.
    """
    with atomic_open(path) as fh:
        fh.write(text)


def write_json(path: str | Path, data: Any) -> None:
    """Write data as indented JSON atomically.

    Parameters
    ----------
    path : str or Path
        The file.
    data : object
        What :func:`json.dumps` can write (see :func:`json_safe` for NaN).
    """
    write_text(path, json.dumps(data, indent=2) + "\n")


def write_csv(path: str | Path, columns: Mapping[str, Sequence[float] | np.ndarray]) -> None:
    """Write equal-length columns as CSV with a header, floats at :data:`CSV_FLOAT_FORMAT`, atomically.

    Parameters
    ----------
    path : str or Path
        The file.
    columns : Mapping of str to sequence of float
        The columns by name, in the order they are written.
    """
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    with atomic_open(path) as fh:
        fh.write(",".join(names) + "\n")
        np.savetxt(fh, data, delimiter=",", fmt=CSV_FLOAT_FORMAT)
