"""Exceptions raised by agvctl.

Every error a user can cause with a file or a flag is a :class:`ConfigError`; its message is one line of the form
``"<file>: <key.path>: <problem>"`` and the CLI prints it as is and exits with code 2.
"""

from __future__ import annotations


class AgvctlError(Exception):
    """Base class of every agvctl error. Its message is one line: line breaks and other control characters in
    it (say from a key or a file name) are shown escaped, as ``\\n``."""

    def __str__(self) -> str:
        text = super().__str__()
        return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in text)


class ConfigError(AgvctlError, ValueError):
    """Bad input: a file, key or value that cannot be used. The message is one line naming where."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source = source
        self.key = key
        self.problem = problem
        where = f"{source}: {key}" if key else source
        super().__init__(f"{where}: {problem}")


class PlanningError(AgvctlError):
    """A trajectory could not be planned within the limits."""
