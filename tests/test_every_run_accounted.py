"""Every run is accounted for: a run that raises is its experiment's error in ``check`` and ``fuzz`` (exit 3, a
JUnit ``<error>``, the JSON says so), every other run is still run and reported, and asking for no run at all is
bad input."""

from __future__ import annotations

import json
import multiprocessing
import os
import shutil
import xml.etree.ElementTree as ET
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import pytest

from agvctl.checks import runner
from agvctl.checks.runner import check_experiments, execute
from agvctl.cli import main
from agvctl.controllers.base import PoseCommand
from agvctl.controllers.registry import POSE_CONTROLLERS, PoseControllerKind
from agvctl.errors import ConfigError
from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import load_fuzz_config

ROOT = Path(__file__).resolve().parent.parent
LINE = ROOT / "experiments" / "line.toml"


class GivesUp:
    """A user's pose controller that raises half a second into the run."""

    def __init__(self, vehicle: object, settings: object) -> None:
        del vehicle, settings

    def reset(self, reference: object) -> None:
        del reference

    def update(self, t_s: float, pose: object, wheel_speed_m_s: object) -> PoseCommand:
        if t_s > 0.5:
            raise RuntimeError("the user's controller gave up")
        return PoseCommand(0.0, 0.0)


@pytest.fixture
def gives_up(monkeypatch: pytest.MonkeyPatch) -> str:
    monkeypatch.setitem(POSE_CONTROLLERS, "gives_up", PoseControllerKind(GivesUp, None, "raises"))
    return "gives_up"


def _experiment(tmp_path: Path, name: str, table: str = "") -> Path:
    shutil.copy(ROOT / "trajectories" / "line.toml", tmp_path / "line.toml")
    path = tmp_path / f"{name}.toml"
    path.write_text(f'name = "{name}"\ntrajectory = "line.toml"\nsettle_s = 0.5\n{table}', encoding="utf-8")
    return path


def test_a_raising_controller_is_its_experiments_error_and_the_others_are_still_reported(
    tmp_path: Path, gives_up: str, capsys: pytest.CaptureFixture[str]
) -> None:
    broken = _experiment(tmp_path, "broken", f'[controller]\npose = "{gives_up}"\n')
    junit, js = tmp_path / "r.xml", tmp_path / "r.json"
    argv = ["check", str(broken), str(LINE), "--junit", str(junit), "--json", str(js), "--jobs", "1"]
    assert main(argv) == 3
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert "ERROR  broken" in out and "RuntimeError: the user's controller gave up" in out and "PASS  line" in out
    root = ET.parse(junit).getroot()
    assert (root.get("errors"), root.get("failures")) == ("1", "0")
    broken_suite, line_suite = root.findall("testsuite")
    (case,) = broken_suite.findall("testcase")
    error = case.find("error")
    assert case.get("name") == "run" and error is not None and case.find("failure") is None
    message = error.get("message") or ""
    assert message.startswith("RuntimeError: the user's controller gave up") and "\n" not in message
    data = json.loads(js.read_text())
    assert len(line_suite.findall("testcase")) == len(data["experiments"][1]["limits"])
    assert line_suite.get("errors") == line_suite.get("failures") == "0"
    assert data["completed"] is False and data["passed"] is False and data["runs_errored"] == 1
    first, second = data["experiments"]
    assert first["completed"] is False and first["errors"][0]["sample"] is None
    assert first["errors"][0]["error"] == message
    assert second["completed"] is True and second["passed"] is True and second["errors"] == []


def test_a_run_error_wins_over_a_violated_limit(tmp_path: Path, gives_up: str) -> None:
    broken = _experiment(tmp_path, "broken", f'[controller]\npose = "{gives_up}"\n')
    impossible = ROOT / "tests" / "data" / "line_impossible.toml"
    assert main(["check", str(impossible), str(broken), "--jobs", "1"]) == 3
    assert main(["check", str(impossible), "--jobs", "1"]) == 1


def test_check_experiments_records_the_error_instead_of_raising(tmp_path: Path, gives_up: str) -> None:
    broken = _experiment(tmp_path, "broken", f'[controller]\npose = "{gives_up}"\n')
    report = check_experiments([broken], jobs=1)
    (exp,) = report.experiments
    assert not report.completed and not report.passed and not exp.completed
    assert exp.verdicts == [] and exp.errors[0].error is not None
    assert exp.errors[0].error.startswith("RuntimeError: the user's controller gave up (at ")


