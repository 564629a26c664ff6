"""The default gate: a user's first files pass it with no ``[limits]``, and deliberately broken controllers fail it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from agvctl.checks.summary import run_summary
from agvctl.evaluation.metrics import METRICS, reference_end_index
from agvctl.log import SimLog
from agvctl.params import load_vehicle
from agvctl.scenario import load_experiment, run_experiment

PATHS = {
    "bend": '[[segments]]\ntype = "line"\nlength_m = 1.5\n[[segments]]\ntype = "arc"\nradius_m = 0.5\nangle_deg = 90\n'
    '[[segments]]\ntype = "line"\nlength_m = 1.0\n',
    "s_curve": '[[segments]]\ntype = "line"\nlength_m = 1.2\n[[segments]]\ntype = "arc"\nradius_m = 1.0\n'
    'angle_deg = 60\n[[segments]]\ntype = "arc"\nradius_m = 1.0\nangle_deg = -60\n'
    '[[segments]]\ntype = "line"\nlength_m = 1.0\n',
}
HEAVIER = '"body.mass_kg" = 102.0, "motor.coulomb_friction_n_m" = 0.0845, "motor.stiction_n_m" = 0.0845'
"""+20 % mass, +30 % Coulomb friction (stiction kept at least as large)."""


def first_file(tmp_path: Path, path: str, plant_set: str = "") -> Path:
    (tmp_path / f"{path}.path.toml").write_text(f'name = "{path}"\n' + PATHS[path])
    experiment = tmp_path / f"{path}.toml"
    experiment.write_text(
        f'name = "{path}"\ntrajectory = "{path}.path.toml"\n\n[plant]\n'
        "initial_pose = { x_m = 0.0, y_m = 0.03, theta_deg = 2.0 }\n"
        + (f"set = {{ {plant_set} }}\n" if plant_set else "")
    )
    return experiment


@pytest.mark.parametrize("plant_set", ["", HEAVIER], ids=["nominal", "heavier_and_stiffer"])
@pytest.mark.parametrize("path", sorted(PATHS))
def test_a_users_first_file_passes_the_default_gate(tmp_path: Path, path: str, plant_set: str) -> None:
    experiment = load_experiment(first_file(tmp_path, path, plant_set))
    summary = run_summary(experiment, run_experiment(experiment))
    limits = {r["limit"]: r for r in summary["limits"]}
    assert all(r["default"] for r in limits.values())  # no [limits]: the default gate alone
    assert {"final_position_error_m", "cross_track_error_max_m", "peak_wheel_accel_m_s2"} <= limits.keys()
    assert summary["passed"], [r["message"] for r in limits.values() if not r["passed"]]


def faults() -> ModuleType:
    """The broken controllers of ``experiments/robustness/broken_controllers.py``."""
    path = Path(__file__).resolve().parents[1] / "experiments" / "robustness" / "broken_controllers.py"
    spec = importlib.util.spec_from_file_location("broken_controllers", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("fault", "caught_by"),
    [
        ("sides swapped", "final_position_error_m"),
        ("heading feedback flipped", "cross_track_error_max_m"),
        ("stops at 60 %", "final_position_error_m"),
        ("solver stopped after one iteration", "solver_failures"),
        ("NaN from 60 % of the path", "non_finite_commands"),
        ("heading 1.5° off", "final_heading_error_deg"),
        ("heading 0.75° off", "final_heading_error_deg"),
        ("0.3 V DA offset on one wheel", "rest_current_max_a"),
        ("wheel loops hold their output at rest", "rest_current_max_a"),
        ("setpoints x0.8", "lateness_s"),
        ("pauses 3 s midway", "lateness_s"),
    ],
)
def test_the_default_gate_fails_a_broken_controller(tmp_path: Path, fault: str, caught_by: str) -> None:
    experiment = load_experiment(first_file(tmp_path, "s_curve"))
    pose_controller, wheel_controller = faults().FAULTS[fault](experiment)
    result = run_experiment(experiment, pose_controller=pose_controller, wheel_controller=wheel_controller)
    summary = run_summary(experiment, result)
    failed = {r["limit"] for r in summary["limits"] if not r["passed"]}
    assert not summary["passed"] and caught_by in failed, failed


def test_wheel_loops_with_four_times_their_gains_fail_on_acceleration_and_stay_on_the_path(tmp_path: Path) -> None:
    experiment = load_experiment(first_file(tmp_path, "s_curve"))
    _, wheel_controller = faults().FAULTS["wheel-loop gains x4"](experiment)
    summary = run_summary(experiment, run_experiment(experiment, wheel_controller=wheel_controller))
    failed = {r["limit"] for r in summary["limits"] if not r["passed"]}
    # on the path, but slamming the wheels from limit to limit (and arriving late for it)
    assert "peak_wheel_accel_m_s2" in failed and failed <= {"peak_wheel_accel_m_s2", "lateness_s"}, failed
    assert load_vehicle().derived.accel_limit_m_s2 < 1.3  # the bound is the torque limit, twice eq 5's a_lim


def test_wheel_loops_that_drive_at_0_8_of_their_setpoints_fail_on_following_them(tmp_path: Path) -> None:
    experiment = load_experiment(first_file(tmp_path, "s_curve"))
    _, wheel_controller = faults().FAULTS["wheel loops at 0.8 of their setpoints"](experiment)
    summary = run_summary(experiment, run_experiment(experiment, wheel_controller=wheel_controller))
    limits = {r["limit"]: r for r in summary["limits"]}
    failed = {key for key, r in limits.items() if not r["passed"]}
    assert "wheel_speed_error_max_m_s" in failed, failed
    # the pose loop closes around the fault: it stays on the path and only arrives late
    assert failed <= {"wheel_speed_error_max_m_s", "lateness_s"}, failed


def synthetic_log(x_m: np.ndarray, ref_x_m: np.ndarray, *, current_a: float = 0.0) -> SimLog:
    """A straight drive along x sampled at T_s = 0.04 s: the vehicle at ``x_m``, its reference at ``ref_x_m``,
    both wheels at the vehicle's speed with setpoints 0 wherever it stands, and ``current_a`` in each motor."""
    ts = 0.04
    n = len(x_m)
    speed = np.concatenate((np.diff(x_m) / ts, [0.0]))  # over the sample that starts at each row
    setpoint = speed
    ref_speed = np.concatenate((np.diff(ref_x_m) / ts, [0.0]))
    zeros = np.zeros(n)
    return SimLog(
        {
            "t_s": ts * np.arange(n),
            "x_m": np.asarray(x_m, dtype=float),
            "y_m": zeros,
            "ref_x_m": np.asarray(ref_x_m, dtype=float),
            "ref_y_m": zeros,
            "ref_theta_rad": zeros,
            "ref_wheel_speed_left_m_s": ref_speed,
            "ref_wheel_speed_right_m_s": ref_speed,
            "wheel_speed_left_m_s": speed,
            "wheel_speed_right_m_s": speed,
            "setpoint_wheel_speed_left_m_s": setpoint,
            "setpoint_wheel_speed_right_m_s": setpoint,
            "current_left_a": np.full(n, current_a),
            "current_right_a": np.full(n, -current_a),
        }
    )


