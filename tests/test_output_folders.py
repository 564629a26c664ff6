"""Output folders are whole: each command writing one (``run --out``, ``check --report-dir``, ``fuzz --out``) writes
it beside its place and moves it there once everything is written, replacing an old agvctl output whole — so an
error or an interrupt leaves the old folder as it was and no temporary one, two runs never mix their files and a
re-run leaves no stale file. A folder that holds files but is not an agvctl output, an output into which something
else came since, or a folder that holds an input, is refused before anything runs (one line, exit 2). An output that
cannot be written stops the command before it runs."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path
from typing import Any

import pytest
from cli_runs import one_line, run

from agvctl.cli import run_cmd
from agvctl.cli.staging import MARKER, Staging, staged_outputs

ROOT = Path(__file__).resolve().parent.parent
TRAJECTORY = ROOT / "trajectories" / "line.toml"
FUZZ = 'seed = 1\nscenarios = 1\ncontrollers = ["ramsete"]\nsettle_s = 0.5\n'


def _experiment(d: Path) -> Path:
    shutil.copy(TRAJECTORY, d / "line.toml")
    (d / "ok.toml").write_text('name = "ok"\ntrajectory = "line.toml"\nsettle_s = 0.5\n', encoding="utf-8")
    return d / "ok.toml"


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def _no_temporaries(d: Path) -> None:
    left = [p.name for p in d.iterdir() if p.name.startswith(".") and p.name.endswith((".tmp", ".old"))]
    assert left == [], left


def test_a_rerun_into_an_output_folder_replaces_it_whole(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp, out = _experiment(tmp_path), tmp_path / "out"
    assert run(capsys, "run", exp, "--out", out)[0] == 0
    assert (out / "path.png").is_file() and (out / MARKER).is_file()
    assert run(capsys, "run", exp, "--out", out, "--no-plot")[0] == 0  # the first run's plots are gone
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [MARKER, "log.csv", "summary.json", "experiment.toml", "plant_vehicle.toml"]
    )
    _no_temporaries(tmp_path)


def test_a_fuzz_rerun_leaves_no_stale_failure_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "fz.toml").write_text(FUZZ)
    out = tmp_path / "out"
    argv = ["fuzz", tmp_path / "fz.toml", "--out", out, "--jobs", "1", "--no-plot", "--junit", out / "j.xml"]
    with staged_outputs("fuzz") as staging:  # an earlier run's folder, with a failure this run does not find
        failures = staging.directory("--out", out) / "failures"
        failures.mkdir()
        (failures / "s9_00000_ramsete.toml").write_text("an earlier run's failure\n")
    first = run(capsys, *argv)[0]
    assert first in (0, 1) and (out / "summary.json").is_file() and (out / "j.xml").is_file()
    assert not (out / "failures" / "s9_00000_ramsete.toml").exists() and (out / "j.xml").is_file()
    _no_temporaries(tmp_path)


@pytest.mark.parametrize("command", ["run", "fuzz"])
def test_a_folder_that_is_not_an_agvctl_output_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    exp = _experiment(tmp_path)
    (tmp_path / "fz.toml").write_text(FUZZ)
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "notes.txt").write_text("the user's own file\n")
    before = _files(tmp_path)
    argv = ["run", exp] if command == "run" else ["fuzz", tmp_path / "fz.toml", "--jobs", "1"]
    code, out, err = run(capsys, *argv, "--out", theirs)
    assert code == 2 and out == ""
    one_line(err, f"agvctl: --out: {theirs} holds files that are not an agvctl output; refusing to replace it")
    assert _files(tmp_path) == before


@pytest.mark.parametrize("change", ["added", "edited", "linked"])
def test_an_output_folder_that_holds_anything_agvctl_did_not_write_there_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: str
) -> None:
    """A build's object beside generated code, notes, an edited file, a link in place of a file: the user's, so the
    rerun refuses to replace the folder (one line naming the file, exit 2) and changes nothing."""
    exp, out = _experiment(tmp_path), tmp_path / "out"
    assert run(capsys, "run", exp, "--out", out, "--no-plot")[0] == 0
    if change == "added":
        (out / "notes").mkdir()
        (out / "notes" / "mine.txt").write_text("the user's own notes\n")
        named = "notes/mine.txt, which agvctl did not write there"
    elif change == "edited":
        (out / "experiment.toml").write_text("# the user's edit\n", encoding="utf-8")
        named = "experiment.toml, changed since agvctl wrote it"
    else:
        (out / "log.csv").unlink()
        (tmp_path / "elsewhere.csv").write_text("the user's own log\n")
        (out / "log.csv").symlink_to(tmp_path / "elsewhere.csv")
        named = "log.csv, which agvctl did not write there"
    before = _files(tmp_path)
    code, _, err = run(capsys, "run", exp, "--out", out, "--no-plot")
    assert code == 2
    one_line(err, f"agvctl: --out: {out} holds {named}; refusing to replace it (move it out, or choose another")
    assert _files(tmp_path) == before


def test_a_folder_holding_an_input_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    exp = _experiment(tmp_path)
    assert run(capsys, "run", exp, "--out", out, "--no-plot")[0] == 0
    inner = _experiment(out)  # an experiment kept in an earlier run's output folder
    before = _files(tmp_path)
    code, _, err = run(capsys, "run", inner, "--out", out, "--no-plot")
    assert code == 2
    one_line(err, f"agvctl: --out: {out} holds ", "an input of this command; refusing to replace it")
    assert _files(tmp_path) == before


@pytest.mark.parametrize("failure", [OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()])
def test_a_run_stopped_while_writing_leaves_the_old_folder_as_it_was(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], failure: BaseException
) -> None:
    exp, out = _experiment(tmp_path), tmp_path / "out"
    assert run(capsys, "run", exp, "--out", out, "--no-plot")[0] == 0
    before = _files(tmp_path)
    real = run_cmd.write_run_outputs

    def half_written(*args: Any, **kwargs: Any) -> list[Path]:
        real(*args, **{**kwargs, "plots": False})
        raise failure

    monkeypatch.setattr(run_cmd, "write_run_outputs", half_written)
    code, _, err = run(capsys, "run", exp, "--out", out)
    if isinstance(failure, KeyboardInterrupt):
        assert code == 130
        one_line(err, "agvctl: interrupted")
    else:
        assert code == 2
        one_line(err, f"agvctl: --out: cannot write {out}: No space left on device")
    assert ".tmp" not in err and _files(tmp_path) == before
    _no_temporaries(tmp_path)


def test_two_runs_into_one_folder_never_mix_their_files(tmp_path: Path) -> None:
    out = tmp_path / "out"
    first, second = Staging("run"), Staging("run")
    (first.directory("--out", out) / "a.txt").write_text("first")
    (second.directory("--out", out) / "b.txt").write_text("second")
    first.commit()
    second.commit()
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "b.txt"]
    _no_temporaries(tmp_path)


def test_a_staged_file_is_written_in_place_only_on_commit(tmp_path: Path) -> None:
    target = tmp_path / "r.xml"
    with pytest.raises(RuntimeError), staged_outputs("check") as staging:
        staging.write_text("--junit", target, "<xml/>")
        raise RuntimeError("a later output failed")
    assert list(tmp_path.iterdir()) == []
    with staged_outputs("check") as staging:
        staging.write_text("--junit", target, "<xml/>")
    assert target.read_text() == "<xml/>" and [p.name for p in tmp_path.iterdir()] == ["r.xml"]


@pytest.mark.parametrize(
    ("argv", "flag", "where"),
    [
        (["fuzz", "{fz}", "--jobs", "1", "--out", "{d}/out", "--junit", "/proc/j.xml"], "--junit", "/proc/j.xml"),
        (["fuzz", "{fz}", "--jobs", "1", "--out", "/proc/fuzz-out"], "--out", "/proc/fuzz-out"),
        (
            [
                "simulate",
                "--duration",
                "0.2",
                "--da-left",
                "1",
                "--da-right",
                "1",
                "--out",
                "{d}/log.csv",
                "--plot",
                "/proc/p.png",
            ],
            "--plot",
            "/proc/p.png",
        ),  # fmt: skip
        (["run", "{exp}", "--out", "/proc/run-out"], "--out", "/proc/run-out"),
    ],
    ids=["fuzz --junit", "fuzz --out", "simulate --plot", "run --out"],
)
def test_an_output_that_cannot_be_written_is_found_before_anything_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], flag: str, where: str
) -> None:
    exp = _experiment(tmp_path)
    (tmp_path / "fz.toml").write_text(FUZZ)
    before = _files(tmp_path)
    code, out, err = run(capsys, *(a.format(d=tmp_path, fz=tmp_path / "fz.toml", exp=exp) for a in argv))
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {flag}: ", where)
    assert ".tmp" not in err and _files(tmp_path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fz.toml", "line.toml", "ok.toml"]
