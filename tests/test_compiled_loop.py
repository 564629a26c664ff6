"""The closed loop in C: where every part has a compiled step it runs the same samples as the loop in Python and
writes the same log to the last bit; where a part has none, the loop stays in Python."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from agvctl.cli import main
from agvctl.controllers.baselines.c_unicycle import CompiledLtvLqrController, CompiledRamseteController
from agvctl.controllers.pi import default_pi_gains
from agvctl.controllers.pi.c_loops import CompiledPIWheelController
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.planning import plan_file
from agvctl.plant.codegen import c_compiler
from agvctl.plant.integrator import sample_splits
from agvctl.sim import compiled_loop
from agvctl.sim.loop import run_closed_loop

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")

LAWS = {"ramsete": CompiledRamseteController, "ltv_lqr": CompiledLtvLqrController}
PLANTS = {
    # the plant off the model, the gyro on: its readings drawn from the same stream in the same order
    "off_model": ["wheels.right.radius_m=0.101", "body.mass_kg=100", "sensors.gyro_enabled=true"],
    # a stiff friction model: eight sub-samples per sample, their statistics merged
    "stiff": ["friction_model.p_factor=100", "motor.stiction_n_m=0.09"],
}


def _run(vehicle, plant_vehicle, law, *, compiled, delay="none", start=(0.03, -0.02, 0.05)):
    reference = plan_file("trajectories/figure8.toml", vehicle)
    return run_closed_loop(
        plant_vehicle=plant_vehicle,
        controller_vehicle=vehicle,
        reference=reference,
        pose_controller=LAWS[law](vehicle),
        wheel_controller=CompiledPIWheelController(vehicle, default_pi_gains(vehicle).gains),
        initial_pose=start,
        settle_s=1.0,
        compute_delay=delay,
        sensor_seed=5,
        compiled=compiled,
    )


@needs_cc
@pytest.mark.parametrize(
    ("law", "plant", "delay"), [("ramsete", "off_model", "none"), ("ltv_lqr", "stiff", "one_sample")]
)
def test_the_loop_in_c_writes_the_python_loops_log_to_the_last_bit(vehicle, law, plant, delay, monkeypatch):
    plant_vehicle = vehicle.with_overrides(PLANTS[plant])
    used = []
    run = compiled_loop.run_compiled
    monkeypatch.setattr("agvctl.sim.loop.run_compiled", lambda *a, **k: used.append(1) or run(*a, **k))
    python = _run(vehicle, plant_vehicle, law, compiled=False, delay=delay)
    in_c = _run(vehicle, plant_vehicle, law, compiled=True, delay=delay)
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


@needs_cc
def test_fallbacks_in_the_loop_in_c_are_counted_as_in_python(vehicle):
    # a start 2 m off: the laws are far from their reference; the counts must agree whatever they are
    runs = [_run(vehicle, vehicle, "ramsete", compiled=c, start=(2.0, -2.0, 3.0)) for c in (False, True)]
    assert runs[0].solver_failures == runs[1].solver_failures
    np.testing.assert_array_equal(runs[0].log["solver_status"], runs[1].log["solver_status"])


@needs_cc
def test_a_part_without_a_compiled_step_keeps_the_loop_in_python(vehicle, monkeypatch):
    reference = plan_file("trajectories/figure8.toml", vehicle)
    monkeypatch.setattr("agvctl.sim.loop.run_compiled", lambda *a, **k: pytest.fail("the loop ran in C"))
    gains = default_pi_gains(vehicle).gains
    common = {"plant_vehicle": vehicle, "controller_vehicle": vehicle, "reference": reference, "settle_s": 0.0}
    parts = [
        {"pose_controller": CompiledRamseteController(vehicle), "wheel_controller": PIWheelController(vehicle, gains)},
        {
            "pose_controller": CompiledRamseteController(vehicle),
            "wheel_controller": CompiledPIWheelController(vehicle, gains),
            "localization": "odometry",
        },
        {
            "pose_controller": CompiledRamseteController(vehicle),
            "wheel_controller": CompiledPIWheelController(vehicle, gains),
            "wheel_speed": "count_difference",
        },
    ]
    for part in parts:
        assert run_closed_loop(**common, **part).loop == "python"


@needs_cc
def test_agvctl_run_says_where_the_loop_ran(tmp_path, capsys):
    trajectory = Path("trajectories/line.toml").resolve()
    for wheel_loops, where in (("pi_c", "the loop in C"), ("pi", "the loop in Python")):
        experiment = tmp_path / f"{wheel_loops}.toml"
        experiment.write_text(
            f'name = "{wheel_loops}"\ntrajectory = "{trajectory}"\n\n[controller]\npose = "ramsete_c"\n'
            f'wheel_loops = "{wheel_loops}"\n',
            encoding="utf-8",
        )
        assert main(["run", str(experiment), "--no-plot", "--out", str(tmp_path / wheel_loops)]) == 0
        assert where in capsys.readouterr().out
        summary = json.loads((tmp_path / wheel_loops / "summary.json").read_text(encoding="utf-8"))
        assert summary["loop"] == where.removeprefix("the loop in ").lower()
