"""``agvctl plan`` through ``main(argv)``: outputs, and one-line exit-2 errors for every kind of bad input."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.cli import main
from agvctl.planning import CSV_COLUMNS, DRAWN_PATH_TOLERANCE_M, load_path, plan

ROOT = Path(__file__).resolve().parents[1]
SQUARE = ROOT / "trajectories" / "square.toml"

GOOD = """name = "t"
[limits]
wheel_speed_m_s = 0.8
[[segments]]
type = "line"
length_m = 1.0
[[segments]]
type = "turn"
angle_deg = 90
[[segments]]
type = "arc"
radius_m = 1.0
angle_deg = 90
"""


def _g(old: str, new: str) -> str:
    return GOOD.replace(old, new)


def test_json_summary(capsys):
    assert main(["plan", str(SQUARE), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {
        "name",
        "duration_s",
        "path_length_m",
        "peak_wheel_speed_m_s",
        "peak_wheel_accel_m_s2",
        "peak_wheel_jerk_m_s3",
        "drawn_path_deviation_m",
        "drawn_path_tolerance_m",
        "final_pose",
    }
    assert set(out["final_pose"]) == {"x_m", "y_m", "theta_rad"}
    assert out["name"] == "square-2m"
    assert out["path_length_m"] == pytest.approx(8.0)
    assert out["final_pose"]["x_m"] == pytest.approx(0.0, abs=1e-9)
    assert out["final_pose"]["theta_rad"] == pytest.approx(2 * math.pi)
    assert out["peak_wheel_speed_m_s"] <= 0.8 and out["peak_wheel_accel_m_s2"] <= 0.657
    assert out["peak_wheel_jerk_m_s3"] <= 3.0
    assert out["drawn_path_deviation_m"] == 0.0  # lines and turns in place: nothing to smooth
    assert out["drawn_path_tolerance_m"] == DRAWN_PATH_TOLERANCE_M


def test_text_summary(capsys):
    assert main(["plan", str(SQUARE)]) == 0
    assert "square-2m" in capsys.readouterr().out


def test_csv_columns_grid_and_precision(tmp_path, vehicle, capsys):
    out = tmp_path / "ref.csv"
    assert main(["plan", str(SQUARE), "--out", str(out)]) == 0
    with out.open() as fh:
        rows = list(csv.reader(fh))
    assert (
        tuple(rows[0])
        == CSV_COLUMNS
        == (
            "t_s",
            "x_m",
            "y_m",
            "theta_rad",
            "speed_m_s",
            "yaw_rate_rad_s",
            "wheel_speed_left_m_s",
            "wheel_speed_right_m_s",
            "wheel_accel_left_m_s2",
            "wheel_accel_right_m_s2",
        )
    )
    data = np.array(rows[1:], dtype=float)
    assert np.allclose(data[:, 0], np.arange(len(data)) * 0.04, rtol=0, atol=1e-12)
    ref = plan(load_path(SQUARE), vehicle)
    expected = np.column_stack(list(ref.grid.columns().values()))
    # at least nine significant digits
    assert np.allclose(data, expected, rtol=1e-9, atol=1e-12)


def test_vehicle_overrides_change_the_grid(tmp_path, capsys):
    out = tmp_path / "ref.csv"
    assert main(["plan", str(SQUARE), "--set", "control.sample_period_s=0.02", "--out", str(out)]) == 0
    t = np.loadtxt(out, delimiter=",", skiprows=1)[:, 0]
    assert t[1] == pytest.approx(0.02)


def test_plot_is_a_png(tmp_path, capsys):
    png = tmp_path / "ref.png"
    assert main(["plan", str(SQUARE), "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def _bad(tmp_path, capsys, text: str | None, *extra: str, name: str = "bad.toml") -> tuple[int, str, Path]:
    path = tmp_path / name
    if text is not None:
        path.write_text(text)
    out = tmp_path / "ref.csv"
    code = main(["plan", str(path), "--out", str(out), *extra])
    err = capsys.readouterr().err
    assert not out.exists(), "nothing may be written on bad input"
    assert not list(tmp_path.glob(".ref.csv.*")), "no temporary file left behind"
    return code, err, path


def _assert_one_line(code: int, err: str, path: Path, key: str, *words: str) -> None:
    assert code == 2
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert "Traceback" not in err
    assert str(path) in err
    assert key in err, err
    for w in words:
        assert w in err, err


@pytest.mark.parametrize(
    ("text", "key", "words"),
    [
        (_g('type = "arc"', 'type = "spiral"'), "segments[2].type", ("unknown segment type", "'spiral'")),
        (_g('type = "arc"', 'type = "ark"'), "segments[2].type", ("did you mean",)),
        (
            _g("length_m = 1.0", "lenght_m = 1.0"),
            "segments[0].lenght_m",
            ("unknown key", "segments[0].length_m"),
        ),
        (
            _g("angle_deg = 90\n[[", "angle_deg = 90\nradius_m = 1\n[["),
            "segments[1].radius_m",
            ("unknown key",),
        ),
        (_g("radius_m = 1.0", "radius_m = 0"), "segments[2].radius_m", ("must be >= 0.001",)),
        (_g("radius_m = 1.0", "radius_m = -1.5"), "segments[2].radius_m", ("must be >= 0.001", "-1.5")),
        (_g("length_m = 1.0", "length_m = 0.0"), "segments[0].length_m", ("must not be zero",)),
        (_g("length_m = 1.0", 'length_m = "far"'), "segments[0].length_m", ("expected a number",)),
        (_g("wheel_speed_m_s = 0.8", "wheel_speed_m_s = 0"), "limits.wheel_speed_m_s", ("must be >= 0.001",)),
        (_g("wheel_speed_m_s = 0.8", "wheel_accel_m_s2 = -0.5"), "limits.wheel_accel_m_s2", ("must be >= 0.001",)),
        (_g("wheel_speed_m_s = 0.8", "wheel_jerk_m_s3 = 0.0"), "limits.wheel_jerk_m_s3", ("must be >= 0.001",)),
        (_g("wheel_speed_m_s = 0.8", "wheel_speed = 0.8"), "limits.wheel_speed", ("did you mean",)),
        (_g('name = "t"', 'name = "t"\ncolour = "red"'), "colour", ("unknown key",)),
        (
            _g("angle_deg = 90\n[[", "angle_deg = 90\nspeed_m_s = -0.1\n[["),
            "segments[1].speed_m_s",
            ("must be >= 0.001",),
        ),
        (_g("[[segments]]", "[[segment]]"), "segment", ("unknown key",)),
        ('name = "t"\nsegments = []\n', "segments", ("at least one segment",)),
        ('name = "t"\n', "segments", ("missing key",)),
        (_g('type = "turn"\n', ""), "segments[1].type", ("missing key",)),
    ],
)
def test_bad_path_file(tmp_path, capsys, text, key, words):
    code, err, path = _bad(tmp_path, capsys, text)
    _assert_one_line(code, err, path, key, *words)


def _wp(*points: str) -> str:
    return 'name = "w"\n' + "".join(f"[[waypoints]]\n{p}\n" for p in points)


@pytest.mark.parametrize(
    ("text", "key", "words"),
    [
        (_wp("x_m = 0\ny_m = 0"), "waypoints", ("at least 2 waypoints", "got 1")),
        ('name = "w"\nwaypoints = []\n', "waypoints", ("at least 2 waypoints", "got 0")),
        (_wp("x_m = 0\ny_m = 0", "x_m = 1\ny_m = 0", "x_m = 1\ny_m = 0"), "waypoints[2]", ("same point",)),
        (_wp("x_m = 0\ny_m = 0", "x_m = nan\ny_m = 0"), "waypoints[1].x_m", ("must be finite",)),
        (_wp("x_m = 0\ny_m = 0", "y_m = 1"), "waypoints[1].x_m", ("missing key",)),
        (_wp("x_m = 0\ny_m = 0\ntheta_deg = 180", "x_m = 1\ny_m = 0"), "waypoints[0].theta_deg", ("cusp",)),
        (
            _wp("x_m = 0\ny_m = 0", "x_m = 1\ny_m = 0\ntheta_deg = 180", "x_m = 2\ny_m = 0"),
            "waypoints[1].theta_deg",
            ("cusp",),
        ),
        (_wp("x_m = 0\ny_m = 0", "x_m = 1\ny_m = 0\nheading_deg = 5"), "waypoints[1].heading_deg", ("unknown key",)),
        (
            _wp("x_m = 0\ny_m = 0", "x_m = 1\ny_m = 0") + '[[segments]]\ntype = "line"\nlength_m = 1\n',
            "waypoints",
            ("not both",),
        ),
        ("start = { x_m = 1.0 }\n" + _wp("x_m = 0\ny_m = 0", "x_m = 1\ny_m = 0"), "start", ("first waypoint",)),
        (_g('name = "t"', 'name = "t"\njoin = "smoothly"'), "join", ("must be one of", "'stop'")),
    ],
)
def test_bad_waypoint_file(tmp_path, capsys, text, key, words):
    code, err, path = _bad(tmp_path, capsys, text)
    _assert_one_line(code, err, path, key, *words)


@pytest.mark.parametrize(
    ("text", "key", "values"),
    [
        (_g("wheel_speed_m_s = 0.8", "wheel_speed_m_s = 1.2"), "limits.wheel_speed_m_s", ("1.2", "0.9342")),
        (_g("wheel_speed_m_s = 0.8", "wheel_accel_m_s2 = 0.9"), "limits.wheel_accel_m_s2", ("0.9", "0.6572")),
        (
            _g("angle_deg = 90\n[[", "angle_deg = 90\nspeed_m_s = 1.5\n[["),
            "segments[1].speed_m_s",
            ("1.5", "0.9342"),
        ),
    ],
)
def test_limit_above_the_vehicle(tmp_path, capsys, text, key, values):
    code, err, path = _bad(tmp_path, capsys, text)
    _assert_one_line(code, err, path, key, *values, "--force")
    # --force plans anyway, with a one-line warning naming the same key
    out = tmp_path / "forced.csv"
    assert main(["plan", str(path), "--force", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "warning" in err and key in err and values[1] in err
    assert out.exists()


def test_limit_check_follows_the_vehicle(tmp_path, capsys):
    # a lower current limit lowers a_lim (eq 5), so 0.6 m/s² becomes impossible
    path = tmp_path / "p.toml"
    path.write_text(GOOD.replace("wheel_speed_m_s = 0.8", "wheel_accel_m_s2 = 0.6"))
    assert main(["plan", str(path)]) == 0
    capsys.readouterr()
    assert main(["plan", str(path), "--set", "amplifier.current_limit_a=4.0"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "limits.wheel_accel_m_s2" in err


def test_missing_file(tmp_path, capsys):
    code, err, path = _bad(tmp_path, capsys, None, name="nope.toml")
    _assert_one_line(code, err, path, "", "file not found")


def test_malformed_toml(tmp_path, capsys):
    code, err, path = _bad(tmp_path, capsys, "name = \n[[segments]\n")
    _assert_one_line(code, err, path, "", "malformed TOML")


def test_not_utf8(tmp_path, capsys):
    path = tmp_path / "bin.toml"
    path.write_bytes(b"\xff\xfe\x00name")
    code, err, _ = _bad(tmp_path, capsys, None, name="bin.toml")
    _assert_one_line(code, err, path, "", "cannot read")


def test_bad_vehicle_override(tmp_path, capsys):
    code, err, _ = _bad(tmp_path, capsys, GOOD, "--set", "wheels.separation=0.5")
    assert code == 2 and err.count("\n") == 1 and "wheels.separation" in err


def test_unwritable_output(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["plan", str(SQUARE), "--out", str(blocker / "ref.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write" in err


def test_help(capsys):
    assert main(["plan", "--help"]) == 0
    assert "--force" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("text", "key", "words"),
    [
        (_g("length_m = 1.0", "length_m = 1e12"), "segments[0].length_m", ("above the maximum 14400 s",)),
        (_g("length_m = 1.0", "length_m = 1.0\nspeed_m_s = 1e-300"), "segments[0].speed_m_s", ("must be >= 0.001",)),
    ],
)
def test_a_path_too_long_or_too_slow_to_plan_is_one_line_naming_the_key(tmp_path, capsys, text, key, words):
    code, err, path = _bad(tmp_path, capsys, text)
    _assert_one_line(code, err, path, key, *words)
