"""Output folders and files written beside their place and moved into place together, only once all is written.

A command that writes an output folder (``run --out``, ``check --report-dir``, ``fuzz --out``) writes it into a
temporary folder beside it (``.<name>.<random>.tmp``) and its output files into temporary files beside them; when
everything is written, :meth:`Staging.commit` moves them into place, the folder replacing any old one whole. So an
error or an interrupt leaves no half-written output, two runs into one folder never mix their files, and a re-run
leaves no stale file of an earlier one (a plot it no longer draws, a failure it no longer finds).

Every path is resolved against the real file system first (:func:`agvctl.fileio.real_path`), and the tool works on
the resolved path only. Only a folder that is empty or an agvctl output is replaced: it holds the marker file
:data:`MARKER`, which lists every file the command wrote with its SHA-256, and nothing else, each file unchanged. A
folder into which something else came since (a build's objects, a user's notes, an edited file) is refused, as any
other folder is, before anything runs (:func:`check_replaceable`), and so is a folder holding an input of the command.
A marker without a list (written by an earlier agvctl, or by a command that adds to its folder as it goes) marks the
folder as an output whole. The commit checks again on the folder it has just moved aside, and puts back one
that is no longer an agvctl output. Only a regular file is replaced by an output file. A SIGINT during the moves is
held until they are done: the old folder is never lost half-way.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import shutil
import signal
import stat
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import FrameType

from agvctl.cli.outputs import writing
from agvctl.errors import ConfigError
from agvctl.fileio import (
    check_replaceable_file,
    make_folders,
    real_path,
    remove_empty_folders,
    temporary_prefix,
)

__all__ = ["MARKER", "Staging", "check_replaceable", "staged_outputs"]

MARKER = ".agvctl-output"
"""The file that marks a folder as an agvctl output, which the next run into it may replace whole."""


_FILES = "files "
"""The marker's line that opens its list of files: ``files <count>``, then ``<sha256>  <relative path>`` each."""


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _marker_text(command: str, folder: Path) -> str:
    """The marker of ``folder`` as written: what it is, and every file in it with its SHA-256."""
    files = sorted((p.relative_to(folder).as_posix(), p) for p in folder.rglob("*") if p.is_file() and p.name != MARKER)
    lines = [
        f"an output folder of agvctl {command}: the next run into it replaces it whole, as long as it holds only the "
        "files below, unchanged",
        f"{_FILES}{len(files)}",
        *(f"{_sha256(path)}  {name}" for name, path in files),
    ]
    return "\n".join(lines) + "\n"


def _foreign(folder: Path) -> str | None:
    """Why ``folder`` is not an agvctl output that may be replaced (None: it is one, or it is empty).

    An output holds the marker as a regular file (a symbolic link named so does not count); where the marker lists
    files, the folder holds no other file and each listed file unchanged.
    """
    try:
        marker = os.lstat(folder / MARKER).st_mode
    except FileNotFoundError:
        return None if not any(folder.iterdir()) else "files that are not an agvctl output"
    if not stat.S_ISREG(marker):
        return "files that are not an agvctl output"
    lines = (folder / MARKER).read_text(encoding="utf-8", errors="replace").splitlines()
    if not any(line.startswith(_FILES) for line in lines):
        return None  # a marker without a list: the folder is an output whole
    start = next(i for i, line in enumerate(lines) if line.startswith(_FILES))
    listed: dict[str, str] = {}
    for line in lines[start + 1 :]:
        digest, _, name = line.partition("  ")
        listed[name] = digest
    for root, dirs, names in os.walk(folder):
        dirs.sort()
        for name in sorted(names) + [d for d in dirs if os.path.islink(os.path.join(root, d))]:
            path = Path(root, name)
            relative = path.relative_to(folder).as_posix()
            if relative == MARKER:
                continue
            if relative not in listed or not stat.S_ISREG(os.lstat(path).st_mode):
                return f"{relative}, which agvctl did not write there"
            if _sha256(path) != listed[relative]:
                return f"{relative}, changed since agvctl wrote it"
    return None


def _is_ours(folder: Path) -> bool:
    """``folder`` is empty or an agvctl output that may be replaced (see :func:`_foreign`)."""
    return _foreign(folder) is None


def check_replaceable(flag: str, directory: str | Path, inputs: Iterable[str | Path]) -> None:
    """Refuse an output folder the command may not replace: one holding files but not an agvctl output, or one
    holding an input of the command (both judged on the real path, ``..`` and symbolic links resolved).

    Parameters
    ----------
    flag : str
        The flag that names the folder, for the message.
    directory : str or Path
        The folder as given.
    inputs : iterable of str or Path
        The files the command reads.

    Raises
    ------
    ConfigError
        One line naming the flag and the folder as given.
    """
    with writing(flag, directory):
        d = real_path(directory)
    if not d.is_dir():
        return
    for p in inputs:
        with contextlib.suppress(OSError):
            if d in real_path(p).parents:
                raise ConfigError(flag, "", f"{directory} holds {p}, an input of this command; refusing to replace it")
    foreign = _foreign(d)
    if foreign is not None:
        advice = "remove it" if foreign.startswith("files") else "move it out"
        raise ConfigError(
            flag, "", f"{directory} holds {foreign}; refusing to replace it ({advice}, or choose another folder)"
        )


