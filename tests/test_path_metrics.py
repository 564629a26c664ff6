"""Path errors on exact geometry: a straight line, a circle, a turn in place, a path that retraces itself."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.checks.summary import run_summary
from agvctl.cli import main
from agvctl.evaluation.path_metrics import ReferencePath, path_errors
from agvctl.planning import ArcSegment, LineSegment, TurnSegment, WheelLimits, plan_segments
from agvctl.planning.reference import Reference
from agvctl.scenario.experiment import load_experiment, run_experiment

LIMITS = WheelLimits(wheel_speed_m_s=0.6, wheel_accel_m_s2=0.4, wheel_jerk_m_s3=2.0)
SPACING_M = 0.005


def _plan(*segments: LineSegment | ArcSegment | TurnSegment) -> Reference:
    return plan_segments(list(segments), limits=LIMITS, separation_m=0.5, sample_period_s=0.04)


def test_straight_line() -> None:
    ref = _plan(LineSegment(length_m=2.0))
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, ref.duration_s, 200))
    x = rng.uniform(0.0, 2.0, 200)  # anywhere along the line, either side of it
    y = rng.uniform(-0.3, 0.3, 200)
    theta = rng.uniform(-1.0, 1.0, 200)
    e = path_errors(t, x, y, theta, ref, spacing_m=SPACING_M)
    s_ref = ref.sample(t).x_m  # the line runs along +x from the origin
    np.testing.assert_allclose(e.cross_track_m, np.abs(y), atol=1e-12)
    np.testing.assert_allclose(e.along_track_lag_m, s_ref - x, atol=1e-12)
    np.testing.assert_allclose(e.heading_error_rad, theta, atol=1e-12)


def test_beyond_the_ends_the_distance_is_to_the_end_point() -> None:
    ref = _plan(LineSegment(length_m=1.0))
    e = path_errors([0.0, 0.0], [-0.3, 1.4], [0.4, -0.3], [0.0, 0.0], ref)
    np.testing.assert_allclose(e.cross_track_m, [0.5, 0.5], atol=1e-12)  # 3-4-5 triangles


def test_circle() -> None:
    radius = 1.0
    ref = _plan(ArcSegment(radius_m=radius, angle_deg=300))  # a left arc from the origin around (0, 1)
    rng = np.random.default_rng(2)
    phi = rng.uniform(0.05, math.radians(295), 300)  # angle travelled along the arc
    rho = radius + rng.uniform(-0.3, 0.3, 300)  # distance from the centre
    x, y = rho * np.sin(phi), 1.0 - rho * np.cos(phi)
    theta = phi + rng.uniform(-0.5, 0.5, 300)
    t = rng.uniform(0.0, ref.duration_s, 300)
    e = path_errors(t, x, y, theta, ref, spacing_m=SPACING_M)
    sagitta = SPACING_M**2 / (8 * radius)  # the polyline's chords lie inside the arc by at most this
    np.testing.assert_allclose(e.cross_track_m, np.abs(rho - radius), atol=sagitta * 1.01)
    # off the arc, the foot on a chord is not the radial projection: the chord's normal turns by up to
    # spacing/(2R) across it, which shifts the foot along it by up to |ρ − R| spacing/(2R)
    along = 0.3 * SPACING_M / (2 * radius)
    np.testing.assert_allclose(e.path_length_m, radius * phi, atol=along)
    np.testing.assert_allclose(e.along_track_lag_m, ref.sample(t).path_length_m - radius * phi, atol=along)
    np.testing.assert_allclose(e.heading_error_rad, theta - phi, atol=along / radius)


def test_turn_in_place_has_a_range_of_headings() -> None:
    ref = _plan(LineSegment(length_m=1.0), TurnSegment(angle_deg=90), LineSegment(length_m=1.0))
    t = np.full(4, 0.5 * ref.duration_s)
    theta = np.radians([0.0, 45.0, 90.0, 120.0])
    e = path_errors(t, np.ones(4), np.zeros(4), theta, ref)  # at the corner, where the path turns
    np.testing.assert_allclose(e.cross_track_m, 0.0, atol=1e-12)
    # the heading range is what the dense samples see of the turn: within 1 µrad of its ends
    np.testing.assert_allclose(e.heading_error_rad, np.radians([0.0, 0.0, 0.0, 30.0]), atol=1e-6)


def test_a_path_that_retraces_itself_keeps_the_clocks_lap() -> None:
    ref = _plan(*[ArcSegment(radius_m=1.0, angle_deg=a) for a in (360, -360, 360)])  # a figure-8 and a lap
    t = np.linspace(0.0, ref.duration_s, 700)
    s = ref.sample(t)
    e = path_errors(t, s.x_m, s.y_m, s.theta_rad, ref)  # exactly on the reference
    np.testing.assert_allclose(e.cross_track_m, 0.0, atol=1e-5)
    np.testing.assert_allclose(e.along_track_lag_m, 0.0, atol=1e-5)
    np.testing.assert_allclose(e.heading_error_rad, 0.0, atol=1e-4)


def test_a_path_at_rest_and_bad_input() -> None:
    ref = _plan(TurnSegment(angle_deg=90))
    path = ReferencePath(ref)
    assert len(path) == 1
    e = path.errors([0.0], [0.3], [0.4], [math.pi])
    assert e.cross_track_m[0] == pytest.approx(0.5)
    assert e.heading_error_rad[0] == pytest.approx(math.pi / 2)  # 90° beyond the range 0…90°
    with pytest.raises(ValueError, match="same length"):
        path.errors([0.0, 1.0], [0.0], [0.0], [0.0])
    with pytest.raises(ValueError, match="spacing_m"):
        ReferencePath(ref, spacing_m=0.0)


# -- wired into the closed loop: log columns, metrics, limits, run's report -------------------------------------

TRAJECTORIES = Path(__file__).resolve().parent.parent / "trajectories"


def _offset_line_experiment(tmp_path: Path, limits: str) -> Path:
    """The 3 m line along +x, the vehicle starting 4 cm to its right, heading along it."""
    path = tmp_path / "offset_line.toml"
    path.write_text(
        f'name = "offset_line"\ntrajectory = "{(TRAJECTORIES / "line.toml").as_posix()}"\nsettle_s = 1.0\n'
        "[plant]\ninitial_pose = { x_m = 0.0, y_m = -0.04, theta_deg = 0.0 }\n"
        '[controller]\npose = "ramsete"\n'
        f"[limits]\n{limits}\n"
    )
    return path


def test_closed_loop_log_metrics_and_limits_separate_lag_from_error(tmp_path: Path) -> None:
    exp = load_experiment(
        _offset_line_experiment(tmp_path, "cross_track_error_max_m = 0.03\nalong_track_lag_max_m = 10.0")
    )
    result = run_experiment(exp)
    log = result.log
    for name in ("cross_track_error_m", "along_track_lag_m", "path_heading_error_rad"):
        assert np.all(np.isfinite(log[name])), name
    # geometry: the line is the x axis from 0 to 3 m, so the distance to it is |y| while 0 <= x <= 3
    inside = (log["x_m"] >= 0.0) & (log["x_m"] <= 3.0)
    np.testing.assert_allclose(log["cross_track_error_m"][inside], np.abs(log["y_m"][inside]), atol=1e-9)
    assert log["cross_track_error_m"][0] == pytest.approx(0.04, abs=1e-9)
    # the reference point is on the path: no farther from the vehicle than the path's nearest point
    assert np.all(log["cross_track_error_m"] <= log["position_error_m"] + 1e-9)
    # along the x axis the lag is the reference's x minus the vehicle's
    np.testing.assert_allclose(log["along_track_lag_m"][inside], (log["ref_x_m"] - log["x_m"])[inside], atol=1e-9)
    np.testing.assert_allclose(
        log["path_heading_error_rad"][inside], np.angle(np.exp(1j * log["theta_rad"][inside])), atol=1e-9
    )
    summary = run_summary(exp, result)
    m = summary["metrics"]
    assert m["cross_track_error_max_m"] == pytest.approx(np.max(np.abs(log["y_m"][inside])), abs=1e-9)
    assert m["cross_track_error_rms_m"] <= m["cross_track_error_max_m"]
    assert m["along_track_lag_max_m"] == pytest.approx(np.max(np.abs(log["along_track_lag_m"])))
    verdicts = {r["limit"]: r for r in summary["limits"]}
    assert not verdicts["cross_track_error_max_m"]["passed"]  # 4 cm off at the start, against 3 cm
    assert verdicts["cross_track_error_max_m"]["first_time_s"] == 0.0
    assert verdicts["along_track_lag_max_m"]["passed"]


def test_run_prints_the_path_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp = _offset_line_experiment(tmp_path, "path_heading_error_max_deg = 90.0")
    assert main(["run", str(exp), "--out", str(tmp_path / "out"), "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "cross-track error" in out and "along-track lag" in out
    assert "path_heading_error_max_deg:" in out
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for key in ("cross_track_error_max_m", "cross_track_error_rms_m", "along_track_lag_max_m"):
        assert summary["metrics"][key] >= 0.0
    header = (tmp_path / "out" / "log.csv").read_text().splitlines()[0].split(",")
    assert {"cross_track_error_m", "along_track_lag_m", "path_heading_error_rad"} <= set(header)


def test_bad_path_limit_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    exp = _offset_line_experiment(tmp_path, "cross_track_eror_max_m = 0.1")
    assert main(["run", str(exp), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "limits.cross_track_eror_max_m" in err and "cross_track_error_max_m" in err


def test_beside_a_turn_in_place_its_headings_count() -> None:
    ref = _plan(LineSegment(length_m=1.0), TurnSegment(angle_deg=90), LineSegment(length_m=1.0))
    turning = 0.5 * ref.duration_s  # the reference is turning at the corner (1, 0)
    assert ref.sample([turning]).x_m[0] == pytest.approx(1.0) and ref.sample([turning]).y_m[0] == pytest.approx(0.0)
    t = np.array([ref.duration_s, ref.duration_s, ref.duration_s, turning])
    # 2 cm right of the second line, 3 cm up it: nearer to that line than to the corner, and within reach of it;
    # then half a metre up the line (out of reach); then 20 cm up the line while the reference turns
    x, y = np.array([1.02, 1.02, 1.01, 1.0]), np.array([0.03, 0.03, 0.5, 0.2])
    theta = np.radians([45.0, 180.0, 45.0, 45.0])
    e = path_errors(t, x, y, theta, ref)
    np.testing.assert_allclose(e.cross_track_m, [0.02, 0.02, 0.01, 0.0], atol=1e-12)
    # mid-turn beside the corner: on the path; 90° past the turn's end: 90°; up the line: the line's heading;
    # while the reference turns: the turn's headings
    np.testing.assert_allclose(e.heading_error_rad, np.radians([0.0, 90.0, -45.0, 0.0]), atol=1e-6)


def test_the_way_back_after_a_sharp_turn_is_another_branch() -> None:
    ref = _plan(LineSegment(length_m=1.0), TurnSegment(angle_deg=165), LineSegment(length_m=1.0))
    way_there = 0.97  # arc length on the first line, 3 cm before the turn
    t = ref.sample(np.linspace(0.0, ref.duration_s, 20001))
    clock = float(np.interp(way_there, t.path_length_m, np.linspace(0.0, ref.duration_s, 20001)))
    # 6 mm beside the way there, 2 mm from the way back (it leaves the corner at 165°, 15° from the way there)
    x, y = 0.97, 0.006
    back = math.radians(165.0)
    to_back = abs(-(x - 1.0) * math.sin(back) + y * math.cos(back))
    assert to_back < 0.006
    e = path_errors([clock], [x], [y], [0.0], ref)
    np.testing.assert_allclose(e.cross_track_m, [to_back], atol=1e-9)  # the true distance to the path
    np.testing.assert_allclose(e.heading_error_rad, [0.0], atol=1e-6)  # along the way there, not turned around
    np.testing.assert_allclose(e.path_length_m, [way_there], atol=1e-6)
    np.testing.assert_allclose(e.along_track_lag_m, [0.0], atol=1e-6)


def test_turning_one_way_and_back_covers_every_heading_between() -> None:
    ref = _plan(
        LineSegment(length_m=1.0), TurnSegment(angle_deg=150), TurnSegment(angle_deg=-120), LineSegment(length_m=1.0)
    )
    t = np.full(3, 0.5 * ref.duration_s)
    theta = np.radians([140.0, 150.0, 170.0])  # past both ends (0° and 30°) but within the excursion to 150°
    e = path_errors(t, np.ones(3), np.zeros(3), theta, ref)
    np.testing.assert_allclose(e.heading_error_rad, np.radians([0.0, 0.0, 20.0]), atol=1e-6)


def test_a_nearer_branch_does_not_crowd_out_the_vehicles_own() -> None:
    """Driving back from a 176° turn, 3 mm beside the way there and 18 mm from the way back it drives on, lagging
    10 cm behind the clock: the way back is the vehicle's branch (a run read 165° of heading error here when only the
    8 nearest vertices, all on the way there, and the segments around the clock were candidates)."""
    ref = _plan(LineSegment(length_m=1.0), TurnSegment(angle_deg=176.0), LineSegment(length_m=1.0))
    times = np.linspace(0.0, ref.duration_s, 20001)
    s = ref.sample(times)
    back = math.radians(176.0)
    x_back = 0.3  # along the way back
    clock = float(times[np.argmin(np.abs(s.path_length_m - (1.1 + x_back)))])
    x, y = 1.0 + x_back * math.cos(back), 0.003
    to_back = abs(-(x - 1.0) * math.sin(back) + y * math.cos(back))
    assert 0.015 < to_back < 0.02
    e = path_errors([clock], [x], [y], [back], ref)
    np.testing.assert_allclose(e.cross_track_m, [0.003], atol=1e-6)  # the true distance: to the way there
    assert abs(e.heading_error_rad[0]) < 1e-6  # on the way back, heading along it
    assert abs(e.path_length_m[0] - (1.0 + x_back)) < 0.02


def test_a_branch_several_centimetres_away_is_still_a_candidate() -> None:
    """Driving back from a 172.5° turn, 4 mm beside the way there and 8 cm from the way back it drives on, lagging
    25 cm behind the clock: the way back is still the vehicle's branch, although every vertex within 8 cm lies on
    the way there."""
    ref = _plan(LineSegment(length_m=1.2), TurnSegment(angle_deg=-172.5), LineSegment(length_m=1.2))
    times = np.linspace(0.0, ref.duration_s, 20001)
    s = ref.sample(times)
    back = math.radians(-172.5)
    q = 0.6  # along the way back
    clock = float(times[np.argmin(np.abs(s.path_length_m - (1.2 + q + 0.25)))])
    x, y = 1.2 + q * math.cos(back), 0.004
    to_back = abs(-(x - 1.2) * math.sin(back) + y * math.cos(back))
    assert 0.08 < to_back < 0.085
    e = path_errors([clock], [x], [y], [back], ref)
    np.testing.assert_allclose(e.cross_track_m, [0.004], atol=1e-6)  # the true distance: to the way there
    assert abs(e.heading_error_rad[0]) < math.radians(1.0)  # on the way back, heading along it
    assert abs(e.along_track_lag_m[0] - 0.25) < 0.02
