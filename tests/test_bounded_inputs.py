"""Inputs that would make the planner or the closed loop grow without bound, and nonsense settings, are refused
before any work with one line naming the file and key; the planner's work grows linearly with its input; the Python
API checks its arguments as the files are checked and sees a file as it is now."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from cli_runs import one_line, run

from agvctl.checks.runner import check_experiments
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig
from agvctl.controllers.baselines.ramsete import RamseteConfig
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.errors import ConfigError
from agvctl.planning import LineSegment, WheelLimits, plan_segments, plan_waypoints
from agvctl.planning import reference as reference_module
from agvctl.planning.arguments import MAX_DURATION_S
from agvctl.planning.spec import ArcSegment, Waypoint
from agvctl.scenario import load_experiment

ROOT = Path(__file__).resolve().parent.parent
LIMITS = WheelLimits(0.8, 0.5, 3.0)
LINE = '[[segments]]\ntype = "line"\nlength_m = {}\n'


def _plan_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, *parts: str) -> None:
    path = tmp_path / "path.toml"
    path.write_text(text)
    code, _, err = run(capsys, "plan", path, "--out", tmp_path / "ref.csv")
    assert code == 2
    one_line(err, f"agvctl: {path}: ", *parts)
    assert not (tmp_path / "ref.csv").exists()


@pytest.mark.parametrize(
    ("text", "key"),
    [
        (
            LINE.format(1.0)
            + '[[segments]]\ntype = "turn"\nangle_deg = 90\n'
            + LINE.format(1.0) * 2
            + LINE.format(1e6),
            "segments[4].length_m",
        ),
        (LINE.format(1e308), "segments[0].length_m"),
        ('[[segments]]\ntype = "arc"\nradius_m = 1e308\nangle_deg = 90\n', "segments[0].radius_m"),
        ('[[segments]]\ntype = "arc"\nradius_m = 1.0\nangle_deg = 1e308\n', "segments[0].angle_deg"),
        ('[[segments]]\ntype = "turn"\nangle_deg = 1e308\n', "segments[0].angle_deg"),
        (
            "[[waypoints]]\nx_m = 0\ny_m = 0\n[[waypoints]]\nx_m = 1\ny_m = 0\n[[waypoints]]\nx_m = 1e6\ny_m = 0\n",
            "waypoints[2]",
        ),
    ],  # fmt: skip
)
def test_a_path_longer_than_the_longest_reference_is_refused_at_its_segment_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, key: str
) -> None:
    # a path's least time is its length over the wheel speed limit: these take far beyond the bound
    _plan_refused(tmp_path, capsys, text, f"{key}: the path up to here takes at least", f"{MAX_DURATION_S:g} s")


@pytest.mark.parametrize("key", ["wheel_speed_m_s", "wheel_accel_m_s2", "wheel_jerk_m_s3"])
def test_a_vanishing_wheel_limit_in_a_path_file_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str
) -> None:
    _plan_refused(tmp_path, capsys, f"[limits]\n{key} = 1e-300\n" + LINE.format(1.0), f"limits.{key}: must be >= 0.001")


def test_the_planning_api_refuses_a_path_too_long_before_planning_it() -> None:
    with pytest.raises(ConfigError, match=r"plan_segments: segments\[1\]\.radius_m: .* above the maximum 14400 s"):
        plan_segments(
            [LineSegment(length_m=1.0), ArcSegment(radius_m=1e300, angle_deg=1.0)],
            limits=LIMITS,
            separation_m=0.5,
            sample_period_s=0.04,
        )
    far = [Waypoint(x_m=0.0, y_m=0.0), Waypoint(x_m=1e6, y_m=0.0)]
    with pytest.raises(ConfigError, match=r"<path>: waypoints\[1\]: .* above the maximum"):
        plan_waypoints(far, limits=LIMITS, separation_m=0.5, sample_period_s=0.04)
    with pytest.raises(ConfigError, match="WheelLimits: wheel_speed_m_s: must be finite and >= 0.001"):
        WheelLimits(1e-300, 0.5, 3.0)


def test_more_corners_too_short_to_drive_than_the_recursion_limit_plan_stopping_at_each() -> None:
    # 1 µm lines between arcs: no smooth join fits (at least 1 µm), so the reference stops at every corner
    corner = [LineSegment(length_m=4e-7), ArcSegment(radius_m=0.5, angle_deg=1e-5)]
    reference = plan_segments(corner * 600, limits=LIMITS, separation_m=0.5, sample_period_s=0.04)
    assert len(reference.motions) == 1200
    assert reference.path_length_m == pytest.approx(600 * (4e-7 + 0.5 * math.radians(1e-5)), rel=1e-9)


def test_the_peaks_taken_in_chunks_are_the_peaks_of_the_dense_samples(monkeypatch: pytest.MonkeyPatch) -> None:
    segments = [LineSegment(length_m=0.3), ArcSegment(radius_m=0.4, angle_deg=120.0), LineSegment(length_m=0.2)]
    reference = plan_segments(segments, limits=LIMITS, separation_m=0.5, sample_period_s=0.04)
    monkeypatch.setattr(reference_module, "PEAK_CHUNK", 97)
    peaks = reference.peaks(dense_period_s=1e-3)
    t = np.concatenate([np.arange(math.ceil(reference.duration_s / 1e-3)) * 1e-3, [reference.duration_s]])
    s = reference.sample(t)
    for name, left, right in (
        ("peak_wheel_speed_m_s", s.wheel_speed_left_m_s, s.wheel_speed_right_m_s),
        ("peak_wheel_accel_m_s2", s.wheel_accel_left_m_s2, s.wheel_accel_right_m_s2),
        ("peak_wheel_jerk_m_s3", s.wheel_jerk_left_m_s3, s.wheel_jerk_right_m_s3),
    ):
        dense = max(np.max(np.abs(left)), np.max(np.abs(right)))
        assert dense <= peaks[name] * (1 + 1e-12)  # the phase switches are added to the dense samples
    assert peaks["peak_wheel_speed_m_s"] <= LIMITS.wheel_speed_m_s * (1 + 1e-6)  # the planner keeps the limits
    assert peaks["peak_wheel_accel_m_s2"] <= LIMITS.wheel_accel_m_s2 * (1 + 1e-6)


def _experiment(tmp_path: Path, controller: str = "", plant: str = "", limits: str = "") -> Path:
    (tmp_path / "line.toml").write_text((ROOT / "trajectories" / "line.toml").read_text())
    path = tmp_path / "exp.toml"
    path.write_text(
        f'name = "e"\ntrajectory = "line.toml"\nsettle_s = 0.5\n[controller]\npose = "mpc"\n{controller}'
        f"[plant]\n{plant}[limits]\n{limits}"
    )
    return path


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        ("max_solve_time_s = 1e-308", "controller.max_solve_time_s: must be >= 0.0001"),
        ("weight_input = 1e308", "controller.weight_input: must be <= 1e+06"),
        ("max_wheel_speed_m_s = 1e-300", "controller.max_wheel_speed_m_s: must be >= 0.001"),
        ("max_wheel_accel_m_s2 = 1e300", "controller.max_wheel_accel_m_s2: must be <= 100"),
        ("tolerance = 1e-300", "controller.tolerance: must be >= 1e-10"),
        ("max_iterations = 1000000000", "controller.max_iterations: must be <= 1e+06"),
    ],
)
def test_a_nonsense_mpc_setting_is_refused_naming_its_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], line: str, problem: str
) -> None:
    path = _experiment(tmp_path, controller=line + "\n")
    code, _, err = run(capsys, "run", path, "--no-plot", "--out", tmp_path / "out")
    assert code == 2
    one_line(err, f"agvctl: {path}: {problem}")
    assert not (tmp_path / "out").exists()


def test_every_pose_controllers_settings_refuse_nonsense_numbers_naming_the_field() -> None:
    for make, message in (
        (lambda: MpcConfig(weight_position=1e308), "MpcConfig: weight_position: must be <= 1e+06"),
        (lambda: MpcConfig(wheel_loop_time_constant_s=1e-300), "MpcConfig: wheel_loop_time_constant_s: must be >="),
        (lambda: RamseteConfig(max_wheel_speed_m_s=1e-300), "RamseteConfig: max_wheel_speed_m_s: must be >= 0.001"),
        (lambda: RamseteConfig(b_rad2_m2=1e308), "RamseteConfig: b_rad2_m2: must be <= 1e+06"),
        (lambda: LtvLqrConfig(tolerance_x_m=1e-300), "LtvLqrConfig: tolerance_x_m: must be >= 0.0001"),
        (lambda: LtvLqrConfig(schedule_step_m_s=1e-300), "LtvLqrConfig: schedule_step_m_s: must be >= 0.001"),
    ):
        with pytest.raises(ConfigError) as info:
            make()
        assert str(info.value).startswith(message), info.value


def test_an_initial_pose_far_off_is_refused_naming_its_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _experiment(tmp_path, plant="initial_pose = { x_m = 1e308, y_m = 0.0, theta_deg = 0.0 }\n")
    code, _, err = run(capsys, "run", path, "--no-plot", "--out", tmp_path / "out")
    assert code == 2
    one_line(err, f"agvctl: {path}: plant.initial_pose.x_m: must be within ±10000 m (got 1e+308)")
    assert not (tmp_path / "out").exists()


def test_load_experiment_refuses_an_argument_that_is_not_a_file_name() -> None:
    for bad in (b"experiments/line.toml", 3, None):
        with pytest.raises(ConfigError, match="load_experiment: path: expected a file name"):
            load_experiment(bad)  # type: ignore[arg-type]


def test_a_file_edited_between_two_checks_in_one_process_is_checked_as_it_is_now(tmp_path: Path) -> None:
    # a 3 m line ends within a few millimetres: 0.5 m passes, 1 µm cannot
    path = _experiment(tmp_path, limits="final_position_error_m = 0.5\n")
    assert check_experiments([path], jobs=1).passed
    path.write_text(path.read_text().replace("final_position_error_m = 0.5", "final_position_error_m = 1e-6"))
    assert not check_experiments([path], jobs=1).passed


def test_a_settings_file_edited_between_two_checks_in_one_process_is_checked_as_it_is_now(tmp_path: Path) -> None:
    # a pose controller held to 1 mm/s cannot reach the end of a 3 m line: 0.5 m from it fails
    settings = tmp_path / "tuned.toml"
    settings.write_text('pose = "mpc"\n')
    path = _experiment(tmp_path, controller='pose_settings = "tuned.toml"\n', limits="final_position_error_m = 0.5\n")
    assert settings in load_experiment(path).input_files
    assert check_experiments([path], jobs=1).passed
    settings.write_text('pose = "mpc"\nmax_wheel_speed_m_s = 0.001\n')
    assert not check_experiments([path], jobs=1).passed
