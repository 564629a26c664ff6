"""The LTV MPC's QP step as generated C (``qp_solver = "osqp_c"``): the initial error, every block's writes and the
solve run in C, for each error frame and prediction model, with Python's commands to the bit; a QP holding a block
without C is refused in one line that names the block."""

from __future__ import annotations

import ctypes
import dataclasses
import re
import subprocess

import numpy as np
import osqp
import pytest
from test_mpc import _CappedLeftWheel, _LeftWheelCap

from agvctl.codegen.qp import experiment_qp
from agvctl.controllers.mpc.c_qp import compile_qp_c
from agvctl.controllers.mpc.c_solver import QpInfo
from agvctl.controllers.mpc.c_step import REFERENCE_TABLES, generate_step_c
from agvctl.controllers.mpc.c_step_loop import StepInput
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.ltv_qp import SpeedBox
from agvctl.controllers.mpc.ltv_qp_model import Dynamics
from agvctl.controllers.mpc.osqp_fixes import OSQP_VERSION
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS
from agvctl.errors import ConfigError
from agvctl.plant.codegen import c_compiler
from agvctl.scenario.experiment import load_experiment, run_experiment

pytestmark = [
    pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine"),
    pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}"),
]


def _commands(experiment, settings: MpcConfig) -> dict[str, np.ndarray]:
    result = run_experiment(experiment, pose_controller=LtvMpcController(experiment.controller_vehicle, settings))
    return {side: np.asarray(result.log.columns[f"da_command_{side}_v"]) for side in ("left", "right")}


@pytest.mark.parametrize(
    "changes",
    [{}, {"error_frame": "world"}, {"prediction_model": "kinematic"}],
    ids=["path frame, wheel-loop model", "world frame", "kinematic model"],
)
def test_every_frame_and_model_steps_in_c_with_the_commands_of_python(changes, monkeypatch):
    """Started 3 cm and 2° off the figure 8 (so the heading coupling is written): every DA command equal; the C run
    never calls the Python blocks' writes."""
    experiment = load_experiment("experiments/figure8_offpath.toml")
    settings = dataclasses.replace(experiment.spec.controller.pose_settings, **changes)
    python = _commands(experiment, settings)

    def in_python(*args: object) -> None:
        raise AssertionError("the step in C called a Python block's write")

    monkeypatch.setattr(Dynamics, "write", in_python)
    monkeypatch.setattr(SpeedBox, "write", in_python)
    c = _commands(experiment, dataclasses.replace(settings, qp_solver="osqp_c"))
    for side in ("left", "right"):
        assert len(python[side]) == len(c[side]) > 600
        np.testing.assert_array_equal(python[side], c[side])


def test_a_qp_with_a_block_without_c_is_refused_naming_the_block():
    vehicle = load_experiment("experiments/figure8.toml").controller_vehicle
    with pytest.raises(ConfigError, match=r"qp_solver.*no C for left wheel cap$"):
        _CappedLeftWheel(vehicle, MpcConfig(qp_solver="osqp_c"))


def test_the_step_compiles_strictly_and_calls_only_the_solver_and_libm(tmp_path):
    """The step's C with the solver's header, compiled alone with the strict flags: the symbols it takes from
    outside are the solver's entry points and libm's (the compiler may join cos and sin into sincos)."""
    controller = LtvMpcController(load_experiment("experiments/figure8.toml").controller_vehicle)
    code = generate_step_c(controller.step_parts, origin="a test", generator="agvctl")
    for name, text in code.files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    (tmp_path / "agv_mpc_qp.h").write_text(
        "typedef struct { int status; int iterations; int error; } agv_mpc_qp_info;\n"
        "int agv_mpc_qp_solve(const double *q, const double *l, const double *u, const double *p,\n"
        "                     const double *a, double *z, double *y, agv_mpc_qp_info *info);\n"
        "int agv_mpc_qp_warm_start(const double *z, const double *y);\n",
        encoding="utf-8",
    )
    compiler = c_compiler()
    assert compiler is not None
    subprocess.run([compiler, *STRICT_C_FLAGS, "-c", "agv_mpc_step.c", "-o", "step.o"], cwd=tmp_path, check=True)
    undefined = subprocess.run(["nm", "-u", "step.o"], cwd=tmp_path, capture_output=True, text=True, check=True)
    names = {re.split(r"\s+", line.strip())[-1] for line in undefined.stdout.splitlines() if line.strip()}
    assert names <= {"agv_mpc_qp_solve", "agv_mpc_qp_warm_start", "cos", "sin", "sincos", "fmod"}, names
    assert {"agv_mpc_qp_solve", "agv_mpc_qp_warm_start"} <= names


