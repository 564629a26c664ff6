"""A vehicle is checked against physics: each number within its physically possible range, the numbers together
by the rules of agvctl.params.rules (each named in its message with its reason and the report's equation), in a
file, under --set and in Python alike; a rule is accepted by name in [checks] accept; every refusal names the key."""

from __future__ import annotations

import dataclasses
import importlib.util
import shutil
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from cli_runs import one_line, run
from hypothesis import HealthCheck, given, settings

from agvctl.config import dump_toml
from agvctl.errors import ConfigError
from agvctl.params import default_vehicle_path, load_vehicle
from agvctl.params.rules import VEHICLE_RULES
from agvctl.planning import plan
from agvctl.planning.spec import load_path

ROOT = Path(__file__).resolve().parent.parent
VEHICLE = load_vehicle()

IMPOSSIBLE = [  # (override, the key the message names, what it says)
    ("body.inertia_kg_m2=1e-12", "body.inertia_kg_m2", "must be within"),
    ("body.inertia_kg_m2=1.0", "body.inertia_kg_m2", "about the centre of mass, not positive"),
    ("motor.torque_constant_n_m_a=2.7", "motor.torque_constant_n_m_a", "100 times k_e"),
    ("body.com_behind_axle_m=0.5", "body.com_behind_axle_m", "not between the axle and the castor"),
    ("body.com_behind_axle_m=-0.1", "body.com_behind_axle_m", "not between the axle and the castor"),
    ("body.mass_kg=1", "body.mass_kg", "below 0.5 of the frame and battery"),
    ("wheels.separation_m=10", "wheels.separation_m", "more than twice the frame's width"),
    ("wheels.radius_m=5", "wheels.radius_m", "does not fit the frame's length"),
    ("friction_model.p_factor=1e-9", "friction_model.p_factor", "less than 10 times faster"),
    ("frame.length_m=1e-9", "frame.length_m", "must be within [0.001, 100]"),
    ("frame.width_m=0.1", "frame.width_m", "does not fit the frame"),
    ("sensors.encoder_counts_per_rev=1", "sensors.encoder_counts_per_rev", "resolve the motor speed in steps"),
    ("motor.gear_ratio=1e-6", "motor.gear_ratio", "must be within"),
    ("motor.gear_ratio=0.5", "motor.gear_ratio", "turns the wheel faster than its motor"),
    ("motor.resistance_ohm=1e-300", "motor.resistance_ohm", "must be within"),
    ("frame.wheel_axis_to_castor_m=0.6", "frame.wheel_axis_to_castor_m", "beyond the frame's length"),
]
HUGE_KEYS = [  # 1e308 in any of these names the key, never "the derived constants"
    "frame.length_m",
    "frame.mass_kg",
    "battery.mass_kg",
    "body.mass_kg",
    "body.inertia_kg_m2",
    "body.com_behind_axle_m",
    "wheels.separation_m",
    "wheels.radius_m",
    "motor.inertia_kg_m2",
    "motor.resistance_ohm",
    "motor.voltage_constant_v_s_rad",
    "motor.torque_constant_n_m_a",
    "motor.viscous_friction_n_m_s_rad",
    "motor.gear_ratio",
    "amplifier.gain",
    "amplifier.current_limit_a",
    "amplifier.voltage_limit_v",
    "da.max_v",
    "friction_model.p_factor",
    "sensors.position_fix_sigma_m",
]


@pytest.mark.parametrize(("setting", "key", "message"), IMPOSSIBLE)
def test_an_impossible_vehicle_is_refused_by_params_naming_the_key(
    capsys: pytest.CaptureFixture[str], setting: str, key: str, message: str
) -> None:
    code, out, err = run(capsys, "params", "--set", setting)
    assert code == 2 and out == ""
    one_line(err, f": {key}: ", message)


def _vehicle_file(folder: Path, setting: str) -> Path:
    """The shipped vehicle file with one value changed, as a user edits it."""
    key, value = setting.split("=")
    data = tomllib.loads(default_vehicle_path().read_text())
    *tables, name = key.split(".")
    node = data
    for table in tables:
        node = node[table]
    node[name] = tomllib.loads(f"v = {value}")["v"]
    path = folder / "vehicle.toml"
    path.write_text(dump_toml(data))
    return path


@pytest.mark.parametrize(("setting", "key", "message"), IMPOSSIBLE)
def test_an_impossible_vehicle_file_is_refused_by_run_naming_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], setting: str, key: str, message: str
) -> None:
    vehicle = _vehicle_file(tmp_path, setting)
    shutil.copy(ROOT / "trajectories" / "line.toml", tmp_path / "line.toml")
    experiment = tmp_path / "line.toml.experiment.toml"
    experiment.write_text('name = "line"\ntrajectory = "line.toml"\nvehicle = "vehicle.toml"\n')
    code, out, err = run(capsys, "run", experiment, "--no-plot", "--out", tmp_path / "out")
    assert code == 2 and out == ""
    one_line(err, f"{vehicle}: {key}: ", message)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("key", HUGE_KEYS)
