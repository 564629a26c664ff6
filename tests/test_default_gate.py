"""The default gate: a user's first files pass it with no ``[limits]``, and deliberately broken controllers fail it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from agvctl.checks.summary import run_summary
from agvctl.controllers.base import PoseCommand
from agvctl.controllers.registry import POSE_CONTROLLERS
from agvctl.params import load_vehicle
from agvctl.planning.reference import Reference
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
    assert {"final_position_error_m", "cross_track_error_max_m", "wheel_accel_m_s2"} <= limits.keys()
    assert summary["passed"], [r["message"] for r in limits.values() if not r["passed"]]


class _SidesSwapped:
    """The default controller with its left and right setpoints swapped."""

    def __init__(self, inner: object) -> None:
        self.inner = inner

    def reset(self, reference: Reference) -> None:
        self.inner.reset(reference)  # type: ignore[attr-defined]

    def update(self, t_s: float, pose: object, wheel_speed_m_s: object) -> PoseCommand:
        c: PoseCommand = self.inner.update(t_s, pose, wheel_speed_m_s)  # type: ignore[attr-defined]
        return dataclasses.replace(c, wheel_speed_left_m_s=c.wheel_speed_right_m_s,
                                   wheel_speed_right_m_s=c.wheel_speed_left_m_s)  # fmt: skip


def test_the_default_gate_fails_a_controller_with_its_sides_swapped(tmp_path: Path) -> None:
    experiment = load_experiment(first_file(tmp_path, "s_curve"))
    spec = experiment.spec.controller
    broken = _SidesSwapped(POSE_CONTROLLERS[spec.pose].make(experiment.controller_vehicle, spec.pose_settings))
    summary = run_summary(experiment, run_experiment(experiment, pose_controller=broken))  # type: ignore[arg-type]
    failed = {r["limit"] for r in summary["limits"] if not r["passed"]}
    assert not summary["passed"] and "final_position_error_m" in failed


def test_the_default_gate_fails_wheel_loops_with_four_times_their_gains(tmp_path: Path) -> None:
    from agvctl.controllers.pi.wheel_loop import PIWheelController

    experiment = load_experiment(first_file(tmp_path, "s_curve"))
    loops = experiment.wheel_loops
    gains = dataclasses.replace(loops.design.gains, kp=4 * loops.design.gains.kp, ki=4 * loops.design.gains.ki)
    wheel = PIWheelController(experiment.controller_vehicle, gains, coulomb_feedforward=loops.coulomb_feedforward)
    summary = run_summary(experiment, run_experiment(experiment, wheel_controller=wheel))
    failed = {r["limit"] for r in summary["limits"] if not r["passed"]}
    assert failed == {"wheel_accel_m_s2"}  # on the path, but slamming the wheels from limit to limit
    assert load_vehicle().derived.accel_limit_m_s2 < 1.3  # the bound is the torque limit, twice eq 5's a_lim
