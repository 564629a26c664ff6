"""A user's own pose controller, outside the package, is a citizen of every command: named by ``module:Name`` or by
an installed entry point's name, it runs, is gated by ``check`` (Monte Carlo included), fuzzed beside the MPC and
tuned, with the same results on one job, two jobs and a Dask cluster; bad references are bad input and bad
behaviour at run time is that run's error."""

from __future__ import annotations

import json
import os
import shutil
import sys
import textwrap
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import pytest

from agvctl.checks.report import TIMING_METRICS
from agvctl.cli import main
from agvctl.fuzz.report import FuzzReport
from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.reports import resolved_experiment_toml
from agvctl.scenario import load_experiment, run_experiment

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "experiments" / "own_controller" / "pure_pursuit.py"
MODULE = "own_pursuit"

SHORT_PATHS = """
[paths]
segments = [1, 2]
line_length_m = [0.2, 0.6]
arc_radius_m = [0.3, 0.8]
arc_angle_deg = [20.0, 60.0]
turn_angle_deg = [20.0, 60.0]
"""


@pytest.fixture
def user_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """A folder outside the package holding the user's controller module (on PYTHONPATH, not installed) and a
    short path."""
    folder = tmp_path / "user"
    folder.mkdir()
    shutil.copy(EXAMPLE, folder / f"{MODULE}.py")
    shutil.copy(ROOT / "trajectories" / "line.toml", folder / "line.toml")
    monkeypatch.syspath_prepend(str(folder))
    paths = [str(folder), str(ROOT), os.environ.get("PYTHONPATH", "")]
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in paths if p))
    yield folder
    sys.modules.pop(MODULE, None)


def _experiment(folder: Path, pose: str, extra: str = "") -> Path:
    path = folder / "mine.toml"
    path.write_text(
        f'name = "mine"\ntrajectory = "line.toml"\nsettle_s = 0.5\n[plant]\ninitial_pose = {{ x_m = 0.0, y_m = 0.02, '
        f'theta_deg = 2.0 }}\n[controller]\npose = "{pose}"\nlookahead_m = 0.2\n{extra}'
        '[robustness]\nsamples = 4\nseed = 5\nspread = { "body.mass_kg" = 0.2, "wheels.left.radius_m" = 0.005 }\n',
        encoding="utf-8",
    )
    return path


def _fuzz_file(folder: Path, pose: str, scenarios: int = 10) -> Path:
    path = folder / "mine_fuzz.toml"
    path.write_text(
        f'seed = 7\nscenarios = {scenarios}\ncontrollers = ["{pose}", "mpc"]\nsettle_s = 1.0\n{SHORT_PATHS}',
        encoding="utf-8",
    )
    return path


def _check_physical(json_path: Path) -> list[object]:
    data = json.loads(json_path.read_text())
    return [
        (
            e["passed"],
            e["limits"],
            [{k: v for k, v in run.items() if k not in TIMING_METRICS} for run in e["metrics"]],
        )
        for e in data["experiments"]
    ]


def _fuzz_physical(report: FuzzReport) -> list[tuple[object, ...]]:
    return [
        (o.scenario, o.controller, o.passed, o.error, {k: v for k, v in o.metrics.items() if k not in TIMING_METRICS})
        for o in report.outcomes
    ]


def _check_on_jobs(
    capsys: pytest.CaptureFixture[str], experiment: Path, folder: Path, jobs_to_run: tuple[str, ...] = ("1", "2")
) -> list[list[object]]:
    physical = []
    for jobs in jobs_to_run:
        js = folder / f"check{jobs}.json"
        assert main(["check", str(experiment), "--jobs", jobs, "--json", str(js)]) == 0, capsys.readouterr()
        physical.append(_check_physical(js))
    return physical


