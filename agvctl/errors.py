"""Exceptions raised by agvctl, and the one line a report gives an exception.

Every error a user can cause with a file or a flag is a :class:`ConfigError`; its message is one line of the form
``"<file>: <key.path>: <problem>"`` and the CLI prints it as is and exits with code 2.
"""

from __future__ import annotations

import traceback
from pathlib import Path

__all__ = [
    "AgvctlError",
    "ConfigError",
    "PlanningError",
    "caused_by_interrupt",
    "exception_line",
    "expect_instance",
    "note_interrupt",
]


class AgvctlError(Exception):
    """Base class of every agvctl error. Its message is one line: line breaks and other control characters in
    it (say from a key or a file name) are shown escaped, as ``\\n``."""

    def __str__(self) -> str:
        text = super().__str__()
        return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


class ConfigError(AgvctlError, ValueError):
    """Bad input: a file, key or value that cannot be used. The message is one line naming where.

    A :class:`ValueError` too, so code that expects one for a bad value still catches it.

    Parameters
    ----------
    source : str
        Where the input came from: a file's path, an option (``--set``), or a function or class given a bad
        argument in Python (``PoseEkf``).
    key : str
        The dotted key or the argument (``controller.horizon``); ``""`` when the whole source is bad.
    problem : str
        What is wrong, with the value found: ``must be >= 1 (got 0)``.

    Examples
    --------
    >>> raise ConfigError("experiments/square.toml", "controller.horizon", "must be >= 1 (got 0)")
    Traceback (most recent call last):
    ...
    agvctl.errors.ConfigError: experiments/square.toml: controller.horizon: must be >= 1 (got 0)
    """

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        self.problem = problem
        where = f"{source}: {key}" if key else source
        super().__init__(f"{where}: {problem}")


class PlanningError(AgvctlError):
    """A trajectory could not be planned within the limits."""


def exception_line(exc: BaseException, limit: int = 300) -> str:
    """An exception's type, message and innermost frame on one line, as the reports of ``check`` and ``fuzz`` name a
    run that raised.

    Parameters
    ----------
    exc : BaseException
        The exception, with its traceback if it was raised.
    limit : int
        The most characters of the line; a longer one is cut and ends in ``…``.

    Returns
    -------
    str
        ``"RuntimeError: boom (at my_controller.py:12)"``, whitespace (line breaks included) collapsed.
    """
    frames = traceback.extract_tb(exc.__traceback__) if exc.__traceback__ else []
    at = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    text = " ".join(f"{type(exc).__name__}: {exc}{at}".split())
    return text if len(text) <= limit else text[: limit - 1] + "…"


def expect_instance(value: object, cls: type | tuple[type, ...], source: str, argument: str) -> None:
    """Refuse an argument of the wrong type in one line naming the function or class and the argument.

    The public functions and classes check their arguments so, as the file loaders name a key.

    Parameters
    ----------
    value : object
        The argument.
    cls : type or tuple of type
        The type (or types) it must be an instance of.
    source : str
        The function or class that takes it, e.g. ``PoseEkf``.
    argument : str
        The argument's name.

    Raises
    ------
    ConfigError
        ``"PoseEkf: vehicle: expected a VehicleParams (got 'x')"`` (the value's repr cut to 60 characters).
    """
    if not isinstance(value, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        shown = repr(value)
        raise ConfigError(
            source, argument, f"expected a {names} (got {shown if len(shown) <= 60 else shown[:59] + '…'})"
        )


_INTERRUPTS = {"noted": False}
"""Whether the command line noted an interrupt (SIGINT) in this process (:func:`note_interrupt`)."""


def note_interrupt() -> None:
    """Note that this process was interrupted (SIGINT). The command line's SIGINT handler calls it before raising
    ``KeyboardInterrupt``, so that an error a library raises instead while the interrupt unwinds it (matplotlib's
    drawing can turn one into a ``ValueError``) is still known for an interruption (:func:`caused_by_interrupt`)."""
    _INTERRUPTS["noted"] = True


def caused_by_interrupt(exc: BaseException | None) -> bool:
    """Whether ``exc`` comes from an interrupt: a ``KeyboardInterrupt``, an exception caused by one (an interrupt
    inside an import can surface as another error with the interrupt as its cause), or any exception after the
    command line noted an interrupt (:func:`note_interrupt`).

    Parameters
    ----------
    exc : BaseException or None
        The exception caught.

    Returns
    -------
    bool
        True if it is, or follows, an interrupt: the caller lets it stop the command rather than report it as a
        run's error.
    """
    if exc is not None and _INTERRUPTS["noted"]:
        return True
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False