def test_a_monte_carlo_sample_that_raises_leaves_the_other_samples_verdicts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The product's code raising in one sample (here: the run of sample 1) is that sample's error."""
    real = runner.run_experiment

    def raises_in_sample_1(prepared, **kwargs):  # type: ignore[no-untyped-def]
        if prepared.spec.plant.sensor_seed == 1 + 1:  # sensor_seed + 1 + the sample's index
            raise FloatingPointError("the integrator diverged")
        return real(prepared, **kwargs)

    monkeypatch.setattr(runner, "run_experiment", raises_in_sample_1)
    mc = _experiment(tmp_path, "mc", '[robustness]\nsamples = 3\nseed = 1\n[robustness.spread]\n"body.mass_kg" = 0.1\n')
    report = check_experiments([mc], jobs=1)
    (exp,) = report.experiments
    assert [o.task.sample for o in exp.errors] == [1]
    assert exp.errors[0].error is not None and exp.errors[0].error.startswith("FloatingPointError: the integrator")
    assert exp.verdicts and all(v.runs == 2 for v in exp.verdicts)
    assert not exp.passed and not report.completed


def test_a_task_whose_worker_raises_is_given_to_on_error() -> None:
    def run(task: int) -> str:
        if task == 1:
            raise OSError("worker lost")
        return f"ran {task}"

    with ThreadPoolExecutor(max_workers=1) as pool:
        out = execute(pool, run, [0, 1, 2], None, on_error=lambda task, exc: f"{task}: {exc}")
    assert out == ["ran 0", "1: worker lost", "ran 2"]


def _dies(task: int) -> int:
    os._exit(1)  # a worker process that dies (a segfault in a solver, the OOM killer)


def test_runs_whose_worker_process_died_are_accounted_for() -> None:
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        out = execute(pool, _dies, [0, 1], None, on_error=lambda task, exc: f"{task}: {type(exc).__name__}")
    assert out == ["0: BrokenProcessPool", "1: BrokenProcessPool"]


def test_checking_no_experiment_is_bad_input() -> None:
    with pytest.raises(ConfigError, match="at least one experiment"):
        check_experiments([])


def test_fuzzing_no_scenario_is_bad_input() -> None:
    spec = load_fuzz_config(ROOT / "experiments" / "fuzz" / "ci.toml")
    with pytest.raises(ConfigError, match="at least one scenario"):
        fuzz(spec, scenarios=[], jobs=1)
    with pytest.raises(ConfigError, match=">= 0"):
        fuzz(spec, scenarios=[-1], jobs=1)


def test_a_fuzz_run_that_raises_is_an_error_and_exits_3(
    tmp_path: Path, gives_up: str, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "fz.toml"
    config.write_text(
        f'seed = 3\nscenarios = 2\ncontrollers = ["ramsete", "{gives_up}"]\nsettle_s = 0.5\n'
        "[paths]\nsegments = [2, 2]\nline_length_m = [0.3, 0.6]\narc_radius_m = [0.3, 0.5]\n",
        encoding="utf-8",
    )
    out, junit = tmp_path / "out", tmp_path / "fz.xml"
    assert main(["fuzz", str(config), "--jobs", "1", "--out", str(out), "--junit", str(junit), "--no-plot"]) == 3
    assert "Traceback" not in capsys.readouterr().err
    root = ET.parse(junit).getroot()
    assert (root.get("tests"), root.get("errors")) == ("4", "2")
    runs = json.loads((out / "summary.json").read_text())["runs"]
    errors = [r["error"] for r in runs if r["controller"] == gives_up]
    assert all(e.startswith("RuntimeError: the user's controller gave up (at ") for e in errors)
    assert all(r["error"] is None for r in runs if r["controller"] == "ramsete")


class CommandsNaN(GivesUp):
    """A user's pose controller whose commands turn NaN half a second into the run."""

    def update(self, t_s: float, pose: object, wheel_speed_m_s: object) -> PoseCommand:
        return PoseCommand(float("nan") if t_s > 0.5 else 0.0, 0.0)


def test_a_non_finite_command_fails_check_as_a_named_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(POSE_CONTROLLERS, "nan", PoseControllerKind(CommandsNaN, None, "NaN"))
    exp = _experiment(tmp_path, "nan", '[controller]\npose = "nan"\n')
    junit = tmp_path / "r.xml"
    assert main(["check", str(exp), "--junit", str(junit), "--jobs", "1"]) == 1
    assert "FAIL  non_finite_commands: " in capsys.readouterr().out
    cases = {c.get("name"): c for c in ET.parse(junit).getroot().iter("testcase")}
    failure = cases["non_finite_commands"].find("failure")
    assert failure is not None and "VIOLATED" in (failure.get("message") or "")