@contextlib.contextmanager
def _interrupts_held() -> Iterator[None]:
    """SIGINT held off until the block ends, then raised as KeyboardInterrupt (in the main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []

    def hold(signum: int, frame: FrameType | None) -> None:
        caught.append(signum)

    previous = signal.signal(signal.SIGINT, hold)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def _not_ours(final: Path) -> OSError:
    return OSError(
        errno.ENOTEMPTY,
        "it is no longer an agvctl output (something else is there now); refusing to replace it",
        str(final),
    )


def _swap_in(staged: Path, final: Path) -> None:
    """Move the folder ``staged`` to the resolved path ``final``, replacing an old agvctl output there whole.

    The rename alone replaces nothing or an empty folder (the kernel refuses a folder that holds anything, and
    anything that is not a folder). An old folder that holds files is first moved aside, and replaced only if what
    was moved holds the marker; if not (something else was put there since the check), it is moved back.
    """
    try:
        os.rename(staged, final)
        return
    except OSError as exc:
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
            raise
    aside = Path(tempfile.mkdtemp(prefix=temporary_prefix(final.name), suffix=".old", dir=final.parent))
    old = aside / final.name
    os.rename(final, old)
    if old.is_symlink() or not old.is_dir() or not _is_ours(old):
        try:
            os.rename(old, final)
            aside.rmdir()
        except OSError:
            raise OSError(
                errno.ENOTEMPTY,
                f"{final} is no longer an agvctl output and something new is in its place; it is kept as {old}",
                str(final),
            ) from None
        raise _not_ours(final)
    try:
        os.rename(staged, final)
    except OSError:
        with contextlib.suppress(OSError):
            os.rename(old, final)
            aside.rmdir()
        raise
    shutil.rmtree(aside, ignore_errors=True)


class Staging:
    """The output folders and files of one command, written in temporary places until :meth:`commit`.

    Parameters
    ----------
    command : str
        The command's name, written into each folder's marker file.
    """

    def __init__(self, command: str) -> None:
        self.command = command
        self._dirs: list[tuple[str, Path, Path]] = []  # (flag, resolved final, staged)
        self._files: list[tuple[str, Path, Path]] = []
        self._made: list[Path] = []  # folders made for the outputs

    def directory(self, flag: str, final: str | Path) -> Path:
        """A new temporary folder beside ``final`` to write its files into; it becomes ``final`` on commit.

        Parameters
        ----------
        flag : str
            The flag that names the folder, for messages.
        final : str or Path
            The folder as given: resolved (:func:`~agvctl.fileio.real_path`) and refused unless it is missing,
            empty or an agvctl output.

        Returns
        -------
        Path
            The temporary folder, holding the marker file.
        """
        check_replaceable(flag, final, ())
        with writing(flag, final):
            real = real_path(final)
            if real.exists() and not real.is_dir():
                raise OSError(errno.ENOTDIR, f"{final} exists and is not a folder", str(final))
            self._made += make_folders(real.parent)
            staged = Path(tempfile.mkdtemp(prefix=temporary_prefix(real.name), suffix=".tmp", dir=real.parent))
            self._dirs.append((flag, real, staged))
            (staged / MARKER).write_text(
                f"an output folder of agvctl {self.command}: the next run into it replaces it whole\n",
                encoding="utf-8",
            )
        return staged

    def write_text(self, flag: str, final: str | Path, text: str) -> None:
        """Write ``text`` for the file ``final``: into a staged folder when ``final`` lies in one, else into a
        temporary file beside it (only a regular file is replaced there on commit).

        Parameters
        ----------
        flag : str
            The flag that names the file, for messages.
        final : str or Path
            The file as given.
        text : str
            Its contents (UTF-8).
        """
        with writing(flag, final):
            real = real_path(final)
            for _flag, d, staged in self._dirs:
                if d in real.parents:
                    target = staged / real.relative_to(d)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_text(text, encoding="utf-8")
                    return
            check_replaceable_file(real)
            self._made += make_folders(real.parent)
            fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(real.name), suffix=".tmp", dir=real.parent)
            self._files.append((flag, real, Path(tmp)))
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the permissions open() would
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
                fh.write(text)

    def commit(self) -> None:
        """Move every staged file and folder into place (a SIGINT meanwhile is held until all are moved).

        Each target is checked again first (a regular file or nothing for a file; nothing, an empty folder or an
        agvctl output for a folder), and each folder again on what is moved aside.
        """
        with _interrupts_held():
            for flag, final, _staged in self._files:
                with writing(flag, final):
                    check_replaceable_file(final)
            for flag, final, _staged in self._dirs:
                with writing(flag, final):
                    if final.is_symlink() or (final.exists() and not (final.is_dir() and _is_ours(final))):
                        raise _not_ours(final)
            for flag, final, staged in self._files:
                with writing(flag, final):
                    os.replace(staged, final)
            for flag, final, staged in self._dirs:
                with writing(flag, final):
                    (staged / MARKER).write_text(_marker_text(self.command, staged), encoding="utf-8")
                    _swap_in(staged, final)
            self._files, self._dirs, self._made = [], [], []

    def discard(self) -> None:
        """Remove whatever is still staged (nothing after :meth:`commit`), and the folders made for it."""
        with _interrupts_held():
            for _flag, _final, staged in self._files:
                with contextlib.suppress(FileNotFoundError):
                    staged.unlink()
            for _flag, _final, staged in self._dirs:
                shutil.rmtree(staged, ignore_errors=True)
            remove_empty_folders(self._made)
            self._files, self._dirs, self._made = [], [], []


@contextlib.contextmanager
def staged_outputs(command: str) -> Iterator[Staging]:
    """A :class:`Staging` committed when the block completes and discarded when it raises (or is interrupted).

    Parameters
    ----------
    command : str
        The command's name, written into each folder's marker file.

    Yields
    ------
    Staging
        The staging to write the outputs through.
    """
    staging = Staging(command)
    try:
        yield staging
        staging.commit()
    finally:
        staging.discard()