def test_the_codegen_folder_steps_the_experiments_qp_as_the_closed_loop_did(monkeypatch):
    """``agvctl codegen``'s QP folder (the solver, the step and the figure 8 as static tables), compiled: started as
    the controller's reset starts it and given each step's input from a closed loop run in Python, its corrections
    make that run's setpoints, bit for bit."""
    experiment = load_experiment("experiments/figure8.toml")
    steps: list[tuple[tuple, tuple[float, float] | None]] = []
    tracked: list[int] = []
    solve, track = LtvMpcController._solve, LtvMpcController._track

    def recording_solve(self, step):
        result = solve(self, step)
        given = (step.k, step.fraction, step.pose, step.wheel_speed_m_s, step.previous_m_s, step.window)
        kept = tuple(np.array(a) if isinstance(a, np.ndarray) else a for a in given)  # the loop reuses its arrays
        steps.append((kept, result))
        return result

    def recording_track(self, reference):
        tracked.append(len(steps))
        return track(self, reference)

    monkeypatch.setattr(LtvMpcController, "_solve", recording_solve)
    monkeypatch.setattr(LtvMpcController, "_track", recording_track)
    settings, vehicle = experiment.spec.controller.pose_settings, experiment.controller_vehicle
    run_experiment(experiment, pose_controller=LtvMpcController(vehicle, settings))
    on_path = steps[: tracked[1]] if len(tracked) > 1 else steps  # the path's own steps (not a docking manoeuvre's)
    assert len(on_path) > 600

    controller = LtvMpcController(vehicle, settings)
    folder = experiment_qp(experiment, controller, generator="a test", measure_memory=False)
    assert folder.code is not None
    controller.reset(experiment.reference)  # back on the path (the folder's docking manoeuvres were tracked)
    feedforward = controller.step_tables()[REFERENCE_TABLES.index("feedforward")].reshape(-1, 2)
    v_max = controller.max_wheel_speed_m_s
    library = compile_qp_c(folder.code)
    state = np.zeros(library.agv_mpc_step_state_size(), dtype=np.uint8)
    assert library.agv_mpc_step_start_reference(ctypes.c_void_p(state.ctypes.data)) == 0
    tables = ctypes.addressof(ctypes.c_void_p.in_dll(library, "agv_mpc_step_tables"))
    step_input, correction, info = StepInput(), np.empty(2 * settings.horizon), QpInfo()
    for args, expected in on_path:
        step_input.set(*args)
        result = library.agv_mpc_step_solve(
            ctypes.c_void_p(state.ctypes.data),
            ctypes.c_void_p(tables),
            ctypes.byref(step_input),
            ctypes.c_void_p(correction.ctypes.data),
            ctypes.byref(info),
        )
        if expected is None:
            assert result != 0
            continue
        assert result == 0
        first = feedforward[args[0]] + correction[:2]
        first = np.where(v_max < first, v_max, first)
        assert tuple(np.where(-v_max > first, -v_max, first).tolist()) == expected


