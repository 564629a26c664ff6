"""A whole controller cascade as generated C (the Ramsete law, the reference as data and the PI loops): the law
commands what the Python law commands, the cascade builds with warnings as errors and holds no heap and no I/O, and
its one step function replays the closed loop's DA commands from the closed loop's pose and motor speeds."""

from __future__ import annotations

import ctypes
import dataclasses
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import osqp
import pytest
from cli_runs import line_experiment

from agvctl.checks.report import TIMING_METRICS
from agvctl.cli import main
from agvctl.codegen import cascade_back_to_back, generate_code
from agvctl.controllers.baselines import LtvLqrConfig, LtvLqrController, RamseteConfig, RamseteController
from agvctl.controllers.baselines.c_unicycle import CompiledLtvLqrController, CompiledRamseteController
from agvctl.controllers.mpc.docking import EndOfPath
from agvctl.controllers.mpc.osqp_fixes import OSQP_VERSION
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS
from agvctl.errors import AgvctlError, ConfigError
from agvctl.fuzz.run import fuzz, fuzz_tasks
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config
from agvctl.planning import plan_file
from agvctl.plant.codegen import c_compiler, compiled_library
from agvctl.scenario.experiment import load_experiment, run_experiment

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")


def _law_line(folder: Path, law: str = "ramsete") -> Path:
    settings = {"ramsete": "b_rad2_m2 = 3.0\n", "ltv_lqr": "tolerance_y_m = 0.05\n"}[law]
    return line_experiment(folder, f"line_{law}.toml", 'pose = "mpc"\nhorizon = 20\n', f'pose = "{law}"\n{settings}')


LAWS = {
    "ramsete": (
        RamseteController,
        CompiledRamseteController,
        RamseteConfig(b_rad2_m2=5.0, zeta=0.9, max_wheel_speed_m_s=0.4),
    ),
    "ltv_lqr": (LtvLqrController, CompiledLtvLqrController, LtvLqrConfig(tolerance_y_m=0.05, max_wheel_speed_m_s=0.4)),
}


@needs_cc
@pytest.mark.parametrize("law", sorted(LAWS))
def test_a_unicycle_law_in_c_commands_what_the_python_law_commands(vehicle, law):
    python_class, c_class, config = LAWS[law]
    reference = plan_file("trajectories/figure8.toml", vehicle)
    c_law, py_law = c_class(vehicle, config), python_class(vehicle, config)
    c_law.reset(reference)
    py_law.reset(reference)
    rng = np.random.default_rng(7)
    rows = len(c_law.reference_rows)
    for k in rng.integers(-3, rows + 20, 400):  # before the start and past the end too
        t_s = float(k) * vehicle.control.sample_period_s
        ref = c_law.reference_rows[min(max(int(k), 0), rows - 1)]
        # around the reference, and headings many turns away (the error wraps to [-pi, pi))
        pose = ref[:3] + rng.normal(0.0, [0.1, 0.1, 1.0]) + [0.0, 0.0, 2.0 * math.pi * rng.integers(-3, 4)]
        c, p = c_law.update(t_s, pose, np.zeros(2)), py_law.update(t_s, pose, np.zeros(2))
        assert (c.wheel_speed_left_m_s, c.wheel_speed_right_m_s, c.status) == (
            p.wheel_speed_left_m_s,
            p.wheel_speed_right_m_s,
            p.status,
        )
        assert max(abs(c.wheel_speed_left_m_s), abs(c.wheel_speed_right_m_s)) <= 0.4 + 1e-12  # scaled, rounded
    nan_pose = np.array([math.nan, 0.0, 0.0])  # a pose that is not finite: the reference's own wheel speeds
    lost, py_lost = c_law.update(0.4, nan_pose, np.zeros(2)), py_law.update(0.4, nan_pose, np.zeros(2))
    assert lost.status == py_lost.status == "fallback_feedforward" and c_law.failures == py_law.failures == 1
    assert (lost.wheel_speed_left_m_s, lost.wheel_speed_right_m_s) == (
        py_lost.wheel_speed_left_m_s,
        py_lost.wheel_speed_right_m_s,
    )
    with pytest.raises(ValueError, match="control grid"):
        c_law.update(0.41, np.zeros(3), np.zeros(2))


