"""Writing output files atomically (no half-written file on error) and at full precision, only where the tool may.

An output path is resolved against the real file system before anything is written (:func:`real_path`): every
symbolic link and ``..`` resolved, missing folders included. The tool then works on that path alone, so it creates
only folders whose names are plain, and nothing it creates can change what an earlier component means. What is there
is replaced only when it is a regular file (:func:`check_replaceable_file`): never a device, a FIFO, a socket or a
folder, which a rename would replace for every program on the machine. The check is made again just before the
temporary file is moved into place.
"""

from __future__ import annotations

import contextlib
import errno
import json
import math
import os
import stat
import tempfile
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = [
    "CSV_FLOAT_FORMAT",
    "atomic_open",
    "check_replaceable_file",
    "file_kind",
    "json_safe",
    "make_folders",
    "real_path",
    "remove_empty_folders",
    "temporary_prefix",
    "write_csv",
    "write_json",
    "write_text",
]

CSV_FLOAT_FORMAT = "%.12g"
"""Twelve significant digits: every CSV the package writes carries at least nine."""

_MAX_SYMLINKS = 40
"""Symbolic links followed in one path before it counts as a loop (Linux's MAXSYMLINKS)."""

_KINDS = (
    (stat.S_ISREG, "a regular file"),
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISLNK, "a symbolic link"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def file_kind(mode: int) -> str:
    """What a file of this ``st_mode`` is, for messages ("a regular file", "a character device", ...).

    Parameters
    ----------
    mode : int
        ``st_mode`` of :func:`os.stat` or :func:`os.lstat`.

    Returns
    -------
    str
        The kind with its article.
    """
    return next((name for test, name in _KINDS if test(mode)), "a special file")


def real_path(path: str | Path) -> Path:
    """The absolute path that ``path`` names on the real file system, missing components included.

    Each component is looked at in turn: a symbolic link is replaced by what it points to (itself resolved the same
    way), ``..`` goes up from the path resolved so far, and a component that does not exist is kept as it is. A
    ``..`` after a missing component therefore cancels it: that is what the kernel will find once the component is
    made a folder, and the tool never makes it (it works on the resolved path only, whose missing components are
    plain names).

    Parameters
    ----------
    path : str or Path
        The path as given (relative to the working folder, or absolute).

    Returns
    -------
    Path
        Absolute, free of ``.``, ``..`` and symbolic links up to the first missing component.

    Raises
    ------
    OSError
        Naming ``path``: a component that is followed by another but is neither a folder nor missing (ENOTDIR), a
        loop of symbolic links (ELOOP), a name too long (ENAMETOOLONG) or a folder that cannot be searched.

    Examples
    --------
    >>> real_path("/no-such-folder/../tmp") == real_path("/tmp")
    True
    """
    followed = [0]
    try:
        return _resolve(Path(os.getcwd()), os.fspath(path), followed)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, os.fspath(path)) from None


def _resolve(base: Path, path: str, followed: list[int]) -> Path:
    """``path`` resolved from the real folder ``base``; ``followed`` counts the symbolic links followed."""
    given = Path(path)
    resolved = Path(given.anchor) if given.is_absolute() else base
    names = given.parts[1:] if given.is_absolute() else given.parts
    mode: int | None = stat.S_IFDIR  # what ``resolved`` is: None while it does not exist
    for i, name in enumerate(names):
        if mode is not None and not stat.S_ISDIR(mode):
            shown = Path(given.anchor, *names[:i])
            raise OSError(errno.ENOTDIR, f"{shown} is not a directory ({file_kind(mode)})")
        if name == "..":
            resolved = resolved.parent
            mode = stat.S_IFDIR if mode is not None else _mode(resolved)
            continue
        candidate = resolved / name
        mode = _mode(candidate) if mode is not None else None
        if mode is not None and stat.S_ISLNK(mode):
            followed[0] += 1
            if followed[0] > _MAX_SYMLINKS:
                raise OSError(errno.ELOOP, os.strerror(errno.ELOOP))
            candidate = _resolve(resolved, os.readlink(candidate), followed)
            mode = _mode(candidate)
        resolved = candidate
    return resolved