class _LeftWheelCapInC(_LeftWheelCap):
    """The left-wheel cap of ``test_mpc`` with its C: a block of one's own brings its part of the step as a template's
    text, its tables and their names, as the package's blocks do."""

    c_tables_names = ("upper",)
    c_template = """{%- if section == "code" %}
/* A cap on the left wheel's setpoints: the window's upper bounds. */
static void {{ part.id }}_write({{ prefix }}_state *state, const double *const *tables, const step_data *step,
                                const {{ prefix }}_input *input)
{
    const double *upper = tables[{{ part.t.upper }}] + step->k;
    int i;
    (void)input;
    for (i = 0; i < {{ part.n_rows }}; ++i) {
        state->u[{{ part.first_row }} + i] = upper[i];
    }
}
{% endif %}"""

    def c_tables(self) -> dict[str, np.ndarray]:
        return {"upper": self._upper_by_point}


class _CappedInC(LtvMpcController):
    def _blocks(self):
        return [*super()._blocks(), _LeftWheelCapInC(self.config.horizon)]


def test_a_block_of_ones_own_with_its_c_template_steps_in_c_with_the_commands_of_python():
    """The user's constraint block, given its C as a template's text: the figure 8 with the cap in C commands every
    DA voltage as with the cap in Python, and the cap binds (its commands differ from the plain controller's)."""
    experiment = load_experiment("experiments/figure8.toml")
    settings, vehicle = experiment.spec.controller.pose_settings, experiment.controller_vehicle
    runs = {
        name: run_experiment(experiment, pose_controller=controller(vehicle, s)).log
        for name, controller, s in (
            ("python", _CappedInC, settings),
            ("c", _CappedInC, dataclasses.replace(settings, qp_solver="osqp_c")),
            ("plain", LtvMpcController, settings),
        )
    }
    for side in ("left", "right"):
        column = f"da_command_{side}_v"
        np.testing.assert_array_equal(runs["python"][column], runs["c"][column])
    assert not np.array_equal(runs["python"]["da_command_left_v"], runs["plain"]["da_command_left_v"])


def _steps(controller: LtvMpcController, reference, feed) -> list[tuple[float, float, str]]:
    controller.reset(reference)
    commands = [controller.update(k * 0.04, pose, wheel) for k, (pose, wheel) in enumerate(feed)]
    return [(c.wheel_speed_left_m_s, c.wheel_speed_right_m_s, c.status) for c in commands]


@pytest.mark.parametrize(
    "changes",
    [{}, {"max_iterations": 40}, {"reference_governor": False}],
    ids=["default", "solves that fail", "no governor"],
)
def test_the_step_in_c_falls_back_and_recovers_as_python_does(changes):
    """Fed 300 samples of a run started off the figure 8, with the wheels at 1.6 m/s at the first (a reset at speed,
    beyond the speed box) and a wheel speed not a number at three samples (a broken measurement): the C step's
    commands, statuses and failure counts are Python's; with an iteration limit of 40 dozens of solves fail, and the
    shifted sequence takes over as in Python."""
    experiment = load_experiment("experiments/figure8_offpath.toml")
    log = run_experiment(experiment).log
    rim = np.array([experiment.controller_vehicle.rim_per_motor_rad(side) for side in ("left", "right")])
    feed = [
        (
            np.array([log["est_x_m"][k], log["est_y_m"][k], log["est_theta_rad"][k]]),
            np.array([log["measured_omega_motor_left_rad_s"][k], log["measured_omega_motor_right_rad_s"][k]]) * rim,
        )
        for k in range(300)
    ]
    feed[0] = (feed[0][0], np.array([1.6, 1.6]))
    for k in (50, 51, 120):
        feed[k] = (feed[k][0], np.array([np.nan, 0.1]))
    settings = dataclasses.replace(experiment.spec.controller.pose_settings, **changes)
    vehicle = experiment.controller_vehicle
    python = LtvMpcController(vehicle, settings)
    c = LtvMpcController(vehicle, dataclasses.replace(settings, qp_solver="osqp_c"))
    steps = _steps(python, experiment.reference, feed)
    assert steps == _steps(c, experiment.reference, feed)
    assert python.failures == c.failures >= 3
    assert {"solved", "fallback_shifted"} <= {status for _, _, status in steps}
    if "max_iterations" in changes:
        assert c.failures > 20
