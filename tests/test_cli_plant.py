"""The params and simulate commands through main(argv): output, exit codes, one-line errors."""

import json

import pytest

from agvctl.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_params_json_report_figures(capsys):
    code, out, _ = run(capsys, "params", "--json")
    assert code == 0
    data = json.loads(out)
    d = data["derived"]
    assert d["inertia_from_dimensions_kg_m2"] == pytest.approx(5.46, rel=5e-3)
    assert d["accel_limit_m_s2"] == pytest.approx(0.657, rel=5e-3)
    assert d["da_volts_per_bit"] == pytest.approx(2.44e-3, rel=1e-3)
    for key in (
        "k_ll",
        "k_rr",
        "k_lr",
        "k_llr",
        "k_lrr",
        "inertia_equivalent_left_kg_m2",
        "inertia_equivalent_right_kg_m2",
        "friction_gain_p_left",
        "friction_gain_p_right",
        "max_speed_m_s",
        "mechanical_time_constant_s",
    ):
        assert key in d
    assert data["vehicle"]["wheels"]["separation_m"] == 0.54
    assert data["vehicle"]["motor"]["gear_ratio"] == 36.0


def test_params_table(capsys):
    code, out, _ = run(capsys, "params", "--set", "wheels.right.radius_m=0.101")
    assert code == 0 and "wheels.right.radius_m" in out and "0.101" in out and "eq 64" in out


def test_simulate_json_and_csv(capsys, tmp_path):
    log = tmp_path / "log.csv"
    code, out, _ = run(
        capsys, "simulate", "--da-left", "2", "--da-right", "2", "--duration", "4", "--json", "--out", str(log)
    )
    assert code == 0
    data = json.loads(out)
    assert data["final"]["t_s"] == pytest.approx(4.0)
    assert data["final"]["x_m"] > 0.5 and abs(data["final"]["y_m"]) < 1e-9
    assert data["peak"]["current_left_a"] == pytest.approx(5.5)
    assert data["wall_time_s"] > 0 and data["setup_time_s"] >= 0
    header, first, *rest = log.read_text().splitlines()
    assert header.startswith("t_s,da_code_left,da_code_right")
    assert len(rest) == 100  # 4 s / 40 ms samples + the final state
    # full precision: the DA voltage 819 · 10/4096 = 1.99951171875 is written with >= 9 significant digits
    assert "1.99951171875" in first


def test_simulate_profile_csv(capsys, tmp_path):
    prof = tmp_path / "p.csv"
    prof.write_text("t_s,da_left_v,da_right_v\n0,2,2\n1.0,-2,-2\n")
    code, out, _ = run(capsys, "simulate", "--input", str(prof), "--duration", "2", "--json")
    assert code == 0
    assert json.loads(out)["final"]["speed_m_s"] < 0


def test_module_entry_point():
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "agvctl", "--help"], capture_output=True, text=True)
    assert res.returncode == 0 and "simulate" in res.stdout


BAD_SETS = [
    ("wheels.left.radius=0.1", "wheels.left.radius", "unknown key (did you mean wheels.left.radius_m?)"),
    ("wheels.radius_left_m=0.1", "wheels.radius_left_m", "renamed; use wheels.left.radius_m"),
    ("wheels.radius_right_m=0.1", "wheels.radius_right_m", "renamed; use wheels.right.radius_m"),
    ("body.mass_kg=0", "body.mass_kg", "must be > 0"),
    ("body.mass_kg=-3", "body.mass_kg", "must be > 0"),
    ("motor.resistance_ohm=0", "motor.resistance_ohm", "must be > 0"),
    ("wheels.left.radius_m=-0.1", "wheels.left.radius_m", "must be > 0"),
    ("motor.gear_ratio=0", "motor.gear_ratio", "must be > 0"),
    ("da.bits=0", "da.bits", "must be > 0"),
    ("da.bits=12.5", "da.bits", "expected an integer"),
    ("da.min_v=5", "da.min_v", "must be below max_v"),
    ("body.mass_kg=heavy", "body.mass_kg", "expected a number"),
    ("body.mass_kg=nan", "body.mass_kg", "must be finite"),
    ("motor.left.coulomb_friction_n_m=0.1", "motor.left.coulomb_friction_n_m", "exceeds stiction 0.065"),
    ("body.inertia_about=middle", "body.inertia_about", "must be one of"),
    ("frame=1", "frame", "is a table"),
    ("novalue", "novalue", "expected KEY=VALUE"),
]


