"""The PI wheel loops' options have one default: every entry point that builds the loops (``run``, ``check``,
``tune``, ``identify``, a gains file, the Python constructors) builds them with the same options, except where a
procedure declares its own choice by name."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import pytest
from cli_runs import one_line, run

from agvctl.calibration.friction.experiment import FRICTION_WHEEL_LOOPS
from agvctl.calibration.umbmark.experiment import UMBMARK_WHEEL_LOOPS
from agvctl.controllers.pi import PIWheelController, WheelLoopOptions, default_pi_gains
from agvctl.controllers.pi.options import Braking
from agvctl.controllers.registry import design_wheel_loops
from agvctl.errors import ConfigError
from agvctl.params import load_vehicle
from agvctl.scenario import load_experiment
from agvctl.scenario.spec import ControllerSpec

ROOT = Path(__file__).resolve().parents[1]
DEFAULTS = WheelLoopOptions()


class _Built(BaseException):
    """Raised by the spy once the loops are built: what follows (the run) is not what these tests specify."""


@pytest.fixture
def built(monkeypatch: pytest.MonkeyPatch) -> list[WheelLoopOptions]:
    """The options of every :class:`PIWheelController` built from now on; the first build stops the command."""
    seen: list[WheelLoopOptions] = []
    original = PIWheelController.__init__

    def spy(self: PIWheelController, *args: object, **kwargs: object) -> None:
        original(self, *args, **kwargs)  # type: ignore[arg-type]
        seen.append(self.options)
        raise _Built

    monkeypatch.setattr(PIWheelController, "__init__", spy)
    return seen


def _line_experiment(folder: Path, controller: str = "") -> Path:
    shutil.copy(ROOT / "trajectories" / "line.toml", folder / "line.toml")
    path = folder / "line_run.toml"
    path.write_text(f'name = "line_run"\ntrajectory = "line.toml"\n[controller]\n{controller}', encoding="utf-8")
    return path


def test_the_python_constructors_take_the_one_default() -> None:
    vehicle = load_vehicle()
    assert PIWheelController(vehicle, default_pi_gains(vehicle).gains).options == DEFAULTS
    assert design_wheel_loops(vehicle, None, source="test").options == DEFAULTS
    assert ControllerSpec().wheel_loop_options == DEFAULTS


def test_run_and_check_build_the_loops_with_the_default_options(
    tmp_path: Path, built: list[WheelLoopOptions], capsys: pytest.CaptureFixture[str]
) -> None:
    path = _line_experiment(tmp_path)
    with pytest.raises(_Built):
        run(capsys, "run", path, "--no-plot", "--out", tmp_path / "out")
    with pytest.raises(_Built):
        run(capsys, "check", path, "--jobs", "1")
    assert built == [DEFAULTS, DEFAULTS]


def test_tune_verifies_and_records_the_default_and_its_gains_file_runs_with_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    gains = tmp_path / "gains.toml"
    code, _, err = run(capsys, "tune", "--out", gains)
    assert code == 0, err
    assert f"coulomb_feedforward = {str(DEFAULTS.coulomb_feedforward).lower()}" in gains.read_text(encoding="utf-8")
    experiment = load_experiment(_line_experiment(tmp_path, 'pi_gains = "gains.toml"\n'))
    assert experiment.wheel_loops.options == DEFAULTS

    seen: list[WheelLoopOptions] = []
    original = PIWheelController.__init__

    def spy(self: PIWheelController, *args: object, **kwargs: object) -> None:
        original(self, *args, **kwargs)  # type: ignore[arg-type]
        seen.append(self.options)

    monkeypatch.setattr(PIWheelController, "__init__", spy)
    assert run(capsys, "tune")[0] == 0
    assert seen == [DEFAULTS]


def test_a_gains_file_verified_with_other_options_than_the_experiments_is_refused_naming_its_key(
    tmp_path: Path,
) -> None:
    (tmp_path / "gains.toml").write_text(
        "[pi]\nkp_v_s_rad = 0.05\nki_v_rad = 0.6\ndt_s = 0.04\ncoulomb_feedforward = false\n", encoding="utf-8"
    )
    path = _line_experiment(tmp_path, 'pi_gains = "gains.toml"\n')
    with pytest.raises(ConfigError, match=r"gains.toml: pi.coulomb_feedforward: .* make them agree") as exc:
        load_experiment(path)
    one_line(str(exc.value) + "\n", "controller.coulomb_feedforward is true")
    # the experiment that says the same is accepted: neither side wins silently
    path.write_text(path.read_text(encoding="utf-8") + "coulomb_feedforward = false\n", encoding="utf-8")
    assert load_experiment(path).wheel_loops.options == WheelLoopOptions(coulomb_feedforward=False)


@pytest.mark.parametrize(
    ("procedure", "declared"),
    [("friction", FRICTION_WHEEL_LOOPS), ("umbmark", UMBMARK_WHEEL_LOOPS)],
)
def test_identify_builds_the_default_options_but_for_the_choice_its_procedure_declares(
    procedure: str,
    declared: WheelLoopOptions,
    built: list[WheelLoopOptions],
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(_Built):
        run(capsys, "identify", procedure, "--simulate")
    assert built == [declared]
    changed = {
        f.name for f in dataclasses.fields(WheelLoopOptions) if getattr(declared, f.name) != getattr(DEFAULTS, f.name)
    }
    assert len(changed) == 1  # each procedure states one choice of its own, the rest are the defaults


def test_an_experiment_names_the_braking_choice_and_the_former_flags_point_to_it(tmp_path: Path) -> None:
    path = _line_experiment(tmp_path, 'braking = "gentle_stop"\n')
    assert load_experiment(path).wheel_loops.options == WheelLoopOptions(braking=Braking.GENTLE_STOP)
    path = _line_experiment(tmp_path, "gentle_stop = true\n")
    with pytest.raises(ConfigError, match=r"controller.gentle_stop: replaced by braking"):
        load_experiment(path)
