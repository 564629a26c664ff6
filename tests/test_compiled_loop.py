"""The closed loop in C: where the pose and the motor speeds are the truth it runs the same samples as the loop in
Python, each controller's compiled step or its Python called from the C, and writes the same log to the last bit;
a controller's error surfaces as in Python; where an estimator computes, the loop stays in Python."""

from __future__ import annotations

import ctypes
import json
import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.cli import main
from agvctl.controllers.base import CStep, PoseCommand
from agvctl.controllers.baselines import RamseteController
from agvctl.controllers.baselines.c_unicycle import CompiledLtvLqrController, CompiledRamseteController
from agvctl.controllers.mpc import LtvMpcController
from agvctl.controllers.pi import default_pi_gains
from agvctl.controllers.pi.c_loops import STRICT_C_FLAGS, CompiledPIWheelController
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.planning import plan_file
from agvctl.plant.codegen import c_compiler, compiled_library
from agvctl.plant.integrator import sample_splits
from agvctl.sim import compiled_loop
from agvctl.sim.loop import run_closed_loop

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")

POSE = {
    "ramsete_c": CompiledRamseteController,
    "ltv_lqr_c": CompiledLtvLqrController,
    "ramsete": RamseteController,
    "mpc": LtvMpcController,
}
PLANTS = {
    # the plant off the model, the gyro on: its readings drawn from the same stream in the same order
    "off_model": ["wheels.right.radius_m=0.101", "body.mass_kg=100", "sensors.gyro_enabled=true"],
    # a stiff friction model: eight sub-samples per sample, their statistics merged
    "stiff": ["friction_model.p_factor=100", "motor.stiction_n_m=0.09"],
}


class _Quiet:
    """Wheel loops that do not say whether they clamped (no ``limited``): the log's flags are NaN."""

    def __init__(self, loops):
        self._loops = loops

    def reset(self):
        self._loops.reset()

    def update(self, setpoint_rad_s, measured_rad_s):
        return self._loops.update(setpoint_rad_s, measured_rad_s)


def _wheels(vehicle, kind):
    gains = default_pi_gains(vehicle).gains
    return {
        "pi_c": lambda: CompiledPIWheelController(vehicle, gains),
        "pi": lambda: PIWheelController(vehicle, gains),
        "quiet": lambda: _Quiet(PIWheelController(vehicle, gains)),
    }[kind]()


def _run(
    vehicle, plant_vehicle, pose, wheels, *, compiled, delay="none", start=(0.03, -0.02, 0.05), path="figure8", **more
):
    reference = plan_file(f"trajectories/{path}.toml", vehicle)
    return run_closed_loop(
        plant_vehicle=plant_vehicle,
        controller_vehicle=vehicle,
        reference=reference,
        pose_controller=pose if not isinstance(pose, str) else POSE[pose](vehicle),
        wheel_controller=_wheels(vehicle, wheels),
        initial_pose=start,
        settle_s=1.0,
        compute_delay=delay,
        sensor_seed=5,
        compiled=compiled,
        **more,
    )


CASES = [
    ("ramsete_c", "pi_c", "off_model", "none", "figure8"),
    ("ltv_lqr_c", "pi_c", "stiff", "one_sample", "figure8"),
    ("ramsete", "pi", "off_model", "one_sample", "figure8"),  # both controllers called in Python
    ("mpc", "pi_c", "off_model", "none", "dock"),  # an MPC that keeps its own clock and docks
    ("ramsete_c", "quiet", "stiff", "none", "line"),  # wheel loops that do not report their clamping
]


@needs_cc
@pytest.mark.parametrize(("pose", "wheels", "plant", "delay", "path"), CASES)
def test_the_loop_in_c_writes_the_python_loops_log_to_the_last_bit(
    vehicle, pose, wheels, plant, delay, path, monkeypatch
):
    plant_vehicle = vehicle.with_overrides(PLANTS[plant])
    used = []
    run = compiled_loop.run_compiled
    monkeypatch.setattr("agvctl.sim.loop.run_compiled", lambda *a, **k: used.append(1) or run(*a, **k))
    python = _run(vehicle, plant_vehicle, pose, wheels, compiled=False, delay=delay, path=path)
    in_c = _run(vehicle, plant_vehicle, pose, wheels, compiled=True, delay=delay, path=path)
    assert used == [1]  # the second run went through the C loop, the first did not
    assert (python.loop, in_c.loop) == ("python", "c")
    assert python.n_samples == in_c.n_samples and python.solver_failures == in_c.solver_failures
    assert list(python.log) == list(in_c.log)
    for name in python.log:
        if name != "solve_time_s":  # measured: the Python step's time, or the C step's
            np.testing.assert_array_equal(python.log[name], in_c.log[name], err_msg=name)
    assert np.all(in_c.log["solve_time_s"] >= 0.0)
    if plant == "stiff":
        assert sample_splits(plant_vehicle) > 1
    else:
        assert np.isfinite(in_c.log["gyro_rate_rad_s"][1:]).all()
    if wheels == "quiet":
        assert np.isnan(in_c.log["wheel_loop_limited_left"]).all()


@needs_cc
def test_the_loop_in_c_reports_progress_each_simulated_second_and_writes_the_same_log(vehicle):
    # with a progress report the C runs a second at a time, its sub-samples' statistics merged after each call
    stiff = vehicle.with_overrides(PLANTS["stiff"])
    reports = {False: [], True: []}
    runs = {c: _run(vehicle, stiff, "ltv_lqr_c", "pi_c", compiled=c, progress=reports[c].append) for c in reports}
    assert runs[True].loop == "c" and sample_splits(stiff) > 1
    for name in runs[False].log:
        if name != "solve_time_s":
            np.testing.assert_array_equal(runs[False].log[name], runs[True].log[name], err_msg=name)
    done = reports[True]
    assert done[-1] == 1.0 and done == sorted(done) and len(done) >= runs[True].n_samples * 0.04 - 1