@needs_cc
@pytest.mark.filterwarnings("ignore::agvctl.feasibility.HeadroomWarning")  # a fuzz run notes them, as here
@pytest.mark.parametrize(("law", "index"), [("ramsete", 3), ("ramsete", 11), ("ltv_lqr", 5)])
def test_in_the_closed_loop_of_fuzz_scenarios_the_c_cascade_commands_what_the_python_cascade_commands(
    law, index, tmp_path
):
    spec = dataclasses.replace(load_fuzz_config("experiments/fuzz/acceptance.toml"), controllers=(law,))
    task = fuzz_tasks(spec, [index]).tasks[0]
    for name, text in task.files:
        (tmp_path / name).write_text(text, encoding="utf-8")
    result = cascade_back_to_back(tmp_path / task.files[-1][0])
    assert result.samples > 100 and result.samples_c == result.samples
    assert result.max_da_difference_v == 0.0
    assert result.same_verdicts


@needs_cc
@pytest.mark.filterwarnings("ignore::agvctl.feasibility.HeadroomWarning")  # a fuzz run notes them, as here
def test_the_fuzzer_runs_a_generated_law_in_its_workers_with_the_python_laws_results():
    laws = ("ltv_lqr", "ramsete")
    spec = load_fuzz_config("experiments/fuzz/acceptance.toml")
    spec = dataclasses.replace(spec, controllers=tuple(name for law in laws for name in (law, f"{law}_c")))
    report = fuzz(spec, jobs=2, scenarios=[0, 1])
    outcomes = {
        (o.scenario, o.controller): (o.passed, o.error, {k: v for k, v in o.metrics.items() if k not in TIMING_METRICS})
        for o in report.outcomes
    }
    assert len(outcomes) == 8
    for scenario in (0, 1):
        for law in laws:
            assert outcomes[(scenario, law)] == outcomes[(scenario, f"{law}_c")]


def test_the_cascades_back_to_back_refuses_another_pose_controller(tmp_path):
    with pytest.raises(ConfigError, match="controller.pose"):
        cascade_back_to_back("experiments/line.toml")


@needs_cc
def test_an_experiment_runs_and_checks_with_the_ramsete_law_as_c(tmp_path, capsys):
    path = line_experiment(
        tmp_path, "line_c.toml", 'pose = "mpc"\nhorizon = 20\n', 'pose = "ramsete_c"\nb_rad2_m2 = 3.0\n'
    )
    assert main(["check", str(path), "--jobs", "1"]) in (0, 1)
    assert "of 1 experiments passed" in capsys.readouterr().out
    python, c = (run_experiment(load_experiment(p)).log for p in (_law_line(tmp_path), path))
    for column in ("setpoint_wheel_speed_left_m_s", "setpoint_wheel_speed_right_m_s", "da_command_left_v", "x_m"):
        np.testing.assert_array_equal(c[column], python[column])


