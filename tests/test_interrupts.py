"""An interrupt at any moment of ``run``, ``check`` and ``fuzz``: exit code 130 with one line, no traceback, no
partial output, no worker left running — or, when the command had already finished, its whole output and its usual
exit code. The real command line is started as a process group (as a terminal starts it) and sent SIGINT (as
Ctrl-C sends it to the whole group) at moments drawn from a fixed-seed generator over each command's duration; the
check runs on two worker processes, the run and the fuzz in the command's own process."""

from __future__ import annotations

import contextlib
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MOMENTS = 20
SHORT_LINE = '[limits]\nwheel_speed_m_s = 0.8\nwheel_accel_m_s2 = 0.5\n[[segments]]\ntype = "line"\nlength_m = 0.5\n'
QUICK = 'name = "quick"\ntrajectory = "line.toml"\nsettle_s = 0.2\n[controller]\npose = "ramsete"\n'
FUZZ = 'seed = 1\nscenarios = 1\ncontrollers = ["ramsete"]\nsettle_s = 0.2\n'
COMMANDS = {
    "run": ["run", "{d}/quick.toml", "--out", "{o}/out"],
    "check": [
        "check",
        "{d}/quick.toml",
        "{d}/quick.toml",
        "--jobs",
        "2",
        "--junit",
        "{o}/j.xml",
        "--json",
        "{o}/r.json",
    ],
    "fuzz": ["fuzz", "{d}/fz.toml", "--jobs", "1", "--out", "{o}/out", "--junit", "{o}/j.xml", "--no-plot"],
}


def _start(argv: list[str], d: Path, o: Path) -> subprocess.Popen[str]:
    o.mkdir()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.Popen(
        [sys.executable, "-m", "agvctl", *(a.format(d=d, o=o) for a in argv)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        cwd=o,
        env=env,
        start_new_session=True,  # its own process group, with its workers, as a terminal's job
    )


def _tree(o: Path) -> list[str]:
    return sorted(str(p.relative_to(o)) for p in o.rglob("*"))


def _group_gone(pgid: int, timeout_s: float = 5.0) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.05)
    return False


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("inputs")
    (d / "line.toml").write_text(SHORT_LINE)
    (d / "quick.toml").write_text(QUICK)
    (d / "fz.toml").write_text(FUZZ)
    return d


def test_an_interrupt_at_any_moment_exits_130_with_no_partial_output(inputs: Path, tmp_path: Path) -> None:
    complete: dict[str, tuple[int, list[str], float]] = {}
    for name, argv in COMMANDS.items():  # each command uninterrupted: its exit code, its whole output, its duration
        t0 = time.monotonic()
        proc = _start(argv, inputs, tmp_path / f"{name}-whole")
        _, err = proc.communicate(timeout=300)
        assert proc.returncode in (0, 1) and "Traceback" not in err, err
        complete[name] = (proc.returncode, _tree(tmp_path / f"{name}-whole"), time.monotonic() - t0)
    rng = random.Random(20261203)
    for i in range(MOMENTS):
        name = list(COMMANDS)[i % len(COMMANDS)]
        code_whole, tree_whole, duration = complete[name]
        moment = rng.uniform(0.05, duration)
        o = tmp_path / f"{name}-{i}"
        proc = _start(COMMANDS[name], inputs, o)
        time.sleep(moment)
        with contextlib.suppress(ProcessLookupError):  # it may have finished already
            os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        seen = f"{name} interrupted at {moment:.2f} s of {duration:.2f} s: exit {proc.returncode}, stderr {err!r}"
        assert "Traceback" not in err and "Error" not in err.replace("agvctl: ", ""), seen
        assert _group_gone(proc.pid), f"{seen}: a worker is still running"
        tree = _tree(o)
        assert not [p for p in tree if p.rsplit("/", 1)[-1].startswith(".") and ".tmp" in p], f"{seen}: {tree}"
        if proc.returncode == 130:
            assert err.splitlines()[-1:] == ["agvctl: interrupted"], seen
            assert tree in ([], tree_whole), f"{seen}: partial output {tree}"
        else:
            assert proc.returncode == code_whole and tree == tree_whole, f"{seen}: {tree}"


def test_an_interrupt_lost_in_a_finaliser_is_delivered_again() -> None:
    """Python only prints a KeyboardInterrupt raised in a weak-reference callback and goes on; the command's hook
    delivers it again, so the command is interrupted rather than finishing with a traceback on stderr."""
    code = (  # Python's own SIGINT handler, which a child of a background job (SIGINT ignored) would lack
        "import signal, sys, time, weakref\n"
        "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
        "import agvctl.__main__ as entry\n"
        "sys.unraisablehook = entry._redeliver\n"
        "class Held: pass\n"
        "def callback(_):\n"
        "    raise KeyboardInterrupt\n"
        "held = Held(); ref = weakref.ref(held, callback)\n"
        "try:\n"
        "    del held\n"
        "    time.sleep(2.0)\n"
        "    print('went on')\n"
        "except KeyboardInterrupt:\n"
        "    print('interrupted')\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert proc.stdout == "interrupted\n" and proc.stderr == "", proc


def test_an_error_raised_while_an_interrupt_unwinds_stops_the_command_instead_of_being_a_runs_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A library may turn the KeyboardInterrupt passing through it into another error (matplotlib's drawing raises a
    ValueError): after the command line noted the interrupt, that error stops the command, it is not one run's
    result."""
    from agvctl import errors
    from agvctl.checks.executors import InlineExecutor

    def drawing() -> None:
        raise ValueError("Invalid bounding box")

    monkeypatch.setitem(errors._INTERRUPTS, "noted", False)
    assert not errors.caused_by_interrupt(ValueError("a run's own error"))
    assert InlineExecutor().submit(drawing).exception() is not None  # a run's error, kept in its future
    try:
        raise RuntimeError("class creation failed") from KeyboardInterrupt()
    except RuntimeError as exc:
        assert errors.caused_by_interrupt(exc)
    errors.note_interrupt()
    assert errors.caused_by_interrupt(ValueError("Invalid bounding box"))
    with pytest.raises(ValueError):
        InlineExecutor().submit(drawing)