def test_a_module_on_the_path_is_checked_and_fuzzed_alike_on_one_and_two_jobs(
    user_folder: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    experiment = _experiment(user_folder, f"{MODULE}:PurePursuit")
    serial, parallel = _check_on_jobs(capsys, experiment, user_folder)
    assert serial == parallel
    runs = serial[0][2]  # type: ignore[index]
    assert isinstance(runs, list) and len(runs) == 4  # the four Monte Carlo samples, each its own plant
    assert len({r["tracking_error_max_m"] for r in runs}) == 4
    spec = load_fuzz_config(_fuzz_file(user_folder, f"{MODULE}:PurePursuit"))
    one, two = fuzz(spec, jobs=1), fuzz(spec, jobs=2)
    assert _fuzz_physical(one) == _fuzz_physical(two)
    assert len(one.outcomes) == 20 and all(o.error is None for o in one.outcomes)


@pytest.mark.slow
def test_a_module_on_the_path_gives_the_same_results_on_a_dask_cluster(user_folder: Path) -> None:
    from dask.distributed import Client, LocalCluster

    from agvctl.checks.runner import check_experiments

    experiment = _experiment(user_folder, f"{MODULE}:PurePursuit")
    spec = load_fuzz_config(_fuzz_file(user_folder, f"{MODULE}:PurePursuit"))
    serial_fuzz, serial_check = fuzz(spec, jobs=1), check_experiments([experiment], jobs=1)
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        Client(cluster),
    ):
        address = cluster.scheduler_address
        dask_fuzz = fuzz(spec, executor="dask", scheduler=address)
        dask_check = check_experiments([experiment], executor="dask", scheduler=address)
    assert _fuzz_physical(serial_fuzz) == _fuzz_physical(dask_fuzz)

    def physical(report: object) -> list[object]:
        return [
            [{k: v for k, v in o.metrics.items() if k not in TIMING_METRICS} for o in e.outcomes]
            for e in report.experiments  # type: ignore[attr-defined]
        ]

    assert physical(serial_check) == physical(dask_check)


def test_an_installed_entry_point_names_the_same_controller(
    user_folder: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    info = user_folder / "own_pursuit-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: own-pursuit\nVersion: 1.0\n", encoding="utf-8")
    (info / "entry_points.txt").write_text(
        f"[agvctl.pose_controllers]\npure_pursuit = {MODULE}:PurePursuit\n", encoding="utf-8"
    )
    by_reference = _check_on_jobs(capsys, _experiment(user_folder, f"{MODULE}:PurePursuit"), user_folder, ("1",))[0]
    by_name = _check_on_jobs(capsys, _experiment(user_folder, "pure_pursuit"), user_folder, ("1",))[0]
    assert by_name == by_reference  # the number of jobs is no matter for it: a name resolves as the reference does
    spec = load_fuzz_config(_fuzz_file(user_folder, "pure_pursuit", scenarios=3))
    reference_spec = load_fuzz_config(_fuzz_file(user_folder, f"{MODULE}:PurePursuit", scenarios=3))
    strip = [(s, p, e, m) for s, _c, p, e, m in _fuzz_physical(fuzz(spec, jobs=1))]
    assert strip == [(s, p, e, m) for s, _c, p, e, m in _fuzz_physical(fuzz(reference_spec, jobs=1))]


def test_a_file_next_to_the_experiment_is_named_relative_to_it(user_folder: Path) -> None:
    shutil.copy(EXAMPLE, user_folder / "pursuit_here.py")
    experiment = load_experiment(_experiment(user_folder, "pursuit_here.py:PurePursuit"))
    assert experiment.spec.controller.pose_settings.lookahead_m == 0.2  # built into the class's Settings
    assert user_folder / "pursuit_here.py" in experiment.input_files  # never written over
    log = run_experiment(experiment).log
    assert abs(float(log["y_m"][-1]) - experiment.reference.final_pose.y_m) < 0.01  # the 2 cm start offset closed
    # the resolved file a run writes names the same code from any folder
    elsewhere = user_folder / "out" / "experiment.toml"
    elsewhere.parent.mkdir()
    elsewhere.write_text(resolved_experiment_toml(experiment), encoding="utf-8")
    again = load_experiment(elsewhere)
    assert again.spec.controller.pose_settings == experiment.spec.controller.pose_settings