def test_lateness_is_the_time_from_the_references_end_to_the_first_arrival_at_the_paths_end() -> None:
    ref = np.minimum(0.01 * np.arange(200), 1.0)  # 1 m at 0.25 m/s: the reference ends at sample 100, t = 4 s
    on_time = synthetic_log(ref, ref)
    late = synthetic_log(np.minimum(0.008 * np.arange(200), 1.0), ref)  # 0.2 m/s: 5 s to arrive
    assert reference_end_index(on_time) == 100
    assert METRICS["lateness_s"].value(on_time, 0.04) == 0.0
    # within 2 cm of the end from 0.98 m on, reached at sample 123 (0.984 m): 0.92 s after the reference's end
    assert METRICS["lateness_s"].value(late, 0.04) == pytest.approx(0.04 * (123 - 100))
    backs_away = synthetic_log(np.concatenate((ref[:150], np.full(50, 0.95))), ref)  # arrived, then 5 cm away
    assert METRICS["lateness_s"].value(backs_away, 0.04) == 0.0


def test_current_at_rest_counts_only_a_whole_second_of_both_wheels_resting() -> None:
    ref = np.minimum(0.01 * np.arange(200), 1.0)
    held = synthetic_log(ref, ref, current_a=0.4)  # at rest from sample 100 on: 100 samples, 4 s
    assert METRICS["rest_current_max_a"].value(held, 0.04) == pytest.approx(0.4)
    short = synthetic_log(ref[:120], ref[:120], current_a=0.4)  # 20 samples at rest: under a second
    assert METRICS["rest_current_max_a"].value(short, 0.04) == 0.0
