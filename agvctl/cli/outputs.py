"""The output files of a command, checked before anything runs and written with errors naming their flag.

Every command that writes files checks them all first (:func:`check_outputs`), so a run never ends by refusing
its output, and never half-writes one output and refuses the next:

* an output is never an input of the same command (the same file, by any name: ``plan a.toml --out a.toml``),
  nor the file of another output flag;
* an output file is not an existing directory, and an output directory not an existing file;
* the directory it goes into exists, or can be made inside an existing writable directory (tried with a
  temporary file that is removed at once: permissions alone do not tell, e.g. for root or under ``/proc``).

Each problem is one line naming the flag and the path as the user gave it. The files themselves are written
atomically (:func:`agvctl.fileio.atomic_open`); :func:`writing` turns an error while writing into the same one line.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from agvctl.errors import ConfigError
from agvctl.fileio import file_kind, real_path
from agvctl.params import default_vehicle_path

__all__ = ["Output", "check_outputs", "files_in", "vehicle_input", "writing"]


@dataclass(frozen=True)
class Output:
    """One output file and the flag that names it (for a directory flag, a file the command writes in it)."""

    flag: str
    path: Path


def files_in(flag: str, directory: str | Path, names: Iterable[str]) -> list[Output]:
    """The outputs ``directory/name`` of a directory flag such as ``--out DIR``."""
    return [Output(flag, Path(directory) / name) for name in names]


def vehicle_input(vehicle: str | Path | None) -> Path:
    """The vehicle file a ``--vehicle`` option reads (the shipped default when not given)."""
    return Path(vehicle) if vehicle is not None and str(vehicle) != "default" else default_vehicle_path()


PACKAGE = Path(__file__).resolve().parent.parent
"""The agvctl package's folder: no output is written into it."""


def _real(flag: str, path: Path) -> Path:
    """``path`` resolved (:func:`~agvctl.fileio.real_path`), an error as one line naming ``flag``."""
    if not str(path):
        raise ConfigError(flag, "", "must not be empty")
    try:
        return real_path(path)
    except OSError as exc:
        if exc.errno == errno.ENAMETOOLONG:
            raise ConfigError(flag, "", f"cannot write it: {exc.strerror} (a name in it, or the whole path)") from None
        raise ConfigError(flag, "", f"cannot write {path}: {exc.strerror}") from None


def _same_file(a: Path, b: Path) -> bool:
    """``a`` and ``b`` (both resolved) are one file: the same path, or another name of it (a hard link)."""
    try:
        return a == b or os.path.samefile(a, b)
    except OSError:  # either does not exist (yet): the same file only by name
        return False


def _check_not_in_package(flag: str, real: Path, shown: Path) -> None:
    if real == PACKAGE or PACKAGE in real.parents or real in PACKAGE.parents:
        where = "holds" if real in PACKAGE.parents else "lies inside"
        raise ConfigError(flag, "", f"{shown} {where} the agvctl package ({PACKAGE}); refusing to write there")


def _nearest_existing(path: Path) -> Path:
    for p in (path, *path.parents):
        if p.exists():
            return p
    return Path("/")


def _check_directory(flag: str, directory: Path, shown: Path, target: Path | None = None) -> None:
    """The resolved ``directory`` exists or can be made, a file can be created in it (or in the nearest existing
    parent), and each name to be made (up to ``target`` if given) is within the file system's limit."""
    nearest = _nearest_existing(directory)
    if not nearest.is_dir():
        raise ConfigError(flag, "", f"cannot write {shown}: {nearest} is not a directory")
    _check_names(flag, nearest, target or directory)
    try:
        with tempfile.TemporaryFile(dir=nearest):
            pass
    except OSError as exc:
        raise ConfigError(
            flag, "", f"cannot write {shown}: cannot create a file in {nearest} ({exc.strerror})"
        ) from None


def _check_names(flag: str, nearest: Path, path: Path) -> None:
    """Each name of ``path`` below the existing folder ``nearest`` fits the file system's limit on a name."""
    try:
        limit = os.pathconf(nearest, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = 255
    for name in path.relative_to(nearest).parts:
        size = len(os.fsencode(name))
        if size > limit:
            short = name if len(name) <= 24 else name[:24] + "…"
            raise ConfigError(
                flag, "", f"cannot write {short}: a name of {size} bytes; the file system allows {limit} (not written)"
            )


def check_outputs(
    outputs: Sequence[Output], inputs: Iterable[str | Path], directories: Sequence[tuple[str, str | Path]] = ()
) -> None:
    """Refuse, before anything runs, outputs that would overwrite an input, each other or anything but a regular
    file, that lie in the package, or that cannot be written.

    Every path is judged where it really is (:func:`~agvctl.fileio.real_path`: ``..`` and symbolic links resolved,
    missing folders included), and the writers write there.

    Parameters
    ----------
    outputs
        Every file the command will write, with its flag.
    inputs
        Every file the command reads (missing ones are ignored: they are reported by the loaders).
    directories
        ``(flag, directory)`` of directory flags (``--out DIR``): each must be a directory or be creatable.

    Raises
    ------
    ConfigError
        One line naming the flag and the path as given.
    """
    existing: list[tuple[Path, Path]] = []
    for p in inputs:
        with contextlib.suppress(OSError):
            if Path(p).exists():
                existing.append((Path(p), real_path(p)))
    for flag, directory in directories:
        d = Path(directory)
        real = _real(flag, d)
        if real.exists() and not real.is_dir():
            raise ConfigError(flag, "", f"{d} is {file_kind(real.lstat().st_mode)}, not a directory")
        _check_not_in_package(flag, real, d)
        _check_directory(flag, real, d)
    seen: list[tuple[Output, Path]] = []
    for out in outputs:
        real = _real(out.flag, out.path)
        if real.is_dir():
            raise ConfigError(out.flag, "", f"{out.path} is a directory; expected a file name")
        if real.exists() and not real.is_file():
            kind = file_kind(real.lstat().st_mode)
            raise ConfigError(out.flag, "", f"{out.path} is {kind}, not a regular file; refusing to replace it")
        clash = next((given for given, p in existing if _same_file(real, p)), None)
        if clash is not None:
            also = "" if clash == out.path else f" (the same file as {clash})"
            raise ConfigError(out.flag, "", f"{out.path} is an input of this command{also}; refusing to overwrite it")
        _check_not_in_package(out.flag, real, out.path)
        other = next((o for o, p in seen if _same_file(real, p)), None)
        if other is not None:
            raise ConfigError(out.flag, "", f"{out.path} is also written by {other.flag}")
        _check_directory(out.flag, real.parent, out.path, real)
        seen.append((out, real))


@contextlib.contextmanager
def writing(flag: str, path: str | Path) -> Iterator[None]:
    """An error while writing ``path`` (the disk filled up, say) as one line naming ``flag`` and ``path``."""
    try:
        yield
    except OSError as exc:
        raise ConfigError(flag, "", f"cannot write {path}: {exc.strerror or exc}") from None
