"""Running the ``agvctl`` command line in-process in tests, and the one-line error it must give."""

from __future__ import annotations

import pytest

from agvctl.cli import main


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    """``agvctl *argv``: its exit code, standard output and standard error."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line(err: str, *parts: str) -> None:
    """``err`` is one line, no traceback, holding every one of ``parts``."""
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for part in parts:
        assert part in err, err
