"""``python -m agvctl`` and the ``agvctl`` command: :func:`agvctl.cli.main`, with an interrupt at any moment — while
the package is still being imported, or while an error is printed — one line and exit code 130, never a traceback."""

from __future__ import annotations

import _thread
import atexit
import contextlib
import os
import signal
import sys
import time

from agvctl.errors import caused_by_interrupt, note_interrupt

__all__ = ["EXIT_INTERRUPTED", "console"]

EXIT_INTERRUPTED = 130
"""The exit code after SIGINT (Ctrl-C), 128 + 2 as shells report it."""


def _on_sigint(signum: int, frame: object) -> None:
    """SIGINT: noted (so that whatever error it turns into on its way out is known for it), then raised as Python's
    default handler raises it."""
    note_interrupt()
    raise KeyboardInterrupt


def _send_interrupt(delay_s: float) -> None:
    time.sleep(delay_s)
    os.kill(os.getpid(), signal.SIGINT)


def _redeliver(args: sys.UnraisableHookArgs) -> None:
    """An interrupt that lands in a finaliser or a weak-reference callback is "ignored" by Python (printed, and the
    command goes on): deliver it again, so that it interrupts the command where that can be handled. Any other
    unraisable exception is reported as Python does."""
    if caused_by_interrupt(args.exc_value):  # sent again from another thread, once this hook has returned
        _thread.start_new_thread(_send_interrupt, (0.01,))
        return
    sys.__unraisablehook__(args)


def _main() -> int:
    try:
        from agvctl.cli import main

        return main()
    except BaseException as exc:
        if not caused_by_interrupt(exc):
            raise
        print("agvctl: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def console() -> None:
    """Run the CLI and exit with its code. Once the command is done (its outputs written and its report printed),
    SIGINT is ignored: the interpreter's shutdown is not an interruption of the command."""
    sys.unraisablehook = _redeliver
    signal.signal(signal.SIGINT, _on_sigint)
    code = _main()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if code == EXIT_INTERRUPTED:
        # the outputs are discarded and the workers stopped already; run the exit handlers (multiprocessing's
        # among them) and exit with 130 at once: the interpreter would otherwise end itself by SIGINT when the
        # interrupt went through code a library runs at import time (it counts that one unhandled, caught or not)
        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):
                stream.flush()
        os._exit(EXIT_INTERRUPTED)
    sys.exit(code)


if __name__ == "__main__":
    console()
