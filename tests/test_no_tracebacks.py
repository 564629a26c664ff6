"""Input the package cannot use is one line naming the file or flag and the key, exit 2, nothing written — never
a traceback: a vehicle that cannot move under default limits, TOML nested too deeply for the parser, a settling time
that would never end."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from cli_runs import one_line, run

from agvctl.errors import ConfigError
from agvctl.params import default_vehicle_path, load_vehicle
from agvctl.planning import load_path, plan

ROOT = Path(__file__).resolve().parent.parent
NO_LIMITS = 'name = "no_limits"\n[[segments]]\ntype = "line"\nlength_m = 1.0\n'


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


# -- a vehicle that cannot move ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("setting", "limit", "why"),
    [
        ("amplifier.voltage_limit_v=0.5", "wheel_speed_m_s", "amplifier.voltage_limit_v = 0.5 V) is below the break"),
        ("da.max_v=0.1", "wheel_speed_m_s", "(da.max_v = 0.1 V through amplifier.gain"),
        ("amplifier.voltage_limit_v=1.5", "wheel_speed_m_s", "none is left for speed"),
        ("amplifier.current_limit_a=2.6", "wheel_accel_m_s2", "amplifier.current_limit_a = 2.6 A"),
    ],
)
def test_plan_with_a_vehicle_that_has_no_default_limit_names_the_vehicle_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], setting: str, limit: str, why: str
) -> None:
    path = tmp_path / "p.toml"
    path.write_text(NO_LIMITS)
    code, out, err = run(capsys, "plan", path, "--set", setting, "--out", tmp_path / "ref.csv")
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {path}: limits.{limit}: no default for this vehicle: ", why)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.toml"]


def test_the_planner_refuses_a_vehicle_that_cannot_move_with_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text(NO_LIMITS)
    vehicle = load_vehicle(None, ["amplifier.voltage_limit_v=0.5"])
    with pytest.raises(ConfigError, match="the vehicle cannot move"):
        plan(load_path(path), vehicle, force=True)


@pytest.mark.parametrize("command", ["run", "check"])
def test_run_and_check_with_a_vehicle_that_cannot_move_areone_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    text = default_vehicle_path().read_text()
    assert "\nvoltage_limit_v = 10.0" in text
    (tmp_path / "weak.toml").write_text(text.replace("\nvoltage_limit_v = 10.0", "\nvoltage_limit_v = 0.5"))
    (tmp_path / "p.toml").write_text(NO_LIMITS)
    exp = tmp_path / "e.toml"
    exp.write_text('name = "weak"\ntrajectory = "p.toml"\nvehicle = "weak.toml"\n')
    before = _files(tmp_path)
    extra = ["--out", tmp_path / "out"] if command == "run" else ["--junit", tmp_path / "r.xml", "--jobs", "1"]
    code, out, err = run(capsys, command, exp, *extra)
    assert code == 2 and out == ""
    one_line(err, "limits.wheel_speed_m_s: no default for this vehicle: the vehicle cannot move", "voltage_limit_v")
    assert _files(tmp_path) == before


# -- TOML nested too deeply ----------------------------------------------------------------------------------------

DEEP = "[" * 3000 + "]" * 3000


@pytest.mark.parametrize(
    ("argv", "file_text"),
    [
        (["check", "{f}", "--junit", "{d}/r.xml"], f'name = "x"\ntrajectory = "t.toml"\na = {DEEP}\n'),
        (["plan", "{f}"], f"a = {DEEP}\n"),
        (["params", "--vehicle", "{f}"], f"a = {DEEP}\n"),
        (["fuzz", "{f}", "--out", "{d}/out"], "seed = 1\nscenarios = 1\nc = " + "{a = " * 600 + "1" + "}" * 600),
    ],
    ids=["check", "plan", "params", "fuzz"],
)
def test_toml_nested_too_deeply_isone_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], file_text: str
) -> None:
    path = tmp_path / "deep.toml"
    path.write_text(file_text)
    code, out, err = run(capsys, *(a.format(f=path, d=tmp_path) for a in argv))
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {path}: malformed TOML: values nested too deeply")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["deep.toml"]


def test_a_set_value_nested_too_deeply_isone_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(capsys, "params", "--set", f"body.mass_kg={DEEP}")
    assert code == 2 and out == ""
    one_line(err, "agvctl: --set: body.mass_kg: value nested too deeply")


# -- a settling time that never ends ---------------------------------------------------------------------------------


def test_a_settling_time_beyond_ten_minutes_is_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copy(ROOT / "trajectories" / "line.toml", tmp_path / "line.toml")
    exp = tmp_path / "e.toml"
    exp.write_text('name = "e"\ntrajectory = "line.toml"\nsettle_s = 1e9\n')
    code, out, err = run(capsys, "check", exp, "--junit", tmp_path / "r.xml", "--jobs", "1")
    assert code == 2 and out == ""
    one_line(err, f"agvctl: {exp}: settle_s: must be <= 600 (got 1e+09)")
    assert not (tmp_path / "r.xml").exists()