def test_tuning_the_users_settings_writes_its_settings_file(
    user_folder: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fuzz_file = _fuzz_file(user_folder, f"{MODULE}:PurePursuit", scenarios=4)
    fuzz_file.write_text(
        fuzz_file.read_text()
        + f'\n[search."{MODULE}:PurePursuit"]\nlookahead_m = [0.05, 0.5]\ngain_1_s = {{ low = 0.5, high = 6.0, '
        "log = true }\n",
        encoding="utf-8",
    )
    out = user_folder / "tuned.toml"
    argv = ["tune", "--pose", str(fuzz_file), "--trials", "3", "--validation-scenarios", "2", "--jobs", "2"]
    assert main([*argv, "--study", str(user_folder / "study"), "--out", str(out)]) == 0, capsys.readouterr().err
    text = out.read_text()
    assert f'pose = "{MODULE}:PurePursuit"' in text and "lookahead_m" in text and "gain_1_s" in text
    # the settings file is used as the built-in controllers' are
    experiment = _experiment(user_folder, f"{MODULE}:PurePursuit")
    experiment.write_text(experiment.read_text().replace("lookahead_m = 0.2\n", 'pose_settings = "tuned.toml"\n'))
    assert load_experiment(experiment).spec.controller.pose_settings is not None


BAD_MODULE = """
from dataclasses import dataclass
from agvctl.controllers.base import PoseCommand

NOT_CALLABLE = 3

class NoUpdate:
    def __init__(self, vehicle, settings): ...
    def reset(self, reference): ...

class OneArgument:
    def __init__(self, vehicle): ...
    def reset(self, reference): ...
    def update(self, t_s, pose, wheel_speed_m_s): ...

class SettingsNotADataclass:
    Settings = dict
    def __init__(self, vehicle, settings): ...
    def reset(self, reference): ...
    def update(self, t_s, pose, wheel_speed_m_s): ...
"""


@pytest.mark.parametrize(
    ("pose", "problem"),
    [
        ("no_such_module_xyz:Name", "cannot import 'no_such_module_xyz'"),
        ("broken_import:Name", "cannot import 'broken_import': ZeroDivisionError"),
        ("bad_controllers:Missing", "'bad_controllers' has no 'Missing'"),
        ("bad_controllers:NOT_CALLABLE", "not a class or a factory"),
        ("bad_controllers:NoUpdate", "no update()"),
        ("bad_controllers:OneArgument", "cannot be called as Name(vehicle, settings)"),
        ("bad_controllers:SettingsNotADataclass", "Settings is a type, not a dataclass"),
        ("bad controllers:Name", "neither a module name nor a .py file"),
        ("missing.py:Name", "file not found"),
        ("no_such_name", "or a reference package.module:Name"),
    ],
)
def test_a_bad_reference_is_one_line_naming_the_file_key_and_reference(
    user_folder: Path, capsys: pytest.CaptureFixture[str], pose: str, problem: str
) -> None:
    (user_folder / "bad_controllers.py").write_text(BAD_MODULE, encoding="utf-8")
    (user_folder / "broken_import.py").write_text("1 / 0\n", encoding="utf-8")
    experiment = _experiment(user_folder, pose)
    out = user_folder / "out"
    for argv in (
        ["check", str(experiment), "--jobs", "1", "--junit", str(out / "r.xml")],
        ["run", str(experiment), "--no-plot", "--out", str(out)],
    ):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and str(experiment) in err[0] and "controller.pose" in err[0], err
        assert pose in err[0] and problem in err[0], err[0]
        assert not out.exists()
    sys.modules.pop("bad_controllers", None)


MISBEHAVING = """
import numpy as np
from agvctl.controllers.base import PoseCommand

class Misbehaving:
    def __init__(self, vehicle, settings):
        self.kind = KIND
    def reset(self, reference): ...
    def update(self, t_s, pose, wheel_speed_m_s):
        if t_s < 0.2:
            return PoseCommand(0.1, 0.1)
        if self.kind == "raises":
            raise RuntimeError("my controller gave up")
        if self.kind == "nan":
            return PoseCommand(float("nan"), 0.1)
        if self.kind == "shape":
            return np.zeros(3)
        return PoseCommand(np.array([0.1, 0.2]), 0.1)
"""


@pytest.mark.parametrize(
    ("kind", "message"),
    [
        ("raises", "RuntimeError: my controller gave up"),
        ("nan", "returned wheel_speed_left_m_s = nan at t = 0.20 s"),
        ("shape", "returned a ndarray of shape (3,) at t = 0.20 s, not a PoseCommand"),
        ("type", "returned wheel_speed_left_m_s = a ndarray of shape (2,)"),
    ],
)
def test_misbehaviour_at_run_time_is_that_runs_error_and_the_others_still_run(
    user_folder: Path, capsys: pytest.CaptureFixture[str], kind: str, message: str
) -> None:
    name = f"misbehaving_{kind}"
    (user_folder / f"{name}.py").write_text(f"KIND = {kind!r}\n" + textwrap.dedent(MISBEHAVING), encoding="utf-8")
    broken = _experiment(user_folder, f"{name}:Misbehaving")
    broken.write_text(broken.read_text().replace("lookahead_m = 0.2\n", "").split("[robustness]")[0])
    good = user_folder / "good.toml"
    good.write_text('name = "good"\ntrajectory = "line.toml"\nsettle_s = 0.5\n', encoding="utf-8")
    junit = user_folder / "r.xml"
    assert main(["check", str(broken), str(good), "--jobs", "1", "--junit", str(junit)]) == 3
    out = capsys.readouterr().out
    assert "PASS  good" in out
    root = ET.parse(junit).getroot()
    assert root.get("errors") == "1"
    error = root.findall("testsuite")[0].find("testcase/error")
    assert error is not None and message in (error.get("message") or ""), error.get("message") if error else None
    if kind != "raises":
        assert f"{name}:Misbehaving" in (error.get("message") or "")
    sys.modules.pop(name, None)


ESTIMATOR_AND_LOOPS = '''
from dataclasses import dataclass
import numpy as np


@dataclass(frozen=True)
class ShiftSettings:
    shift_m: float = 0.0


class ShiftedTruth:
    """The true pose, shifted to the world's left: a perfect sensor, so the simulator hands it the truth."""

    Settings = ShiftSettings

    def __init__(self, vehicle, settings):
        self.shift = np.array([0.0, settings.shift_m, 0.0])

    def reset(self, pose):
        self.pose = np.asarray(pose, dtype=float)

    def observe_truth(self, pose, omega_motor_rad_s):
        self.pose = np.asarray(pose, dtype=float)

    def update(self, measurements):
        return self.pose + self.shift


class ProportionalLoops:
    """Wheel loops of a proportional gain on the motor-speed error, within the DA converter's range."""

    def __init__(self, vehicle, settings):
        self.low_v, self.high_v = vehicle.da.min_v, vehicle.da.max_v

    def reset(self): ...

    def update(self, setpoint_rad_s, measured_rad_s):
        return np.clip(2.0 * (setpoint_rad_s - measured_rad_s), self.low_v, self.high_v)
'''


def test_a_users_estimator_and_wheel_loops_are_named_and_set_up_as_a_pose_controller_is(user_folder: Path) -> None:
    (user_folder / "own_parts.py").write_text(ESTIMATOR_AND_LOOPS, encoding="utf-8")
    path = user_folder / "parts.toml"
    path.write_text(
        'name = "parts"\ntrajectory = "line.toml"\nsettle_s = 1.0\n[controller]\npose = "mpc"\n'
        'localization = "own_parts:ShiftedTruth"\nwheel_loops = "own_parts:ProportionalLoops"\n'
        "[controller.localization_settings]\nshift_m = 0.02\n",
        encoding="utf-8",
    )
    experiment = load_experiment(path)
    assert experiment.spec.controller.localization_settings.shift_m == 0.02
    log = run_experiment(experiment).log
    # the controller puts its estimate on the path's end: the true vehicle ends 2 cm to the right of it
    assert float(log["est_y_m"][-1]) - float(log["y_m"][-1]) == pytest.approx(0.02, abs=1e-12)
    assert float(log["y_m"][-1]) == pytest.approx(experiment.reference.final_pose.y_m - 0.02, abs=0.005)
    sys.modules.pop("own_parts", None)
