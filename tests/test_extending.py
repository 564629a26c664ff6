"""Extending agvctl: a new pose controller is one module and one line in its registry, and so is a new estimator.
Each test writes the module as a user would, adds the one registry line, and runs an experiment file naming it."""

from __future__ import annotations

import importlib.util
import math
import sys
import textwrap
from pathlib import Path
from types import ModuleType

import pytest

from agvctl.controllers.registry import POSE_CONTROLLERS, PoseControllerKind
from agvctl.estimation.registry import ESTIMATORS
from agvctl.scenario import load_experiment, run_experiment

ROOT = Path(__file__).resolve().parents[1]

CONTROLLER_MODULE = '''
"""A pose controller that drives a share of the reference's wheel speeds, with no feedback."""
from dataclasses import dataclass

from agvctl.controllers.base import PoseCommand


@dataclass(frozen=True)
class ShareSettings:
    share: float = 1.0


class ShareOfReference:
    def __init__(self, vehicle, settings):
        self.share = settings.share
        self.reference = None

    def reset(self, reference):
        self.reference = reference

    def update(self, t_s, pose, wheel_speed_m_s):
        s = self.reference.sample([min(t_s, self.reference.duration_s)])
        return PoseCommand(self.share * float(s.wheel_speed_left_m_s[0]),
                           self.share * float(s.wheel_speed_right_m_s[0]))
'''

ESTIMATOR_MODULE = '''
"""A pose estimator that reports the true pose shifted 2 cm to the vehicle's left in the world frame."""
import numpy as np


class ShiftedTruth:
    def __init__(self, vehicle):
        del vehicle
        self.pose = np.zeros(3)

    def reset(self, pose):
        self.pose = np.array(pose, dtype=float)

    def observe_truth(self, pose, omega_motor_rad_s):  # a perfect sensor: the simulator hands it the truth
        self.pose = np.array(pose, dtype=float)

    def update(self, measurements):
        return self.pose + np.array([0.0, 0.02, 0.0])
'''


def user_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, name: str, source: str) -> ModuleType:
    path = tmp_path / f"{name}.py"
    path.write_text(textwrap.dedent(source))
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, name, module)
    spec.loader.exec_module(module)
    return module


def experiment_file(tmp_path: Path, controller_table: str) -> Path:
    path = tmp_path / "line.toml"
    path.write_text(
        f'name = "line"\ntrajectory = "{(ROOT / "trajectories" / "line.toml").as_posix()}"\n'
        f"settle_s = 1.0\n\n[controller]\n{controller_table}\n"
    )
    return path


def test_a_new_pose_controller_is_one_module_and_one_registry_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    module = user_module(tmp_path, monkeypatch, "share_of_reference", CONTROLLER_MODULE)
    monkeypatch.setitem(
        POSE_CONTROLLERS,
        "share",
        PoseControllerKind(module.ShareOfReference, module.ShareSettings, "a share of the feed-forward"),
    )
    experiment = load_experiment(experiment_file(tmp_path, 'pose = "share"\nshare = 0.5'))
    assert experiment.spec.controller.pose_settings == module.ShareSettings(share=0.5)  # built from the file
    log = run_experiment(experiment).log
    travelled_m = math.hypot(float(log["x_m"][-1] - log["x_m"][0]), float(log["y_m"][-1] - log["y_m"][0]))
    assert travelled_m == pytest.approx(0.5 * experiment.reference.path_length_m, rel=0.05)


def test_a_new_estimator_is_one_module_and_one_registry_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    module = user_module(tmp_path, monkeypatch, "shifted_truth", ESTIMATOR_MODULE)
    monkeypatch.setitem(ESTIMATORS, "shifted", module.ShiftedTruth)
    experiment = load_experiment(experiment_file(tmp_path, 'pose = "mpc"\nlocalization = "shifted"'))
    log = run_experiment(experiment).log
    final = experiment.reference.final_pose
    # the controller puts its estimate on the path's end: the true vehicle ends 2 cm to the right of it
    assert float(log["y_m"][-1]) == pytest.approx(final.y_m - 0.02, abs=0.003)
    assert float(log["x_m"][-1]) == pytest.approx(final.x_m, abs=0.003)
    assert float(log["est_y_m"][-1]) == pytest.approx(float(log["y_m"][-1]) + 0.02, abs=1e-12)
