"""The default gate: a user's first files pass it with no ``[limits]``, and deliberately broken controllers fail it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

from agvctl.checks.summary import run_summary
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
