"""The LTV MPC's QP step as generated C (``qp_solver = "osqp_c"``): the initial error, every block's writes and the
solve run in C, for each error frame and prediction model, with Python's commands to the bit; a QP holding a block
without C is refused in one line that names the block."""

from __future__ import annotations

import dataclasses
import re
import subprocess

import numpy as np
import osqp
import pytest
from test_mpc import _CappedLeftWheel

from agvctl.controllers.mpc.c_step import generate_step_c
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
