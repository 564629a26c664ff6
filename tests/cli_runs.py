"""Running the ``agvctl`` command line in-process in tests, and the one-line error it (and the Python API) must
give."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from agvctl.cli import main
from agvctl.errors import AgvctlError


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


def assert_clean(call: Callable[[], object], *sources: str) -> object:
    """Run ``call``: success, or an AgvctlError of one line that starts with one of ``sources``."""
    try:
        return call()
    except AgvctlError as exc:
        message = str(exc)
        assert len(message.splitlines()) == 1, message
        assert message.startswith(sources), message
        return None


def line_experiment(folder: Path, name: str, old: str, new: str) -> Path:
    """``experiments/line.toml`` with ``old`` replaced by ``new`` (e.g. a ``[controller]`` key added), written into
    ``folder`` as ``name`` with its path file found where it is."""
    text = Path("experiments/line.toml").read_text(encoding="utf-8")
    text = text.replace('"../trajectories/', f'"{Path("trajectories").absolute()}/')
    assert old in text, old
    (folder / name).write_text(text.replace(old, new), encoding="utf-8")
    return folder / name
