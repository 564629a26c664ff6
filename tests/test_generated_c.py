"""The PI wheel loops as generated C: they compile with warnings as errors, hold no heap and no file I/O, command
what the Python loops command, and run in the closed loop."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import osqp
import pytest
from cli_runs import line_experiment

from agvctl.cli import main
from agvctl.codegen import back_to_back, generate_code
from agvctl.controllers.mpc.osqp_fixes import OSQP_VERSION
from agvctl.controllers.pi import Braking, PIWheelController, WheelLoopOptions, default_pi_gains
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS, CompiledPIWheelController
from agvctl.errors import AgvctlError
from agvctl.fuzz.run import fuzz_tasks
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.plant.codegen import c_compiler

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")


@pytest.fixture(scope="module")
def figure8_code():
    return generate_code("experiments/figure8.toml", measure_memory=c_compiler() is not None)


def _write(files: dict[str, str], folder: Path) -> None:
    for name, text in files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text, encoding="utf-8")


@needs_cc
def test_the_generated_loops_compile_with_warnings_as_errors_and_stop_at_the_current_limit(vehicle, tmp_path):
    loops_code = generate_code("experiments/figure8_nmpc.toml")  # no generated pose controller: the loops' example
    assert not loops_code.cascade.generated
    _write(loops_code.files, tmp_path)
    subprocess.run(
        [c_compiler(), *STRICT_C_FLAGS, "-o", "example", "example_main.c", "agv_wheel_loops.c", "-lm"],
        cwd=tmp_path,
        check=True,
        capture_output=True,
    )
    out = subprocess.run([str(tmp_path / "example")], check=True, capture_output=True, text=True).stdout
    da = [[float(v) for v in m] for m in re.findall(r"da_v = (\S+) (\S+) limited = \d", out)]
    limited = [int(m) for m in re.findall(r"limited = (\d)", out)]
    gains = loops_code.experiment.wheel_loops.design.gains
    motor, amp = vehicle.motor.left, vehicle.amplifier
    # first sample of a 10 rad/s step on a blocked wheel: k_p e + k_i T_s e + the Coulomb voltage τ_c R/k_t, inside
    # the current window (eq 1 at standstill: |u| ≤ R I_max), over the amplifier gain
    first_v = gains.kp * 10 + gains.ki * gains.dt_s * 10
    first_v += motor.coulomb_friction_n_m * motor.resistance_ohm / motor.torque_constant_n_m_a
    assert first_v < motor.resistance_ohm * amp.current_limit_a
    assert da[0] == pytest.approx([first_v / amp.gain] * 2, rel=1e-12)
    # the integrator winds the command up to the current limit at standstill, less half a DA step, and says so
    da_step_v = vehicle.da.volts_per_code * amp.gain
    limit_v = (motor.resistance_ohm * amp.current_limit_a - da_step_v / 2) / amp.gain
    assert da[2] == pytest.approx([limit_v] * 2, rel=1e-12) and limited[2] == 3 and limited[0] == 0
    m = loops_code.memory
    assert m is not None
    assert f"state {m.state_bytes} bytes, constants {m.constant_bytes} bytes" in out
    assert 0 < m.state_bytes <= 64 and 0 < m.constant_bytes <= 512  # two loops' state and constants, no tables


def test_the_generated_loops_hold_no_heap_no_file_io_and_say_where_they_come_from(figure8_code):
    for name in ("agv_wheel_loops.c", "agv_wheel_loops.h"):
        text = figure8_code.files[name]
        code = re.sub(r"/\*.*?\*/", "", text, flags=re.S)  # the comments may name what the code does not do
        assert not re.search(r"\b(malloc|calloc|realloc|free|fopen|fread|fwrite|printf|fprintf|FILE|stdio)\b", code)
        assert "agvctl" in text and "figure8" in text
    readme = figure8_code.files["README.md"]
    assert "figure8" in readme and re.search(r"agvctl \d+\.\d+", readme)


def _random_inputs(rng, n):
    """Setpoints and speeds across the whole range, with rests (zero setpoint, wheel nearly still) between."""
    for _ in range(n):
        if rng.random() < 0.15:
            yield np.zeros(2), rng.normal(0.0, 0.05, 2)
        else:
            yield rng.normal(0.0, 150.0, 2), rng.normal(0.0, 150.0, 2)


OPTION_SETS = [
    WheelLoopOptions(),
    WheelLoopOptions(braking=Braking.SYMMETRIC, coulomb_feedforward=False),
    WheelLoopOptions(braking=Braking.GENTLE_STOP, steering_priority=False),
    WheelLoopOptions(anti_windup=False),
]


@needs_cc
@pytest.mark.parametrize("options", OPTION_SETS, ids=lambda o: f"{o.braking.value}-aw{int(o.anti_windup)}")
def test_the_c_loops_command_what_the_python_loops_command(vehicle, options):
    gains = default_pi_gains(vehicle).gains
    c_loops, py_loops = CompiledPIWheelController(vehicle, gains, options), PIWheelController(vehicle, gains, options)
    rng = np.random.default_rng(7)
    clamped = 0
    for setpoint, measured in _random_inputs(rng, 3000):
        np.testing.assert_array_equal(c_loops.update(setpoint, measured), py_loops.update(setpoint, measured))
        assert c_loops.limited == py_loops.limited
        clamped += any(py_loops.limited)
    assert clamped > 100 or not options.anti_windup  # the clamps were exercised
    c_loops.reset()
    py_loops.reset()
    np.testing.assert_array_equal(c_loops.update(np.ones(2), np.zeros(2)), py_loops.update(np.ones(2), np.zeros(2)))


@needs_cc
@pytest.mark.filterwarnings("ignore::agvctl.feasibility.HeadroomWarning")  # a fuzz run notes them, as here
@pytest.mark.parametrize("index", [3, 11])
def test_in_the_closed_loop_of_fuzz_scenarios_the_c_loops_match_the_python_loops(index, tmp_path):
    spec = load_fuzz_config("experiments/fuzz/acceptance.toml")
    task = next(t for t in fuzz_tasks(spec, [index]).tasks if t.controller == "mpc")
    _write(dict(task.files), tmp_path)
    result = back_to_back(tmp_path / task.files[-1][0])
    assert result.samples > 100
    assert result.max_da_difference_v <= 1e-9 and result.limited_mismatches == 0
    assert result.same_verdicts


@needs_cc
def test_an_experiment_runs_its_wheel_loops_as_c_when_it_names_pi_c(tmp_path, capsys):
    line_experiment(tmp_path, "line_c.toml", "[controller]\n", '[controller]\nwheel_loops = "pi_c"\n')
    assert main(["check", str(tmp_path / "line_c.toml"), "--jobs", "1"]) == 0
    assert "1 of 1 experiments passed" in capsys.readouterr().out


def test_without_a_compiler_the_c_loops_say_so_in_one_line(vehicle, tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.raises(AgvctlError, match="cannot be compiled") as caught:
        CompiledPIWheelController(vehicle, default_pi_gains(vehicle).gains)
    assert "\n" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []  # nothing half-written left in the cache


@needs_cc
def test_codegen_writes_the_folder_and_prints_the_static_memory(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["codegen", "experiments/line.toml", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert re.search(r"static memory: state \d+ bytes .*constants \d+ bytes", printed)
    assert {p.name for p in out.iterdir()} >= {"agv_wheel_loops.h", "agv_wheel_loops.c", "README.md", "Makefile"}
    assert main(["codegen", "experiments/line.toml", "--out", str(out)]) == 0  # its own output: replaced whole


@needs_cc
@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
def test_codegen_keeps_what_make_built_in_its_folder_and_replaces_it_after_make_clean(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["codegen", "experiments/line.toml", "--out", str(out)]) == 0
    subprocess.run(["make", "-C", str(out)], check=True, capture_output=True)
    built = {p.name for p in out.iterdir()}
    capsys.readouterr()
    assert main(["codegen", "experiments/line.toml", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "which agvctl did not write there" in err
    assert {p.name for p in out.iterdir()} == built  # the build is kept
    subprocess.run(["make", "-C", str(out), "clean"], check=True, capture_output=True)
    assert main(["codegen", "experiments/line.toml", "--out", str(out)]) == 0


def test_codegen_refuses_a_folder_of_the_users_and_leaves_it_untouched(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("mine", encoding="utf-8")
    assert main(["codegen", "experiments/line.toml", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_codegen_refuses_an_experiment_whose_wheel_loops_are_the_users(tmp_path, capsys):
    line_experiment(tmp_path, "mine.toml", "[controller]\n", '[controller]\nwheel_loops = "loops.py:Mine"\n')
    (tmp_path / "loops.py").write_text(
        "class Mine:\n    def __init__(self, vehicle, settings): pass\n    def reset(self): pass\n"
        "    def update(self, setpoint_rad_s, measured_rad_s): return setpoint_rad_s * 0.0\n",
        encoding="utf-8",
    )
    assert main(["codegen", str(tmp_path / "mine.toml"), "--out", str(tmp_path / "c")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "controller.wheel_loops" in err
    assert not (tmp_path / "c").exists()


@needs_cc
@pytest.mark.skipif(shutil.which("make") is None or shutil.which("nm") is None, reason="no make or nm")
@pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}")
def test_the_mpcs_qp_solver_is_in_the_folder_and_builds_into_a_library_with_no_heap_and_no_io(figure8_code, tmp_path):
    qp = figure8_code.qp
    assert qp.code is not None and "mpc_qp/agv_mpc_qp.h" in figure8_code.files
    _write(figure8_code.files, tmp_path)
    done = subprocess.run(["make", "-C", str(tmp_path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "-Werror" in figure8_code.files["Makefile"] and (tmp_path / "libagv_mpc_qp.a").is_file()
    listed = subprocess.run(["nm", str(tmp_path / "libagv_mpc_qp.a")], capture_output=True, text=True, check=True)
    undefined = {line.split()[-1] for line in listed.stdout.splitlines() if re.match(r"^\s+U\s", line)}
    defined = {line.split()[-1] for line in listed.stdout.splitlines() if re.match(r"^[0-9a-f]+\s+[A-Za-z]\s", line)}
    # the solver's square roots; the step's angles; the governor's rounding to the grid and distances; docking's
    libm = {"sqrt", "cos", "sin", "sincos", "fmod", "nearbyint", "hypot", "atan2", "ceil"}
    assert undefined - defined <= {"memset", "memcpy", *libm}, undefined - defined  # no heap, no file I/O
    # the workspace holds P, A, their factorisation and the iterates: tens of kB for n = 150, m = 248
    assert qp.static_bytes is not None and qp.table_bytes is not None
    assert 10_000 < qp.static_bytes - qp.table_bytes < 1_000_000
    # the reference's tables: some hundred values (A_j, -A_j, -B_j, bounds, weights) for each of the figure 8's
    # 28.6 s / 40 ms + N + 2 grid points, and as many for the eight docking manoeuvres' (each 2 to 8 s), in 8 bytes
    assert 50 * 687 * 8 < qp.table_bytes < 150 * (687 + 8 * (200 + 22)) * 8
    assert f"{qp.static_bytes} bytes of static storage" in figure8_code.files["README.md"]


@needs_cc
@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
@pytest.mark.skipif(osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION}")
def test_with_float_the_qp_solver_is_single_precision_builds_strictly_and_takes_less_memory(figure8_code, tmp_path):
    single = generate_code("experiments/figure8.toml", single=True)
    assert single.qp.code is not None and single.qp.code.single
    assert "#define OSQP_USE_FLOAT" in single.files["mpc_qp/osqp_configure.h"]
    assert "single precision (float)" in single.files["README.md"]
    _write(single.files, tmp_path)
    done = subprocess.run(["make", "-C", str(tmp_path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    single_bytes, double_bytes = single.qp.static_bytes, figure8_code.qp.static_bytes
    assert single_bytes is not None and double_bytes is not None
    assert single.qp.table_bytes == figure8_code.qp.table_bytes is not None  # the step and its tables in double
    solver_single, solver_double = single_bytes - single.qp.table_bytes, double_bytes - figure8_code.qp.table_bytes
    assert solver_single < 0.8 * solver_double  # the workspace's values in 4 bytes, not 8


def test_a_pose_controller_neither_generated_nor_solving_a_qp_gets_the_loops_only_and_the_readme_says_why(tmp_path):
    line_experiment(tmp_path, "ff.toml", 'pose = "mpc"\nhorizon = 20\n', 'pose = "none"\n')
    code = generate_code(tmp_path / "ff.toml", measure_memory=False)
    assert code.experiment.spec.controller.pose == "none" and not code.cascade.generated
    assert "has no generated step yet" in code.files["README.md"] and "agv_cascade.h" not in code.files
    assert not any(name.startswith("mpc_qp/") for name in code.files) and "mpc_qp" not in code.files["Makefile"]
    assert code.qp.code is None and "solves no QP" in code.files["README.md"]