@needs_cc
@pytest.mark.skipif(shutil.which("make") is None or shutil.which("nm") is None, reason="no make or nm")
@pytest.mark.parametrize("law", ["ramsete", "ltv_lqr"])
def test_the_generated_cascade_builds_strictly_holds_no_heap_or_io_and_replays_the_closed_loop(law, tmp_path, capsys):
    experiment = _law_line(tmp_path, law)
    code = generate_code(experiment)
    assert code.cascade.generated and {"agv_cascade.h", f"agv_{law}.c", "agv_reference.c"} <= set(code.files)
    out = tmp_path / "c"
    assert main(["codegen", str(experiment), "--out", str(out)]) == 0
    assert "agv_cascade_step" in capsys.readouterr().out
    built = subprocess.run(["make", "-C", str(out)], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    assert "-Werror" in built.stdout
    example = subprocess.run([str(out / "example")], capture_output=True, text=True, check=True).stdout
    assert example.count("sample ") == 3
    objects = []
    for source in ("agv_cascade.c", f"agv_{law}.c", "agv_reference.c", "agv_wheel_loops.c"):
        obj = tmp_path / source.replace(".c", ".o")
        subprocess.run([c_compiler(), *STRICT_C_FLAGS, "-c", str(out / source), "-o", str(obj)], check=True)
        objects.append(str(obj))
    undefined = subprocess.run(["nm", "-u", *objects], capture_output=True, text=True, check=True).stdout.split()
    assert not {"malloc", "calloc", "realloc", "free", "printf", "fopen", "fwrite"} & set(undefined), undefined

    # the step function, fed the closed loop's estimated pose and measured motor speeds, commands its DA voltages
    sources = {name: text for name, text in code.files.items() if name.endswith((".c", ".h"))}
    sources.pop("example_main.c")
    lib = compiled_library(sources, f"agv_cascade_replay_{law}", flags=(*STRICT_C_FLAGS, "-fPIC", "-shared"))
    _assert_replays(lib, run_experiment(load_experiment(experiment)).log)


def _assert_replays(lib: ctypes.CDLL, log) -> None:
    """The compiled cascade's step, fed the closed loop's estimated pose and measured motor speeds sample by sample,
    commands the loop's DA voltages, bit for bit."""
    lib.agv_cascade_state_size.restype = ctypes.c_size_t
    state = (ctypes.c_double * -(-int(lib.agv_cascade_state_size()) // 8))()
    lib.agv_cascade_step.restype = ctypes.c_uint
    lib.agv_cascade_step.argtypes = [ctypes.c_void_p, ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    lib.agv_cascade_init(state)
    pose, motors, da = (ctypes.c_double * 3)(), (ctypes.c_double * 2)(), (ctypes.c_double * 2)()
    for k in range(len(log)):
        pose[:] = [float(log[f"est_{c}"][k]) for c in ("x_m", "y_m", "theta_rad")]
        motors[:] = [float(log[f"measured_omega_motor_{s}_rad_s"][k]) for s in ("left", "right")]
        lib.agv_cascade_step(state, k, pose, motors, da)
        assert (da[0], da[1]) == (log["da_command_left_v"][k], log["da_command_right_v"][k]), k


def test_without_a_compiler_the_c_law_says_so_in_one_line(vehicle, tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(AgvctlError, match="the generated C of the LTV unicycle LQR cannot be compiled") as caught:
        CompiledLtvLqrController(vehicle)
    assert "\n" not in str(caught.value)


@needs_cc
@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
@pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}")
def test_the_mpcs_generated_cascade_builds_strictly_and_replays_the_figure_8_closed_loop(tmp_path, capsys):
    """The LTV MPC's cascade (its QP's solver, step and tables, the controller's step with its settings, the PI
    loops): built with warnings as errors, its one step function fed the closed loop's estimated pose and measured
    motor speeds commands the closed loop's DA voltages, bit for bit, in every sample of the figure 8 (a run that
    ends within tolerance, so no docking, which is not generated)."""
    out = tmp_path / "c"
    assert main(["codegen", "experiments/figure8.toml", "--out", str(out)]) == 0
    assert "docking manoeuvres" in capsys.readouterr().out
    built = subprocess.run(["make", "-C", str(out)], capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    example = subprocess.run([str(out / "example")], capture_output=True, text=True, check=True).stdout
    assert example.count("sample ") == 3

    code = generate_code("experiments/figure8.toml", measure_memory=False)
    assert code.cascade.generated
    sources = {name: text for name, text in code.files.items() if name.endswith((".c", ".h"))}
    sources.pop("example_main.c")
    lib = compiled_library(sources, "agv_cascade_replay_mpc", flags=(*STRICT_C_FLAGS, "-O3", "-fPIC", "-shared"))
    result = run_experiment(load_experiment("experiments/figure8.toml"))
    assert result.n_samples > 700
    _assert_replays(lib, result.log)


@needs_cc
@pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}")
def test_the_mpcs_generated_cascade_docks_as_the_closed_loop_does(tmp_path, monkeypatch):
    """A random scenario whose vehicle stops beside the path's end and docks once: the folder's cascade (the
    manoeuvres planned ahead for each backing distance) commands the closed loop's DA voltages, bit for bit, through
    the path, the decision to dock, the manoeuvre and the rest."""
    manoeuvres: list[object] = []
    after_step = EndOfPath.after_step

    def counting(self, *args):
        manoeuvre = after_step(self, *args)
        if manoeuvre is not None:
            manoeuvres.append(manoeuvre)
        return manoeuvre

    monkeypatch.setattr(EndOfPath, "after_step", counting)
    spec = override_fuzz_config(load_fuzz_config("experiments/fuzz/acceptance.toml"), seed=515151)
    task = fuzz_tasks(dataclasses.replace(spec, controllers=("mpc",)), [12]).tasks[0]
    for name, text in task.files:
        (tmp_path / name).write_text(text, encoding="utf-8")
    experiment = tmp_path / task.files[-1][0]
    code = generate_code(experiment, measure_memory=False)
    result = run_experiment(load_experiment(experiment))
    assert len(manoeuvres) == 1
    sources = {name: text for name, text in code.files.items() if name.endswith((".c", ".h"))}
    sources.pop("example_main.c")
    lib = compiled_library(sources, "agv_cascade_replay_docking", flags=(*STRICT_C_FLAGS, "-O3", "-fPIC", "-shared"))
    _assert_replays(lib, result.log)
