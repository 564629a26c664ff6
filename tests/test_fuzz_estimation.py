"""The fuzz draws estimators and true sensors: each scenario one of the ``[estimators]`` lists' names and its own
sensor noise seed, the true sensors within the ``[plant]`` envelope, and the drawn scenario runs as written."""

import dataclasses
from pathlib import Path

import pytest

from agvctl.errors import ConfigError
from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config
from agvctl.params import load_vehicle

FUZZ = Path(__file__).resolve().parent.parent / "experiments" / "fuzz"


def _config(tmp_path, text):
    path = tmp_path / "fuzz.toml"
    path.write_text('seed = 3\nscenarios = 40\ncontrollers = ["mpc"]\n' + text, encoding="utf-8")
    return path


def test_each_scenario_draws_its_estimators_and_sensor_seed_after_the_rest(tmp_path):
    vehicle = load_vehicle()
    spec = load_fuzz_config(
        _config(tmp_path, '[estimators]\nlocalization = ["ekf", "odometry"]\nwheel_speed = ["kalman", "exact"]\n')
    )
    plain = dataclasses.replace(spec, estimators=type(spec.estimators)())
    drawn = [generate_scenario(spec, vehicle, i) for i in range(40)]
    assert {s.estimators["localization"] for s in drawn} == {"ekf", "odometry"}
    assert {s.estimators["wheel_speed"] for s in drawn} == {"kalman", "exact"}
    assert len({s.sensor_seed for s in drawn}) == 40
    for i, s in enumerate(drawn):  # drawn last: the paths, plants and starts are those of a fuzz without them
        other = generate_scenario(plain, vehicle, i)
        assert (s.path, s.plant_set, s.initial_pose, s.sensor_seed) == (
            other.path,
            other.plant_set,
            other.initial_pose,
            other.sensor_seed,
        )
        text = scenario_files(spec, s, "mpc")[f"{s.name}_mpc.toml"]
        assert f'localization = "{s.estimators["localization"]}"' in text and f"sensor_seed = {s.sensor_seed}" in text


def test_the_estimation_fuzz_draws_true_sensors_within_their_envelope():
    spec = load_fuzz_config(FUZZ / "estimation.toml")
    vehicle = load_vehicle()
    s = vehicle.sensors
    for i in range(50):
        plant = generate_scenario(spec, vehicle, i).plant_set
        assert 0.75 * s.position_fix_sigma_m <= plant["sensors.position_fix_sigma_m"] <= 1.25 * s.position_fix_sigma_m
        assert 0.5 * s.position_fix_rate_hz <= plant["sensors.position_fix_rate_hz"] <= s.position_fix_rate_hz
        assert 0.01 - 1e-9 <= plant["sensors.position_fix_latency_s"] <= 0.1 + 1e-9


def test_bad_estimators_tables_are_one_line_errors(tmp_path):
    with pytest.raises(ConfigError, match=r"estimators.localization\[1\]: must be one of 'truth'"):
        load_fuzz_config(_config(tmp_path, '[estimators]\nlocalization = ["ekf", "kalman"]\n'))
    with pytest.raises(ConfigError, match=r"controller.localization: drawn by \[estimators\] localization"):
        load_fuzz_config(
            _config(tmp_path, '[controller]\nlocalization = "ekf"\n[estimators]\nlocalization = ["ekf"]\n')
        )


def test_estimation_fuzz_scenarios_run_on_the_ekf_and_pass_the_gate():
    spec = override_fuzz_config(load_fuzz_config(FUZZ / "estimation.toml"), seed=5, scenarios=2)
    report = fuzz(spec, jobs=1)
    for outcome in report.outcomes:
        assert outcome.error is None and outcome.passed, outcome.reasons
        assert 0.3 < outcome.metrics["nees_mean"] < 9.0  # of the order of its 3 degrees of freedom
        assert outcome.metrics["fixes_dropped"] == 0