@pytest.mark.parametrize(("setting", "key", "message"), BAD_SETS)
def test_bad_set_values_exit_2_with_one_line(capsys, setting, key, message):
    code, out, err = run(capsys, "params", "--set", setting)
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert key in err and message in err


def _vehicle_file(tmp_path, text):
    from agvctl.params import default_vehicle_path

    path = tmp_path / "v.toml"
    path.write_text(text(default_vehicle_path().read_text()))
    return str(path)


@pytest.mark.parametrize(
    ("edit", "key", "message"),
    [
        (lambda t: t.replace("bits = 12", "bits = 12\nbitz = 3"), "da.bitz", "unknown key (did you mean da.bits?)"),
        (lambda t: t.replace("resistance_ohm = 0.38", ""), "motor.resistance_ohm", "missing key"),
        (lambda t: t.replace("[control]\nsample_period_s = 0.040", ""), "control", "missing key"),
        (lambda t: t.replace('name = "IAU AGV"', "name = 3"), "name", "expected a string"),
        (lambda t: t.replace("mass_kg = 85.0", 'mass_kg = "85"'), "body.mass_kg", "expected a number"),
        (lambda t: t.replace("[motor]", "[motor]\n[motor.middle]"), "motor.middle", "unknown key"),
        (
            lambda t: t.replace("radius_m = 0.10", "radius_left_m = 0.10"),
            "wheels.radius_left_m",
            "renamed; use wheels.left.radius_m",
        ),
        (
            lambda t: t + "\n[wheels.right]\nradius_right_m = 0.10\n",
            "wheels.right.radius_right_m",
            "unknown key (did you mean wheels.right.radius_m?)",
        ),
        (lambda t: t.replace("radius_m = 0.10", ""), "wheels.radius_m", "missing key"),
        (
            lambda t: t + "\n[motor.right]\nstiction_n_m = 0.01\n",
            "motor.right.coulomb_friction_n_m",
            "exceeds stiction",
        ),
        (lambda t: t.replace("[da]", "[da"), "", "malformed TOML"),
    ],
)
def test_bad_vehicle_file_exit_2_with_one_line(capsys, tmp_path, edit, key, message):
    path = _vehicle_file(tmp_path, edit)
    code, _, err = run(capsys, "params", "--vehicle", path)
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert path in err and key in err and message in err


def test_missing_vehicle_file(capsys, tmp_path):
    code, _, err = run(
        capsys,
        "simulate",
        "--vehicle",
        str(tmp_path / "none.toml"),
        "--da-left",
        "1",
        "--da-right",
        "1",
        "--duration",
        "1",
    )
    assert code == 2 and "none.toml" in err and "file not found" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["simulate", "--duration", "2"], "--da-left: required"),
        (["simulate", "--da-left", "1", "--da-right", "1", "--duration", "-1"], "--duration"),
        (["simulate", "--da-left", "1", "--da-right", "1", "--duration", "nan"], "--duration"),
        (["simulate", "--da-left", "x", "--da-right", "1", "--duration", "1"], "invalid float"),
        (["simulate", "--da-left", "inf", "--da-right", "1", "--duration", "1"], "--da-left"),
        (["params", "--bogus"], "unrecognized arguments"),
    ],
)
def test_bad_arguments(capsys, argv, message):
    code, _, err = run(capsys, *argv)
    assert code == 2 and message in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("t_s,da_left_v\n0,1\n", "da_right_v: missing column"),
        ("t_s,da_left_v,da_right_v\n0,1,x\n", "line 2: expected three numbers"),
        ("t_s,da_left_v,da_right_v\n0,1,1\n0,2,2\n", "line 3: t_s must increase"),
        ("t_s,da_left_v,da_right_v\n0,nan,1\n", "line 2: NaN or inf"),
        ("", "empty file"),
    ],
)
def test_bad_profile(capsys, tmp_path, content, message):
    prof = tmp_path / "p.csv"
    prof.write_text(content)
    out = tmp_path / "log.csv"
    code, _, err = run(capsys, "simulate", "--input", str(prof), "--duration", "1", "--out", str(out))
    assert code == 2 and message in err and err.count("\n") == 1
    assert not out.exists()  # nothing half-written


def test_simulate_plot(capsys, tmp_path):
    png = tmp_path / "sim.png"
    code, out, _ = run(capsys, "simulate", "--da-left", "3", "--da-right", "-1", "--duration", "2", "--plot", str(png))
    assert code == 0 and png.stat().st_size > 10_000 and str(png) in out
