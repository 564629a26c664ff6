"""A command's progress on stderr: a bar (tqdm's) on a terminal; in a log (CI, a pipe), a plain line every tenth of
the runs for the commands that count runs, and nothing for the others, so logs hold no carriage returns."""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import Any, TextIO

__all__ = ["Progress"]


class Progress:
    """Call with the work done and the work in all (``progress(done, total)``, or a fraction ``progress(0.4)``);
    ``close()``, or the end of a ``with`` block, ends it.

    Parameters
    ----------
    label : str
        What is in progress, shown before the bar and at the start of each line in a log, e.g. ``"fuzz"``.
    unit : str or None
        What is counted (``"runs"``): in a log, a line ``"fuzz: 30 of 300 runs, 12 s"`` every tenth of them. None:
        a fraction, shown as a bar on a terminal and not at all in a log.
    stream : text stream or None
        Where to write (None: ``sys.stderr``).
    """

    def __init__(self, label: str, unit: str | None = None, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.label = label
        self.unit = unit
        self.terminal = hasattr(self.stream, "isatty") and self.stream.isatty()
        self._bar: Any = None
        self._t0 = time.perf_counter()
        self._tenths = 0

    def __call__(self, done: float, total: float = 1.0) -> None:
        if self.terminal:
            if self._bar is None:
                from tqdm import tqdm  # only on a terminal: a command in a log never imports it

                fraction = self.unit is None
                self._bar = tqdm(
                    total=total,
                    desc=self.label,
                    unit=self.unit or "",
                    file=self.stream,
                    dynamic_ncols=True,
                    bar_format="{desc}: {bar} {percentage:3.0f}%  {elapsed}" if fraction else None,
                )
            if self._bar.total != total:
                self._bar.total = total
            self._bar.update(done - self._bar.n)
        elif self.unit is not None and total > 0:
            tenths = int(10 * done // total)
            if tenths > self._tenths:
                self._tenths = tenths
                elapsed_s = time.perf_counter() - self._t0
                print(
                    f"{self.label}: {done:g} of {total:g} {self.unit}, {elapsed_s:.0f} s", file=self.stream, flush=True
                )

    def close(self) -> None:
        """End the bar's line (on a terminal); nothing in a log."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, traceback: TracebackType | None
    ) -> None:
        self.close()
