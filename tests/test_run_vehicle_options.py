"""``agvctl run --vehicle FILE --set KEY=VALUE``: the experiment's vehicle replaced or changed, as in every other
command that uses a vehicle — the controllers plan and design with it, the plant is it with the experiment's
``[plant] set`` — and said so in the resolved ``experiment.toml``; a bad value is one line, nothing written."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

from cli_runs import one_line, run

from agvctl.params import default_vehicle_path

PATH = '[[segments]]\ntype = "line"\nlength_m = 0.5\n'  # no [limits]: the vehicle's own limits bind
EXPERIMENT = 'name = "short"\ntrajectory = "short_path.toml"\nsettle_s = 0.2\n[controller]\npose = "ramsete"\n'


def _experiment(d: Path) -> Path:
    (d / "short_path.toml").write_text(PATH, encoding="utf-8")
    (d / "short.toml").write_text(EXPERIMENT, encoding="utf-8")
    return d / "short.toml"


def _outputs(out: Path) -> tuple[dict, dict, str]:
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    plant = tomllib.loads((out / "plant_vehicle.toml").read_text(encoding="utf-8"))
    return summary, plant, (out / "experiment.toml").read_text(encoding="utf-8")


def test_run_set_changes_the_vehicle_it_plans_for_and_simulates(tmp_path, capsys):
    experiment = _experiment(tmp_path)
    assert run(capsys, "run", experiment, "--out", tmp_path / "nominal", "--no-plot")[0] == 0
    heavy = ["--set", "body.mass_kg=170", "--set", "body.inertia_kg_m2=10.92"]  # twice the mass and inertia
    assert run(capsys, "run", experiment, *heavy, "--out", tmp_path / "heavy", "--no-plot")[0] == 0
    nominal, nominal_plant, _ = _outputs(tmp_path / "nominal")
    summary, plant, resolved = _outputs(tmp_path / "heavy")
    assert (plant["body"]["mass_kg"], nominal_plant["body"]["mass_kg"]) == (170.0, 85.0)
    # the same motors move twice the mass: the acceleration limit falls, the planned reference is slower
    assert summary["metrics"]["reference_duration_s"] > nominal["metrics"]["reference_duration_s"]
    assert "--set body.mass_kg=170 --set body.inertia_kg_m2=10.92" in resolved.splitlines()[0]


def test_run_vehicle_replaces_the_experiment_vehicle(tmp_path, capsys):
    experiment = _experiment(tmp_path)
    text = default_vehicle_path().read_text(encoding="utf-8")
    assert "mass_kg = 85.0" in text
    vehicle = tmp_path / "heavier.toml"
    vehicle.write_text(text.replace("mass_kg = 85.0", "mass_kg = 95.0"), encoding="utf-8")
    assert run(capsys, "run", experiment, "--vehicle", vehicle, "--out", tmp_path / "out", "--no-plot")[0] == 0
    _summary, plant, resolved = _outputs(tmp_path / "out")
    assert plant["body"]["mass_kg"] == 95.0
    assert tomllib.loads(resolved)["vehicle"] == str(vehicle.resolve())


def test_run_with_a_bad_vehicle_option_is_one_line_and_writes_nothing(tmp_path, capsys):
    experiment = _experiment(tmp_path)
    out = tmp_path / "out"
    code, _, err = run(capsys, "run", experiment, "--set", "wheels.left.radius=0.1", "--out", out)
    assert code == 2
    one_line(err, "--set", "wheels.left.radius", "did you mean wheels.left.radius_m?")
    code, _, err = run(capsys, "run", experiment, "--vehicle", tmp_path / "missing.toml", "--out", out)
    assert code == 2
    one_line(err, "missing.toml", "file not found")
    assert not out.exists()
