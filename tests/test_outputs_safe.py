"""Outputs are safe: a name never takes a default output folder outside its root, an output never replaces an
input of the same command or another output, every output is checked writable before anything runs, and an error
while writing names the flag and the user's path (never a temporary file). Each refusal is one line, exit 2."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest
from cli_runs import one_line, run

from agvctl import fileio
from agvctl.params import default_vehicle_path

ROOT = Path(__file__).resolve().parent.parent
TRAJECTORY = ROOT / "trajectories" / "line.toml"


def _experiment(d: Path, name: str = "ok", file: str = "ok.toml") -> Path:
    d.mkdir(parents=True, exist_ok=True)
    shutil.copy(TRAJECTORY, d / "line.toml")
    path = d / file
    path.write_text(f'name = "{name}"\ntrajectory = "line.toml"\nsettle_s = 0.5\n', encoding="utf-8")
    return path


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


# -- names ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "name", ["/tmp/agvctl-escaped", "../../escaped", "", ".", "..", "a\\b", "a/b", " ", ".agvctl-output", "x" * 300]
)
def test_an_experiment_name_that_is_not_a_plain_folder_name_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    work = tmp_path / "a" / "b"
    exp = _experiment(work, name=name.replace("\\", "\\\\"))
    monkeypatch.chdir(work)
    before = _files(tmp_path)
    code, out, err = run(capsys, "run", exp, "--no-plot")
    assert code == 2 and out == ""
    one_line(err, str(exp), "name: must be a plain name")
    assert _files(tmp_path) == before and not (work / "out").exists()
    assert not Path("/tmp/agvctl-escaped").exists()
    assert run(capsys, "check", exp, "--jobs", "1")[0] == 2  # the same rule wherever the name is read


def test_a_fuzz_name_that_is_not_a_plain_folder_name_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "fz.toml"
    config.write_text('name = "../../escaped"\nseed = 1\nscenarios = 1\ncontrollers = ["ramsete"]\n')
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "fuzz", config, "--jobs", "1")
    assert code == 2
    one_line(err, str(config), "name: must be a plain name")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fz.toml"]


# -- an output never replaces an input ------------------------------------------------------------------------


def _vehicle(d: Path) -> Path:
    shutil.copy(default_vehicle_path(), d / "vehicle.toml")
    return d / "vehicle.toml"


def _profile(d: Path) -> Path:
    (d / "profile.csv").write_text("t_s,da_left_v,da_right_v\n0.0,1.0,1.0\n")
    return d / "profile.csv"


CASES = {
    "check --junit": lambda d: ("--junit", ["check", _experiment(d), "--junit", d / "ok.toml"]),
    "check --json (its trajectory)": lambda d: ("--json", ["check", _experiment(d), "--json", d / "line.toml"]),
    "run --out (its directory)": lambda d: (
        "--out",
        ["run", _experiment(d, file="experiment.toml"), "--out", d, "--no-plot"],
    ),
    "plan --out": lambda d: ("--out", ["plan", shutil.copy(TRAJECTORY, d / "p.toml"), "--out", d / "p.toml"]),
    "plan --plot (another name)": lambda d: (
        "--plot",
        ["plan", shutil.copy(TRAJECTORY, d / "p.toml"), "--plot", d / "sub" / ".." / "p.toml"],
    ),
    "simulate --out": lambda d: (
        "--out",
        ["simulate", "--duration", "0.2", "--input", _profile(d), "--out", d / "profile.csv"],
    ),
    "tune --out": lambda d: ("--out", ["tune", "--vehicle", _vehicle(d), "--out", d / "vehicle.toml"]),
    "identify --out": lambda d: (
        "--out",
        ["identify", "mass", "--simulate", "--vehicle", _vehicle(d), "--out", d / "vehicle.toml"],
    ),
    "fuzz --junit": lambda d: (
        "--junit",
        ["fuzz", _fuzz_config(d), "--junit", d / "fz.toml", "--out", d / "out"],
    ),
}


def _fuzz_config(d: Path) -> Path:
    (d / "fz.toml").write_text('seed = 1\nscenarios = 1\ncontrollers = ["ramsete"]\nsettle_s = 0.5\n')
    return d / "fz.toml"


@pytest.mark.parametrize("case", list(CASES))
def test_an_output_that_is_an_input_of_the_same_command_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], case: str
) -> None:
    flag, argv = CASES[case](tmp_path)
    before = _files(tmp_path)
    code, out, err = run(capsys, *argv)
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {flag}: ", "is an input of this command")
    assert _files(tmp_path) == before  # the input untouched, nothing else written


def test_two_outputs_on_one_file_are_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp = _experiment(tmp_path)
    code, _, err = run(capsys, "check", exp, "--junit", tmp_path / "r", "--json", tmp_path / "r")
    assert code == 2
    one_line(err, "--json: ", "is also written by --junit")
    assert not (tmp_path / "r").exists()


# -- every output checked before anything runs, written atomically ----------------------------------------------


@pytest.mark.parametrize(
    ("where", "problem"),
    [("/proc/r.json", "cannot create a file in /proc"), ("afile/r.json", "afile is not a directory")],
)
def test_an_output_that_cannot_be_written_stops_the_check_before_it_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], where: str, problem: str
) -> None:
    exp = _experiment(tmp_path)
    (tmp_path / "afile").write_text("a file, not a directory\n")
    monkeypatch.chdir(tmp_path)
    before = _files(tmp_path)
    code, out, err = run(capsys, "check", exp, "--junit", "r.xml", "--json", where, "--jobs", "1")
    assert code == 2 and out == ""
    one_line(err, f"agvctl: --json: cannot write {where}: {problem}")
    assert _files(tmp_path) == before and not (tmp_path / "r.xml").exists()


def test_an_error_while_writing_names_the_flag_and_the_users_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    exp = _experiment(tmp_path)
    real_replace = os.replace

    def disk_full(src: str, dst: str) -> None:
        if str(dst).endswith("r.json"):
            raise OSError(errno.ENOSPC, "No space left on device", src, None, dst)
        real_replace(src, dst)

    monkeypatch.setattr(fileio.os, "replace", disk_full)
    code, _, err = run(capsys, "check", exp, "--json", tmp_path / "r.json", "--jobs", "1")
    assert code == 2
    one_line(err, f"agvctl: --json: cannot write {tmp_path / 'r.json'}: No space left on device")
    assert ".tmp" not in err
    assert not any(p.name.startswith(".r.json.") for p in tmp_path.iterdir())  # no temporary file left


def test_an_atomic_writes_error_names_the_file_asked_for(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def fails(src: str, dst: str) -> None:
        raise OSError(errno.EIO, "Input/output error", src)

    monkeypatch.setattr(fileio.os, "replace", fails)
    with pytest.raises(OSError) as info:
        fileio.write_text(tmp_path / "out.txt", "text")
    assert info.value.filename == str(tmp_path / "out.txt") and info.value.errno == errno.EIO
    assert list(tmp_path.iterdir()) == []


# -- seeds --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("procedure", ["mass", "friction", "umbmark"])
def test_a_negative_seed_is_refused(procedure: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "v.toml"
    code, printed, err = run(capsys, "identify", procedure, "--simulate", "--seed", "-1", "--out", out)
    assert code == 2 and printed == ""
    one_line(err, "agvctl: --seed: must be >= 0 (got -1)")
    assert not out.exists()