@needs_cc
def test_fallbacks_in_the_loop_in_c_are_counted_as_in_python(vehicle):
    # a start 2 m off: the laws are far from their reference; the counts must agree whatever they are
    runs = [_run(vehicle, vehicle, "ramsete_c", "pi_c", compiled=c, start=(2.0, -2.0, 3.0)) for c in (False, True)]
    assert runs[0].solver_failures == runs[1].solver_failures
    np.testing.assert_array_equal(runs[0].log["solver_status"], runs[1].log["solver_status"])


class _Breaks:
    """A pose controller that raises at its fifth sample, and one that commands NaN from its third."""

    def __init__(self, vehicle, how):
        self._law, self._how = RamseteController(vehicle), how

    def reset(self, reference):
        self._law.reset(reference)

    def update(self, t_s, pose, wheel_speed_m_s):
        k = round(t_s / 0.04)
        if self._how == "raises" and k == 5:
            raise ZeroDivisionError("the user's controller divided by zero")
        command = self._law.update(t_s, pose, wheel_speed_m_s)
        if self._how == "nan" and k >= 3:
            return type(command)(math.nan, command.wheel_speed_right_m_s)
        return command


@needs_cc
def test_a_controller_in_python_that_raises_stops_the_loop_in_c_with_its_error(vehicle):
    for compiled in (False, True):
        with pytest.raises(ZeroDivisionError, match="divided by zero"):
            _run(vehicle, vehicle, _Breaks(vehicle, "raises"), "pi_c", compiled=compiled, path="line")
    runs = [_run(vehicle, vehicle, _Breaks(vehicle, "nan"), "pi", compiled=c, path="line") for c in (False, True)]
    assert runs[1].loop == "c" and runs[0].solver_failures == runs[1].solver_failures == runs[1].n_samples - 2
    np.testing.assert_array_equal(runs[0].log["x_m"], runs[1].log["x_m"])


@needs_cc
def test_an_estimator_that_computes_keeps_the_loop_in_python(vehicle, monkeypatch):
    reference = plan_file("trajectories/figure8.toml", vehicle)
    monkeypatch.setattr("agvctl.sim.loop.run_compiled", lambda *a, **k: pytest.fail("the loop ran in C"))
    common = {"plant_vehicle": vehicle, "controller_vehicle": vehicle, "reference": reference, "settle_s": 0.0}
    for estimators in ({"localization": "odometry"}, {"wheel_speed": "count_difference"}):
        run = run_closed_loop(
            **common,
            pose_controller=CompiledRamseteController(vehicle),
            wheel_controller=_wheels(vehicle, "pi_c"),
            **estimators,
        )
        assert run.loop == "python"


@needs_cc
def test_agvctl_run_says_where_the_loop_ran(tmp_path, capsys):
    trajectory = Path("trajectories/line.toml").resolve()
    for localization, where in (("truth", "the loop in C"), ("odometry", "the loop in Python")):
        experiment = tmp_path / f"{localization}.toml"
        experiment.write_text(
            f'name = "{localization}"\ntrajectory = "{trajectory}"\n\n[controller]\npose = "ramsete_c"\n'
            f'localization = "{localization}"\n',
            encoding="utf-8",
        )
        assert main(["run", str(experiment), "--no-plot", "--out", str(tmp_path / localization)]) == 0
        assert where in capsys.readouterr().out
        summary = json.loads((tmp_path / localization / "summary.json").read_text(encoding="utf-8"))
        assert summary["loop"] == where.removeprefix("the loop in ").lower()


USER_C = """
typedef struct { double speed_m_s; } user_state;
/* A user's pose controller in C: both wheels at one speed, whatever the pose. */
int user_pose_step(void *state, long k, const double *pose, double *setpoint_m_s)
{
    const user_state *s = (const user_state *)state;
    (void)k;
    (void)pose;
    setpoint_m_s[0] = s->speed_m_s;
    setpoint_m_s[1] = s->speed_m_s;
    return 0;
}
"""


class _UsersCController:
    """A user's controller with a compiled step (its state a struct it owns), and the same law in Python."""

    def __init__(self, speed_m_s):
        lib = compiled_library(USER_C, "user_pose_step", flags=(*STRICT_C_FLAGS, "-fPIC", "-shared"))
        self._step, self._state, self.speed_m_s = lib.user_pose_step, (ctypes.c_double * 1)(speed_m_s), speed_m_s

    def reset(self, reference):
        del reference

    def update(self, t_s, pose, wheel_speed_m_s):
        return PoseCommand(self.speed_m_s, self.speed_m_s)

    def compiled_step(self):
        return CStep(ctypes.cast(self._step, ctypes.c_void_p).value, ctypes.addressof(self._state))


@needs_cc
def test_a_users_own_c_controller_is_called_by_the_loop_in_c(vehicle, monkeypatch):
    called = []
    monkeypatch.setattr(_UsersCController, "update", lambda *a: called.append(1) or PoseCommand(0.1, 0.1))
    in_c = _run(vehicle, vehicle, _UsersCController(0.1), "pi_c", compiled=True, path="line")
    assert in_c.loop == "c" and not called  # the C step ran, the Python update never did
    np.testing.assert_array_equal(in_c.log["setpoint_wheel_speed_left_m_s"], 0.1)
    python = _run(vehicle, vehicle, _UsersCController(0.1), "pi_c", compiled=False, path="line")
    assert called and all(
        np.array_equal(python.log[k], in_c.log[k], equal_nan=True) for k in python.log if k != "solve_time_s"
    )