def _mode(path: Path) -> int | None:
    """``st_mode`` of ``path`` without following a final symbolic link; None when nothing is there."""
    try:
        return os.lstat(path).st_mode
    except FileNotFoundError:
        return None


def check_replaceable_file(path: str | Path) -> None:
    """Refuse to replace what is at ``path`` unless it is a regular file (or nothing is there).

    Parameters
    ----------
    path : str or Path
        A resolved path (:func:`real_path`): a symbolic link there is refused too.

    Raises
    ------
    OSError
        Naming ``path``: a folder (EISDIR) or a device, FIFO, socket or symbolic link (EPERM).
    """
    mode = _mode(Path(path))
    if mode is None or stat.S_ISREG(mode):
        return
    code = errno.EISDIR if stat.S_ISDIR(mode) else errno.EPERM
    raise OSError(code, f"it is {file_kind(mode)}, not a regular file; refusing to replace it", os.fspath(path))


def make_folders(folder: str | Path) -> list[Path]:
    """Make ``folder`` and its missing parents.

    Parameters
    ----------
    folder : str or Path
        A resolved folder (:func:`real_path`).

    Returns
    -------
    list of Path
        The folders made (for :func:`remove_empty_folders`).

    Raises
    ------
    OSError
        A folder cannot be made, or a component is not a folder.
    """
    missing = []
    for p in (Path(folder), *Path(folder).parents):
        if p.is_dir():
            break
        missing.append(p)
    made = []
    try:
        for p in reversed(missing):
            p.mkdir(exist_ok=True)
            made.append(p)
    except OSError:
        remove_empty_folders(made)
        raise
    return made


def remove_empty_folders(folders: Iterable[Path]) -> None:
    """Remove each of ``folders`` (made by :func:`make_folders`) that is empty, the deepest first.

    Parameters
    ----------
    folders : iterable of Path
        The folders; one that holds anything is kept, and so are those above it.
    """
    for p in sorted(set(folders), key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):
            p.rmdir()


def temporary_prefix(name: str) -> str:
    """The prefix of a temporary file or folder written beside ``name``: ``.<name>.``, the name cut to 40 characters
    so that the temporary name fits wherever ``name`` does.

    Parameters
    ----------
    name : str
        The final file or folder name.

    Returns
    -------
    str
        The prefix for :func:`tempfile.mkstemp` or :func:`tempfile.mkdtemp`.
    """
    return f".{name[:40]}."


@contextlib.contextmanager
def atomic_open(path: str | Path, mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; it replaces ``path`` only if the block completes.

    ``path`` is resolved first (:func:`real_path`: a symbolic link is written through, not replaced), and only a
    regular file there is replaced (:func:`check_replaceable_file`, checked again just before the move). Folders
    made for it are removed again when the block fails. An :class:`OSError` of the temporary file (it cannot be
    made, written or moved into place) is raised as one of ``path``: errors name the file the caller asked for,
    never the temporary one.

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
        Naming ``path``, when it is not a regular file, or when the temporary file cannot be made, written or moved
        into place.
    """
    made: list[Path] = []
    try:
        target = real_path(path)
        check_replaceable_file(target)
        made = make_folders(target.parent)
        fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(target.name), suffix=".tmp", dir=target.parent)
    except OSError as exc:
        remove_empty_folders(made)
        raise OSError(exc.errno, exc.strerror, os.fspath(path)) from None
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the permissions open() would
    try:
        with os.fdopen(fd, mode, encoding=None if "b" in mode else "utf-8", newline=None if "b" in mode else "") as fh:
            yield fh
        check_replaceable_file(target)  # again: something else may have been put there meanwhile
        os.replace(tmp, target)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        remove_empty_folders(made)
        if isinstance(exc, OSError) and exc.filename in (None, tmp, os.fspath(target)):
            raise OSError(exc.errno, exc.strerror, os.fspath(path)) from None
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
