"""The closed loop: every shipped experiment runs; the acceptance figures of the figure-8; the run command."""

from pathlib import Path

import numpy as np
import pytest

from agvctl.checks.summary import run_summary
from agvctl.sim.experiment import load_experiment, prepare_experiment, run_experiment
from agvctl.sim.metrics import closed_loop_metrics

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"
SHIPPED = sorted(EXPERIMENTS.glob("*.toml"))


def run_file(name, **edits):
    exp = load_experiment(EXPERIMENTS / name)
    prepared = prepare_experiment(exp)
    result = run_experiment(prepared)
    return prepared, result, closed_loop_metrics(result)


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_experiment_runs_and_passes_its_limits(path):
    exp = load_experiment(path)
    prepared = prepare_experiment(exp)
    result = run_experiment(prepared)
    summary = run_summary(prepared, result)
    log = result.log
    ts = prepared.controller_vehicle.control.sample_period_s
    np.testing.assert_allclose(np.diff(log["t_s"]), ts, rtol=1e-9)
    assert log["t_s"][-1] >= prepared.reference.duration_s + exp.settle_s - 1e-9
    for name in log:
        assert np.all(np.isfinite(log[name])), name
    # nothing reaches the plant but through the actuator: every motor voltage is a DA code times alpha times k_pow
    alpha, gain = prepared.plant_vehicle.da.volts_per_code, prepared.plant_vehicle.amplifier.gain
    np.testing.assert_allclose(log["motor_voltage_left_v"], gain * alpha * log["da_code_left"], atol=1e-12)
    assert np.all(np.abs(log["current_peak_left_a"]) <= 5.5 + 1e-9)
    assert summary["passed"], [r["message"] for r in summary["limits"] if not r["passed"]]
