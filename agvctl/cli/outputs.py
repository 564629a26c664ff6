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
import os
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from agvctl.errors import ConfigError
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


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # either does not exist (yet): the same file only by name
        return a.resolve() == b.resolve()


def _nearest_existing(path: Path) -> Path:
    for p in (path, *path.parents):
        if p.exists():
            return p
    return Path(".")


def _check_directory(flag: str, directory: Path, shown: Path) -> None:
    """``directory`` exists or can be made, and a file can be created in it (or in the nearest existing parent)."""
    nearest = _nearest_existing(directory)
    if not nearest.is_dir():
        raise ConfigError(flag, "", f"cannot write {shown}: {nearest} is not a directory")
    try:
        with tempfile.TemporaryFile(dir=nearest):
            pass
    except OSError as exc:
        raise ConfigError(
            flag, "", f"cannot write {shown}: cannot create a file in {nearest} ({exc.strerror})"
        ) from None


def check_outputs(
    outputs: Sequence[Output], inputs: Iterable[str | Path], directories: Sequence[tuple[str, str | Path]] = ()
) -> None:
    """Refuse, before anything runs, outputs that would overwrite an input or each other or cannot be written.

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
    existing = [Path(p) for p in inputs if Path(p).exists()]
    for flag, directory in directories:
        d = Path(directory)
        if d.exists() and not d.is_dir():
            raise ConfigError(flag, "", f"{d} exists and is not a directory")
        _check_directory(flag, d, d)
    seen: list[Output] = []
    for out in outputs:
        if out.path.is_dir():
            raise ConfigError(out.flag, "", f"{out.path} is a directory; expected a file name")
        clash = next((p for p in existing if _same_file(out.path, p)), None)
        if clash is not None:
            also = "" if clash == out.path else f" (the same file as {clash})"
            raise ConfigError(out.flag, "", f"{out.path} is an input of this command{also}; refusing to overwrite it")
        other = next((o for o in seen if _same_file(out.path, o.path)), None)
        if other is not None:
            raise ConfigError(out.flag, "", f"{out.path} is also written by {other.flag}")
        _check_directory(out.flag, out.path.parent, out.path)
        seen.append(out)


@contextlib.contextmanager
def writing(flag: str, path: str | Path) -> Iterator[None]:
    """An error while writing ``path`` (the disk filled up, say) as one line naming ``flag`` and ``path``."""
    try:
        yield
    except OSError as exc:
        raise ConfigError(flag, "", f"cannot write {path}: {exc.strerror or exc}") from None