def test_a_huge_number_names_its_key(key: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_vehicle(None, [(key, 1e308)])
    assert f": {key}: " in str(info.value) and len(str(info.value).splitlines()) == 1


def test_a_tiny_resistance_is_named_not_the_friction_gain() -> None:
    with pytest.raises(ConfigError, match=r": motor\.resistance_ohm: must be within"):
        load_vehicle(None, ["motor.resistance_ohm=1e-300"])


def test_a_rule_named_in_checks_accept_is_not_checked() -> None:
    overdrive = load_vehicle(None, ['checks.accept=["gear_reduces_speed"]', "motor.gear_ratio=0.9"])
    assert overdrive.motor.left.gear_ratio == 0.9
    assert overdrive.derived.max_speed_m_s > VEHICLE.derived.max_speed_m_s  # eq 29: a faster wheel
    with pytest.raises(ConfigError, match=r"checks\.accept\[0\]: no rule 'gear_reduce'.*did you mean gear_reduces"):
        load_vehicle(None, ['checks.accept=["gear_reduce"]'])


def test_every_rule_is_listed_in_the_vehicle_guide() -> None:
    guide = (ROOT / "docs" / "guide" / "vehicles.md").read_text()
    for rule in VEHICLE_RULES:
        assert f"`{rule.name}`" in guide, rule.name


def test_the_shipped_vehicle_keeps_every_rule_with_a_margin() -> None:
    """Eq 64's own figures: the table's 85 kg is the frame's 51 and the battery's 34; h = 0.12 m lies between the
    axle and the castor 0.5 m behind it; I about the centre of mass is 5.46 − 85·0.12² = 4.236 kg m², above the
    frame's and battery's own 3.107; k_t = k_e (model note 4)."""
    body = VEHICLE.body
    assert body.mass_kg == VEHICLE.frame.mass_kg + VEHICLE.battery.mass_kg
    assert body.inertia_kg_m2 - body.mass_kg * body.com_behind_axle_m**2 == pytest.approx(4.236)
    assert 0 < body.com_behind_axle_m < VEHICLE.frame.wheel_axis_to_castor_m


# -- the Python API checks as the files are checked --------------------------------------------------------------


@pytest.mark.parametrize(
    ("make", "line"),
    [
        (
            lambda: dataclasses.replace(VEHICLE.motor.left, stiction_n_m=0.0),
            "MotorParams: coulomb_friction_n_m: Coulomb friction 0.065 N m exceeds stiction 0 N m",
        ),
        (lambda: dataclasses.replace(VEHICLE, body="heavy").derived, "VehicleParams: body: expected a BodyParams"),
        (
            lambda: dataclasses.replace(VEHICLE, body=dataclasses.replace(VEHICLE.body, com_behind_axle_m=0.5)),
            "VehicleParams: body.com_behind_axle_m: the centre of mass 0.5 m",
        ),
        (lambda: dataclasses.replace(VEHICLE.da, min_v=6.0), "DAParams: min_v: must be below max_v"),
        (lambda: load_vehicle(overrides=[(1, 2)]), '--set: (1, 2): expected "KEY=VALUE" or a (key, value) pair'),
        (lambda: load_vehicle(overrides=[("k",)]), "--set: ('k',): expected \"KEY=VALUE\" or a (key, value) pair"),
        (
            lambda: load_vehicle(b"vehicle.toml"),
            "load_vehicle: path: expected a file name as a str or a Path (got bytes)",
        ),
    ],
)
def test_the_api_refuses_what_a_file_is_refused(make: Any, line: str) -> None:
    with pytest.raises(ConfigError) as info:
        make()
    assert str(info.value).startswith(line) and len(str(info.value).splitlines()) == 1


def test_numpy_scalars_are_accepted_where_python_numbers_are() -> None:
    vehicle = VEHICLE.with_overrides([("da.bits", np.int64(10)), ("body.mass_kg", np.float32(90.0))])
    assert vehicle.da.bits == 10 and vehicle.body.mass_kg == 90.0


def test_load_experiment_refuses_bytes_in_one_line() -> None:
    from agvctl.scenario import load_experiment

    with pytest.raises(ConfigError, match="^load_experiment: path: expected a file name as a str or a Path"):
        load_experiment(b"experiments/line.toml")  # type: ignore[arg-type]


def test_a_references_arrays_are_read_only() -> None:
    reference = plan(load_path(ROOT / "trajectories" / "line.toml"), VEHICLE)
    with pytest.raises(ValueError, match="read-only"):
        reference.grid.x_m[0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        reference.grid_times_s[0] = 1.0


# -- random vehicles ---------------------------------------------------------------------------------------------


def _property_module() -> Any:
    path = ROOT / "experiments" / "vehicle_rules_property.py"
    spec = importlib.util.spec_from_file_location("vehicle_rules_property", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


PROPERTY = _property_module()


@pytest.mark.slow
@settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(sets=PROPERTY.vehicle_overrides())
def test_a_random_vehicle_is_refused_naming_a_key_or_runs_a_line_to_completion(sets: list[tuple[str, Any]]) -> None:
    """experiments/vehicle_rules_property.py: the same property over 1,000 examples."""
    with tempfile.TemporaryDirectory() as folder:
        PROPERTY.check_vehicle(sets, Path(folder), dict.fromkeys(("refused", "path refused", "ran", "within 1 cm"), 0))
