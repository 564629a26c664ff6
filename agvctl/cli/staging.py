"""Output folders and files written beside their place and moved into place together, only once all is written.

A command that writes an output folder (``run --out``, ``check --report-dir``, ``fuzz --out``) writes it into a
temporary folder beside it (``.<name>.<random>.tmp``) and its output files into temporary files beside them; when
everything is written, :meth:`Staging.commit` moves them into place, the folder replacing any old one whole. So an
error or an interrupt leaves no half-written output, two runs into one folder never mix their files, and a re-run
leaves no stale file of an earlier one (a plot it no longer draws, a failure it no longer finds).

Only a folder that is empty or an agvctl output (it holds the marker file :data:`MARKER`) is replaced; any other
folder is refused before anything runs (:func:`check_replaceable`), and so is a folder holding an input of the
command. A SIGINT during the moves is held until they are done: the old folder is never lost half-way.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterable, Iterator
from pathlib import Path
from types import FrameType

from agvctl.cli.outputs import writing
from agvctl.errors import ConfigError

__all__ = ["MARKER", "Staging", "check_replaceable", "staged_outputs"]

MARKER = ".agvctl-output"
"""The file that marks a folder as an agvctl output, which the next run into it may replace whole."""


def check_replaceable(flag: str, directory: str | Path, inputs: Iterable[str | Path]) -> None:
    """Refuse an output folder the command may not replace: one holding files but not an agvctl output, or one
    holding an input of the command.

    Raises
    ------
    ConfigError
        One line naming the flag and the folder as given.
    """
    d = Path(directory)
    if not d.is_dir():
        return
    inside = next((Path(p) for p in inputs if Path(p).exists() and d.resolve() in Path(p).resolve().parents), None)
    if inside is not None:
        raise ConfigError(flag, "", f"{d} holds {inside}, an input of this command; refusing to replace it")
    if any(d.iterdir()) and not (d / MARKER).is_file():
        raise ConfigError(
            flag,
            "",
            f"{d} holds files that are not an agvctl output; refusing to replace it (remove it, or choose another "
            "folder)",
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


def _swap_in(staged: Path, final: Path) -> None:
    """Move the folder ``staged`` to ``final``, replacing an old folder there whole."""
    if final.is_dir():
        old = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".old", dir=final.parent))
        os.rename(final, old / final.name)
        os.rename(staged, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(staged, final)


class Staging:
    """The output folders and files of one command, written in temporary places until :meth:`commit`."""

    def __init__(self, command: str) -> None:
        self.command = command
        self._dirs: list[tuple[str, Path, Path]] = []  # (flag, final, staged)
        self._files: list[tuple[str, Path, Path]] = []

    def directory(self, flag: str, final: str | Path) -> Path:
        """A new temporary folder beside ``final`` to write its files into; it becomes ``final`` on commit."""
        final = Path(final)
        with writing(flag, final):
            final.parent.mkdir(parents=True, exist_ok=True)
            staged = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent))
            self._dirs.append((flag, final, staged))
            (staged / MARKER).write_text(
                f"an output folder of agvctl {self.command}: the next run into it replaces it whole\n",
                encoding="utf-8",
            )
        return staged

    def write_text(self, flag: str, final: str | Path, text: str) -> None:
        """Write ``text`` for the file ``final``: into a staged folder when ``final`` lies in one, else into a
        temporary file beside it."""
        final = Path(final)
        for _flag, d, staged in self._dirs:
            if d.resolve() in final.resolve().parents:
                with writing(flag, final):
                    target = staged / final.resolve().relative_to(d.resolve())
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_text(text, encoding="utf-8")
                return
        with writing(flag, final):
            final.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=".tmp", dir=final.parent)
            self._files.append((flag, final, Path(tmp)))
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the permissions open() would
            with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
                fh.write(text)

    def commit(self) -> None:
        """Move every staged file and folder into place (a SIGINT meanwhile is held until all are moved)."""
        with _interrupts_held():
            for flag, final, staged in self._files:
                with writing(flag, final):
                    os.replace(staged, final)
            for flag, final, staged in self._dirs:
                with writing(flag, final):
                    _swap_in(staged, final)
            self._files, self._dirs = [], []

    def discard(self) -> None:
        """Remove whatever is still staged (nothing after :meth:`commit`)."""
        with _interrupts_held():
            for _flag, _final, staged in self._files:
                with contextlib.suppress(FileNotFoundError):
                    staged.unlink()
            for _flag, _final, staged in self._dirs:
                shutil.rmtree(staged, ignore_errors=True)
            self._files, self._dirs = [], []


@contextlib.contextmanager
def staged_outputs(command: str) -> Iterator[Staging]:
    """A :class:`Staging` committed when the block completes and discarded when it raises (or is interrupted)."""
    staging = Staging(command)
    try:
        yield staging
        staging.commit()
    finally:
        staging.discard()
