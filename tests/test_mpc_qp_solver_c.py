"""The LTV MPC on OSQP's generated C in the closed loop (``qp_solver = "osqp_c"``, software-in-the-loop): the same
commands as OSQP in Python, bit for bit, on shipped and random scenarios, and in single precision the same tracking
within a tie; several controllers in one process each
with a solver of its own; ``check`` and ``fuzz`` take it as they take any controller setting; clear errors where it
cannot run."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import osqp
import pytest
from cli_runs import line_experiment

from agvctl.cli import main
from agvctl.codegen.back_to_back import qp_back_to_back
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.osqp_fixes import OSQP_VERSION
from agvctl.errors import ConfigError
from agvctl.fuzz.run import fuzz, fuzz_tasks
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.plant.codegen import c_compiler
from agvctl.scenario.experiment import load_experiment, run_experiment

pytestmark = [
    pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine"),
    pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}"),
    pytest.mark.filterwarnings("ignore::agvctl.feasibility.HeadroomWarning"),  # a fuzz run notes them, as here
]


def _with_c_solver(experiment) -> LtvMpcController:
    settings = dataclasses.replace(experiment.spec.controller.pose_settings, qp_solver="osqp_c")
    return LtvMpcController(experiment.controller_vehicle, settings)


@pytest.mark.parametrize("path", ["experiments/figure8.toml", "experiments/payload/s_curve_heavy.toml"])
def test_a_shipped_experiment_commands_the_same_da_voltages_with_either_solver(path):
    """Figure 8 and a path with body limits (the QP's body-rate rows): every commanded DA voltage equal."""
    result = qp_back_to_back(path)
    assert result.samples > 200
    assert result.max_da_difference_v == 0.0
    assert result.same_verdicts and result.python.passed


@pytest.mark.parametrize("index", [4, 17])
def test_random_scenarios_command_the_same_da_voltages_with_either_solver(index, tmp_path):
    spec = load_fuzz_config("experiments/fuzz/acceptance.toml")
    task = next(t for t in fuzz_tasks(spec, [index]).tasks if t.controller == "mpc")
    for name, text in task.files:
        (tmp_path / name).write_text(text, encoding="utf-8")
    result = qp_back_to_back(tmp_path / task.files[-1][0])
    assert result.samples > 100
    assert result.max_da_difference_v == 0.0
    assert result.same_verdicts


def test_in_single_precision_the_figure_8_is_tracked_as_in_double_and_judged_alike():
    """The solver in float rounds its data and iterates to 24 bits: the commands differ by a few DA steps, the
    tracking error's RMS by far less than a tenth of a millimetre, and the verdicts not at all."""
    result = qp_back_to_back("experiments/figure8.toml", "osqp_c_float")
    assert result.samples == result.samples_c > 600
    assert 0.0 < result.max_da_difference_v < 0.1  # single precision, and below 1 % of the DA range
    rms = result.python.metrics["tracking_error_rms_m"], result.c.metrics["tracking_error_rms_m"]
    assert abs(rms[0] - rms[1]) < 1e-5
    assert result.same_verdicts and result.c.passed


class _Interleaved:
    """The pose controller of one run that, before each of its steps, steps a second controller on the next input of
    another run, recorded earlier, and keeps what that one commands."""

    def __init__(self, first: LtvMpcController, second: LtvMpcController, reference, inputs: list[tuple]) -> None:
        self.first, self.second, self._inputs = first, second, iter(inputs)
        second.reset(reference)
        self.second_commands: list[tuple[float, float]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.first, name)

    def update(self, t_s, pose, wheel_speed_m_s):
        step = next(self._inputs, None)
        if step is not None:
            command = self.second.update(*step)
            self.second_commands.append((command.wheel_speed_left_m_s, command.wheel_speed_right_m_s))
        return self.first.update(t_s, pose, wheel_speed_m_s)


class _Recording:
    def __init__(self, controller: LtvMpcController) -> None:
        self.controller = controller
        self.inputs: list[tuple] = []
        self.commands: list[tuple[float, float]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.controller, name)

    def update(self, t_s, pose, wheel_speed_m_s):
        self.inputs.append((t_s, np.array(pose), np.array(wheel_speed_m_s)))
        command = self.controller.update(t_s, pose, wheel_speed_m_s)
        self.commands.append((command.wheel_speed_left_m_s, command.wheel_speed_right_m_s))
        return command


def test_two_controllers_stepped_in_turn_in_one_process_each_command_as_alone():
    """The generated solver's workspace is one per library; each controller's solver keeps its own state, so two
    controllers of the same QP stepped in turn (as threads of one worker would) command exactly what each does
    alone."""
    figure8, square = load_experiment("experiments/figure8.toml"), load_experiment("experiments/square.toml")
    alone = _Recording(_with_c_solver(square))
    run_experiment(square, pose_controller=alone)
    figure8_alone = run_experiment(figure8, pose_controller=_with_c_solver(figure8))

    both = _Interleaved(_with_c_solver(figure8), _with_c_solver(square), square.reference, alone.inputs)
    figure8_interleaved = run_experiment(figure8, pose_controller=both)

    assert len(both.second_commands) == len(alone.commands) > 600
    assert both.second_commands == alone.commands
    for side in ("left", "right"):
        column = f"da_command_{side}_v"
        np.testing.assert_array_equal(figure8_interleaved.log.columns[column], figure8_alone.log.columns[column])


def test_check_runs_an_experiment_that_names_the_c_solver(tmp_path, capsys):
    line_experiment(tmp_path, "line_c.toml", "[controller]\n", '[controller]\nqp_solver = "osqp_c"\n')
    assert main(["check", str(tmp_path / "line_c.toml"), "--jobs", "1"]) == 0
    assert "1 of 1 experiments passed" in capsys.readouterr().out


def test_fuzz_with_the_c_solver_gives_the_metrics_of_osqp():
    spec = dataclasses.replace(load_fuzz_config("experiments/fuzz/acceptance.toml"), controllers=("mpc",))
    with_c = dataclasses.replace(spec, controller={**spec.controller, "qp_solver": "osqp_c"})
    python, c = (fuzz(s, scenarios=[6], jobs=1).outcomes[0] for s in (spec, with_c))
    assert c.error is None and python.error is None

    def untimed(metrics: dict[str, float]) -> dict[str, float]:  # less the wall time of a step
        return {k: v for k, v in metrics.items() if "solve_time" not in k and k != "deadline_misses"}

    assert untimed(c.metrics) == untimed(python.metrics)
    assert c.passed == python.passed


def test_the_c_solver_refuses_a_solve_time_limit_it_cannot_keep():
    figure8 = load_experiment("experiments/figure8.toml")
    settings = dataclasses.replace(figure8.spec.controller.pose_settings, qp_solver="osqp_c", max_solve_time_s=0.01)
    with pytest.raises(ConfigError, match="max_solve_time_s: the generated C solver keeps no time") as caught:
        LtvMpcController(figure8.controller_vehicle, settings)
    assert "\n" not in str(caught.value)


def test_without_a_compiler_the_c_solver_is_refused_in_one_line_naming_its_key(tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    figure8 = load_experiment("experiments/figure8.toml")
    with pytest.raises(ConfigError, match="qp_solver: 'osqp_c' cannot be used here: .*cannot be compiled") as caught:
        _with_c_solver(figure8)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("pose", "keys", "named"),
    [
        ("nmpc", 'qp_solver = "osqp_c"\n', "controller.qp_solver: 'osqp_c' is the LTV MPC's QP solver"),
        ("mpc", 'qp_solver = "osqp_c"\nmax_solve_time_s = 0.01\n', "controller.max_solve_time_s: the generated C"),
    ],
)
@pytest.mark.parametrize("command", [["run", "--no-plot"], ["check", "--jobs", "1"]])
def test_a_setting_the_controller_cannot_keep_is_refused_in_one_line_naming_the_files_key(
    pose, keys, named, command, tmp_path, capsys
):
    """Before any run: a file's settings pass the controller's own rules when they are read."""
    line_experiment(tmp_path, "bad.toml", 'pose = "mpc"\n', f'pose = "{pose}"\n{keys}')
    assert main([command[0], str(tmp_path / "bad.toml"), *command[1:]]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{tmp_path / 'bad.toml'}: {named}" in err
