"""Outputs are safe: a name never takes a default output folder outside its root, an output never replaces an
input of the same command or another output, every output is checked writable before anything runs, and an error
while writing names the flag and the user's path (never a temporary file). Each refusal is one line, exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from agvctl.cli import main

ROOT = Path(__file__).resolve().parent.parent
TRAJECTORY = ROOT / "trajectories" / "line.toml"


def run(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _one_line(err: str, *parts: str) -> None:
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for part in parts:
        assert part in err, err


def _experiment(d: Path, name: str = "ok", file: str = "ok.toml") -> Path:
    d.mkdir(parents=True, exist_ok=True)
    shutil.copy(TRAJECTORY, d / "line.toml")
    path = d / file
    path.write_text(f'name = "{name}"\ntrajectory = "line.toml"\nsettle_s = 0.5\n', encoding="utf-8")
    return path


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


# -- names ------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["/tmp/agvctl-escaped", "../../escaped", "", ".", "..", "a\\b", "a/b"])
def test_an_experiment_name_that_is_not_a_plain_folder_name_is_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    work = tmp_path / "a" / "b"
    exp = _experiment(work, name=name.replace("\\", "\\\\"))
    monkeypatch.chdir(work)
    before = _files(tmp_path)
    code, out, err = run(capsys, "run", exp, "--no-plot")
    assert code == 2 and out == ""
    _one_line(err, str(exp), "name: must be a plain name")
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
    _one_line(err, str(config), "name: must be a plain name")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fz.toml"]
