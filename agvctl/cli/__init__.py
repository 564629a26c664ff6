"""The ``agvctl`` command line: a thin layer over the Python API.

Each subcommand lives in its own module with ``register(subparsers)`` adding its parser and setting
``func=run``, where ``run(args) -> int`` calls the public API and prints. The table of subcommands
(:data:`~agvctl.cli.commands.COMMANDS`) names each module, so only the chosen command's module is imported:
``agvctl --help`` reads the table alone. Exit codes: 0 success, 1 a failed
check, 2 bad input or any other :class:`~agvctl.errors.AgvctlError` (one line on stderr naming the file and
key; no traceback), 3 a run of ``check`` or ``fuzz`` that could not be completed (it raised; reported with every
other run), 130 an interrupt (Ctrl-C: one line, no partial output; see :mod:`agvctl.__main__`).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import warnings
from collections.abc import Sequence
from typing import NoReturn

from agvctl import __version__
from agvctl.cli.commands import COMMANDS
from agvctl.cli.options import add_vehicle_options
from agvctl.errors import AgvctlError, ConfigError

__all__ = ["add_vehicle_options", "main"]

EXIT_OK, EXIT_BAD_INPUT = 0, 2


class _UsageError(AgvctlError):
    """A command line argparse rejects (shown on one line, like every AgvctlError)."""


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line and exit code 2 (no usage dump)."""

    def error(self, message: str) -> NoReturn:
        raise _UsageError(f"{self.prog}: {message}")

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        """Parse as argparse does, then refuse an empty value (``--out ''``): no file, name or address is empty,
        and none may silently mean the default."""
        parsed, extras = super().parse_known_args(args, namespace)
        for action in self._actions:
            value = getattr(parsed, action.dest, None)
            if any(v == "" for v in (value if isinstance(value, list) else [value])):
                name = "/".join(action.option_strings) or str(action.metavar or action.dest)
                self.error(f"argument {name}: must not be empty")
        return parsed, extras


def _chosen_command(argv: Sequence[str]) -> str | None:
    """The subcommand named on the command line: the first argument that is not an option (the top level takes
    no option with a value), or None."""
    for arg in argv:
        if arg == "--":
            return None
        if not arg.startswith("-"):
            return arg
    return None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of the command line: every subcommand listed from the table, and the full parser of ``command``
    alone (its module imported)."""
    parser = _Parser(prog="agvctl", description="Control design and trajectory planning for the IAU AGV.")
    parser.add_argument("--version", action="version", version=f"agvctl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, entry in COMMANDS.items():
        if name == command:
            importlib.import_module(entry.module).register(sub)
        else:
            sub.add_parser(name, help=entry.summary)
    return parser


def _one_line_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int, *args: object, **kwargs: object
) -> None:
    print(f"agvctl: warning: {message}", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line: the ``agvctl`` command's entry point, and how tests call it.

    A bad input or any other :class:`~agvctl.errors.AgvctlError` is one line on stderr (no traceback); warnings
    that a limit leaves little headroom are one line each.

    Parameters
    ----------
    argv : sequence of str or None
        The arguments after the program's name (None: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit code: 0 success, 1 a failed check, 2 bad input, 3 a run of ``check`` or ``fuzz`` that could not be
        completed, 130 an interrupt.

    Examples
    --------
    >>> main(["params", "--help"])  # doctest: +ELLIPSIS
    usage: agvctl params ...
    0
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        parser = build_parser(_chosen_command(argv))
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help and --version print, then exit 0
            return exc.code if isinstance(exc.code, int) else EXIT_OK
        if not getattr(args, "func", None):
            parser.print_help()
            return EXIT_BAD_INPUT
        from agvctl.feasibility import HeadroomWarning  # with the command's libraries, not before --help

        with warnings.catch_warnings():  # advice (limits without headroom) as one line on stderr, never an error
            warnings.simplefilter("always", HeadroomWarning)
            warnings.showwarning = _one_line_warning
            return int(args.func(args))
    except _UsageError as exc:
        print(f"{exc} (see --help)", file=sys.stderr)
        return EXIT_BAD_INPUT
    except AgvctlError as exc:  # a ConfigError, or input the library could not use (e.g. a PlanningError)
        print(f"agvctl: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("agvctl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        # nothing more can be written: point stdout at /dev/null so the interpreter's final flush does not fail
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # a file named on the command line that cannot be read or written
        error = ConfigError(str(exc.filename) if exc.filename else "output", "", exc.strerror or str(exc))
        print(f"agvctl: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
