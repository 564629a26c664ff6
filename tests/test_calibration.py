"""Calibration and identification: eqs 63-69 as corrected in the ERRATA, and UMBmark.

Expected values come from the physics: the truths the simulated plant is given, the report's 5.46 kg m², the
steady-state balance k_pow k_t u/R = (k_e k_t/R + f_m) ω + τ_c, and the UMBmark error model's geometry.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.calibration import (
    FrictionExperiment,
    FrictionLog,
    UmbmarkConfig,
    apply_friction,
    fit_friction,
    identify_mass,
    read_friction_log,
    simulate_friction_experiment,
    simulate_umbmark,
    simulated_scale_readings,
    square_end_errors,
    two_speed_friction,
    umbmark_correction,
)
from agvctl.cli import main
from agvctl.params import VehicleParams, inertia_from_dimensions, load_vehicle

TRUTH_SETS = (
    "motor.left.viscous_friction_n_m_s_rad=1.5e-4",
    "motor.left.coulomb_friction_n_m=0.060",
    "motor.left.stiction_n_m=0.070",
    "motor.right.viscous_friction_n_m_s_rad=2.5e-4",
    "motor.right.coulomb_friction_n_m=0.072",
    "motor.right.stiction_n_m=0.072",
)
FAST = FrictionExperiment(motor_speeds_rad_s=(60.0, 120.0, 180.0), settle_s=1.0, hold_s=2.0)


@pytest.fixture(scope="module")
def friction_truth(vehicle: VehicleParams) -> VehicleParams:
    return vehicle.with_overrides(TRUTH_SETS)


@pytest.fixture(scope="module")
def clean_log(vehicle: VehicleParams, friction_truth: VehicleParams) -> FrictionLog:
    return simulate_friction_experiment(friction_truth, vehicle, FAST)


# ----------------------------------------------------------------------------------------------------------------
# eqs 63-64


def test_eq64_reproduces_the_reports_inertia(vehicle: VehicleParams) -> None:
    assert inertia_from_dimensions(vehicle.frame, vehicle.battery) == pytest.approx(5.46, abs=0.005)


def test_eq63_recovers_a_known_centre_of_mass(vehicle: VehicleParams) -> None:
    # a 90 kg vehicle with h = 0.15 m, d_wc = 0.50 m: the castor carries M h/d_wc = 27 kg (moment about the axle)
    m_total, h, d = 90.0, 0.15, vehicle.frame.wheel_axis_to_castor_m
    castor = m_total * h / d
    fit = identify_mass(vehicle, 33.0, (m_total - castor) - 33.0, castor)  # left/right split does not matter
    assert fit.mass_kg.estimate == pytest.approx(m_total)
    assert fit.com_behind_axle_m.estimate == pytest.approx(h)


def test_mass_standard_error_matches_the_scatter(vehicle: VehicleParams) -> None:
    truth = vehicle.with_overrides(["body.com_behind_axle_m=0.14"])
    fits = [
        identify_mass(vehicle, *simulated_scale_readings(truth, noise_scale=1.0, seed=s), scale_stderr_kg=0.2)
        for s in range(400)
    ]
    h = np.array([f.com_behind_axle_m.estimate for f in fits])
    assert abs(h.mean() - 0.14) < 4 * fits[0].com_behind_axle_m.stderr / math.sqrt(len(h))
    assert np.std(h) == pytest.approx(fits[0].com_behind_axle_m.stderr, rel=0.15)


# ----------------------------------------------------------------------------------------------------------------
# friction


def test_friction_noise_off_within_2_percent(
    vehicle: VehicleParams, friction_truth: VehicleParams, clean_log: FrictionLog
) -> None:
    fit = fit_friction(clean_log, vehicle, truth=friction_truth)
    for side in ("left", "right"):
        true_motor = friction_truth.motor.side(side)
        s = fit.side(side)
        assert s.viscous_friction_n_m_s_rad.estimate == pytest.approx(true_motor.viscous_friction_n_m_s_rad, rel=0.02)
        assert s.coulomb_friction_n_m.estimate == pytest.approx(true_motor.coulomb_friction_n_m, rel=0.02)
        # the break-away: within one DA code of torque (k_pow k_t alpha/R = 3.5e-4 N m)
        assert s.stiction_n_m.estimate == pytest.approx(true_motor.stiction_n_m, abs=3.5e-4)
    assert fit.left.coulomb_friction_n_m.estimate != pytest.approx(fit.right.coulomb_friction_n_m.estimate, rel=0.05)


@pytest.mark.parametrize("seed", [1, 2])
def test_friction_noise_on_within_3_sigma(vehicle: VehicleParams, friction_truth: VehicleParams, seed: int) -> None:
    log = simulate_friction_experiment(friction_truth, vehicle, FAST, noise_scale=1.0, seed=seed)
    fit = fit_friction(log, vehicle, truth=friction_truth)
    for side in ("left", "right"):
        s = fit.side(side)
        for e in (s.viscous_friction_n_m_s_rad, s.coulomb_friction_n_m, s.stiction_n_m):
            assert e.truth is not None and e.stderr > 0
            assert abs(e.estimate - e.truth) <= 3 * e.stderr, (side, e)


def test_report_eq67_as_printed_biases_coulomb_friction(
    vehicle: VehicleParams, friction_truth: VehicleParams, clean_log: FrictionLog
) -> None:
    """Two windows of the simulated experiment into eqs 66-67: the ERRATA's sign recovers τ_c, the printed
    one adds 2 f_m ω₂ (0.054 N m here, 90 %)."""
    fit = fit_friction(clean_log, vehicle)
    w1, w2 = (w for w in fit.left.windows if w.setpoint_rad_s in (60.0, 180.0))
    motor, k_pow = vehicle.motor.left, vehicle.amplifier.gain
    f_true = friction_truth.motor.left.viscous_friction_n_m_s_rad
    tau_true = friction_truth.motor.left.coulomb_friction_n_m
    args = (motor, k_pow, w1.omega_mean_rad_s, w1.da_voltage_mean_v, w2.omega_mean_rad_s, w2.da_voltage_mean_v)
    f_m, tau_c = two_speed_friction(*args)
    _, tau_c_printed = two_speed_friction(*args, corrected=False)
    assert f_m == pytest.approx(f_true, rel=0.02)
    assert tau_c == pytest.approx(tau_true, rel=0.02)
    assert tau_c_printed - tau_true == pytest.approx(2 * f_true * w2.omega_mean_rad_s, rel=0.02)
    assert abs(tau_c_printed - tau_true) > 0.5 * tau_true


def test_two_speed_formula_on_the_exact_steady_state(vehicle: VehicleParams) -> None:
    m = vehicle.motor.left
    k_t, k_e, R, k_pow = m.torque_constant_n_m_a, m.voltage_constant_v_s_rad, m.resistance_ohm, 2.0
    f_m, tau_c = 3e-4, 0.05

    def u(w: float) -> float:  # steady state (ERRATA): k_pow k_t u/R = (k_e k_t/R + f_m) w + tau_c
        return ((k_e * k_t / R + f_m) * w + tau_c) * R / (k_pow * k_t)

    assert two_speed_friction(m, k_pow, 80.0, u(80.0), 160.0, u(160.0)) == pytest.approx((f_m, tau_c), rel=1e-12)
    assert two_speed_friction(m, k_pow, 80.0, u(80.0), 160.0, u(160.0), corrected=False)[1] == pytest.approx(
        tau_c + 2 * f_m * 160.0, rel=1e-12
    )


def test_apply_friction_writes_per_side_values(
    vehicle: VehicleParams, friction_truth: VehicleParams, clean_log: FrictionLog
) -> None:
    identified, notes = apply_friction(vehicle, fit_friction(clean_log, vehicle))
    # the right side's truth has τ_s = τ_c; an estimate a hair below τ_c is written as τ_c (a file needs τ_s ≥ τ_c)
    assert all("stiction estimate" in n for n in notes)
    assert identified.motor.right.stiction_n_m >= identified.motor.right.coulomb_friction_n_m
    assert identified.motor.right.coulomb_friction_n_m == pytest.approx(0.072, rel=0.02)
    assert identified.motor.left.viscous_friction_n_m_s_rad == pytest.approx(1.5e-4, rel=0.02)


# ----------------------------------------------------------------------------------------------------------------
# UMBmark


def test_umbmark_error_model_first_order_signs() -> None:
    """x_ccw = 2L(β − α), y_ccw = −2L(β − α), x_cw = y_cw = −2L(β + α) for small angles (module notes)."""
    L, a, b = 4.0, 1e-5, 3e-5
    (x_cw, y_cw), (x_ccw, y_ccw) = square_end_errors(a, b, L)
    assert x_ccw == pytest.approx(2 * L * (b - a), rel=1e-3)
    assert y_ccw == pytest.approx(-2 * L * (b - a), rel=1e-3)
    assert x_cw == pytest.approx(-2 * L * (b + a), rel=1e-3)
    assert y_cw == pytest.approx(-2 * L * (b + a), rel=1e-3)


def test_umbmark_correction_inverts_the_geometry(vehicle: VehicleParams) -> None:
    """A plant with r_r/r_l = 1.004 and b 0.8 % larger: α and β from its geometry, the end errors from the exact
    model, and the correction returns the truth."""
    truth = vehicle.with_overrides(["wheels.right.radius_m=0.1004", "wheels.separation_m=0.54432"])
    r_mean_true = 0.5 * (0.1 + 0.1004)
    b_eff = 0.54432 * 0.1 / r_mean_true  # in units of the believed mean radius
    alpha = 0.5 * math.pi * (1 - 0.54 / b_eff)  # a corner the odometry counts as 90° turns 90° b̂/b
    ratio = 1.004
    beta = 4.0 * 2 * (ratio - 1) / ((ratio + 1) * b_eff)  # leg heading change: L (s_r − s_l)/(b s̄)
    errors = square_end_errors(alpha, beta, 4.0)
    corr = umbmark_correction(errors[0], errors[1], side_length_m=4.0, vehicle=vehicle, truth=truth)
    assert corr.alpha_rad.estimate == pytest.approx(alpha, rel=1e-9)
    assert corr.beta_rad.estimate == pytest.approx(beta, rel=1e-9)
    assert corr.wheel_radius_ratio.estimate == pytest.approx(ratio, abs=2e-6)
    assert corr.separation_m.estimate == pytest.approx(b_eff, rel=1e-9)
    assert corr.radius_left_m.estimate + corr.radius_right_m.estimate == pytest.approx(0.2)


@pytest.mark.slow
def test_umbmark_reduces_the_return_error_tenfold(vehicle: VehicleParams) -> None:
    truth = vehicle.with_overrides(["wheels.right.radius_m=0.1005", "wheels.separation_m=0.5454"])
    result = simulate_umbmark(truth, vehicle, UmbmarkConfig(side_length_m=4.0, runs_per_direction=3))
    assert result.error_before_m > 0.3  # the 4 m square: tens of cm (see module notes: 2L(β ± α))
    assert result.error_after_m * 10 <= result.error_before_m
    c = result.correction
    assert c.wheel_radius_ratio.estimate == pytest.approx(1.005, abs=1e-4)
    assert c.separation_m.estimate == pytest.approx(0.5454 * 0.1 / 0.10025, rel=5e-4)


@pytest.mark.slow
def test_umbmark_with_noise_reports_honest_errors(vehicle: VehicleParams) -> None:
    truth = vehicle.with_overrides(["wheels.right.radius_m=0.1005", "wheels.separation_m=0.5454"])
    result = simulate_umbmark(truth, vehicle, UmbmarkConfig(side_length_m=2.0), noise_scale=1.0, seed=4)
    c = result.correction
    for e in (c.wheel_radius_ratio, c.separation_m):
        assert e.truth is not None and e.stderr > 0
        assert abs(e.estimate - e.truth) <= 3 * e.stderr + 5e-5 * abs(e.truth)  # plus the model's own error
    assert result.error_after_m * 10 <= result.error_before_m


# ----------------------------------------------------------------------------------------------------------------
# CLI


def test_cli_mass(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "v.toml"
    assert (
        main(["identify", "mass", "--left", "35.7", "--right", "35.7", "--castor", "20.4", "--json", "--out", str(out)])
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"mass_kg", "com_behind_axle_m", "inertia_kg_m2"}
    assert data["com_behind_axle_m"]["estimate"] == pytest.approx(20.4 / 91.8 * 0.5)
    text = out.read_text()
    assert text.startswith("# ") and "scale readings" in text
    assert load_vehicle(out).body.mass_kg == pytest.approx(91.8)


def test_cli_friction_simulate_json_and_out(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out, log = tmp_path / "v.toml", tmp_path / "log.csv"
    argv = [
        "identify",
        "friction",
        "--simulate",
        "--speeds",
        "60,120,180",
        "--json",
        "--out",
        str(out),
        "--save-log",
        str(log),
        *[a for s in TRUTH_SETS for a in ("--set", s)],
    ]
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"left", "right"}
    for side in data.values():
        assert set(side) == {"viscous_friction_n_m_s_rad", "coulomb_friction_n_m", "stiction_n_m"}
        for e in side.values():
            assert set(e) == {"estimate", "stderr", "truth"}
            assert e["estimate"] == pytest.approx(e["truth"], rel=0.02)
    assert data["right"]["coulomb_friction_n_m"]["truth"] == 0.072
    assert "friction" in out.read_text().splitlines()[1]
    v = load_vehicle(out)
    assert v.motor.left.coulomb_friction_n_m == pytest.approx(0.060, rel=0.02)
    # the saved log fits the same through --log (no truth there)
    assert main(["identify", "friction", "--log", str(log), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert set(again["left"]["coulomb_friction_n_m"]) == {"estimate", "stderr"}
    assert again["left"]["coulomb_friction_n_m"]["estimate"] == pytest.approx(
        data["left"]["coulomb_friction_n_m"]["estimate"], rel=1e-6
    )


def test_cli_friction_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "friction", "--simulate", "--speeds", "60,150", "--noise", "1", "--seed", "3"]) == 0
    text = capsys.readouterr().out
    assert "before" in text and "truth" in text and "demonstration" in text


def _write_log(
    path: Path, log: FrictionLog, rows: slice | None = None, drop: str | None = None, nan_row: int | None = None
) -> None:
    log.write_csv(path)
    lines = path.read_text().splitlines()
    header, body = lines[0], lines[1:]
    if rows is not None:
        body = body[rows]
    if nan_row is not None:
        cells = body[nan_row].split(",")
        cells[3] = "nan"
        body[nan_row] = ",".join(cells)
    if drop is not None:
        names = header.split(",")
        k = names.index(drop)
        header = ",".join(n for i, n in enumerate(names) if i != k)
        body = [",".join(c for i, c in enumerate(r.split(",")) if i != k) for r in body]
    path.write_text("\n".join([header, *body]) + "\n")


def _one_speed_log(clean_log: FrictionLog) -> FrictionLog:
    sp = clean_log.setpoint_rad_s.copy()
    hold = np.array([p == "hold" for p in clean_log.phase])
    sp[hold] = np.sign(sp[hold]) * 120.0  # every window claims ±120 rad/s ...
    w = clean_log.omega_motor_rad_s.copy()
    w[hold] = sp[hold]  # ... and measured it
    return FrictionLog(clean_log.t_s, clean_log.phase, sp, w, clean_log.da_voltage_v)


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing", "missing column omega_motor_right_rad_s"),
        ("few", "1 steady constant-speed window"),
        ("one_speed", "at one speed"),
        ("nan", "line 6: setpoint_omega_motor_right_rad_s is not a finite number (nan)"),
        ("no_ramp", "no ramp breaks the wheel away"),
    ],
)
def test_cli_bad_friction_logs(
    case: str, message: str, clean_log: FrictionLog, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path, out = tmp_path / "bad.csv", tmp_path / "v.toml"
    if case == "missing":
        _write_log(path, clean_log, drop="omega_motor_right_rad_s")
    elif case == "few":
        _write_log(path, clean_log, rows=slice(0, 110))  # the first window only (75 samples + part of the next)
    elif case == "one_speed":
        _write_log(path, _one_speed_log(clean_log))
    elif case == "nan":
        _write_log(path, clean_log, nan_row=4)
    else:
        n_hold = sum(p in ("hold", "idle") for p in clean_log.phase[: clean_log.phase.index("ramp")])
        _write_log(path, clean_log, rows=slice(0, n_hold))
    assert main(["identify", "friction", "--log", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and str(path) in err
    assert not out.exists()


def test_read_friction_log_round_trip(clean_log: FrictionLog, tmp_path: Path) -> None:
    clean_log.write_csv(tmp_path / "log.csv")
    back = read_friction_log(tmp_path / "log.csv")
    assert back.phase == clean_log.phase
    np.testing.assert_allclose(back.da_voltage_v, clean_log.da_voltage_v, rtol=1e-11)


def test_cli_umbmark_log(tmp_path: Path, capsys: pytest.CaptureFixture[str], vehicle: VehicleParams) -> None:
    errors = square_end_errors(0.01, 0.03, 4.0)
    rng = np.random.default_rng(0)
    rows = ["direction,x_m,y_m"]
    for d, e in (("cw", errors[0]), ("ccw", errors[1])):
        rows += [f"{d},{float(e[0] + n[0])!r},{float(e[1] + n[1])!r}" for n in rng.normal(0, 0.002, (5, 2))]
    log, out = tmp_path / "runs.csv", tmp_path / "v.toml"
    log.write_text("\n".join(rows) + "\n")
    assert main(["identify", "umbmark", "--log", str(log), "--json", "--out", str(out)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {
        "error_before_m",
        "error_after_m",
        "wheel_radius_ratio",
        "separation_m",
        "radius_left_m",
        "radius_right_m",
    }
    assert data["error_after_m"] is None
    assert data["error_before_m"] == pytest.approx(max(np.hypot(*errors[0]), np.hypot(*errors[1])), abs=0.005)
    assert data["separation_m"]["estimate"] == pytest.approx(0.54 * 0.5 * math.pi / (0.5 * math.pi - 0.01), rel=1e-3)
    assert data["wheel_radius_ratio"]["stderr"] > 0
    v = load_vehicle(out)
    assert v.wheels.right.radius_m > v.wheels.left.radius_m  # β > 0: the legs curve left, the right wheel is larger
    assert "UMBmark" in out.read_text().splitlines()[1]
    # the text table
    assert main(["identify", "umbmark", "--log", str(log)]) == 0
    assert "before" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("direction,x_m\ncw,0.1\n", "missing column y_m"),
        ("direction,x_m,y_m\ncw,0.1,0.2\ncw,0.1,0.1\n", "no ccw runs"),
        ("direction,x_m,y_m\ncw,0.1,0.2\nleft,0.1,0.1\n", "line 3: direction must be cw or ccw"),
        ("direction,x_m,y_m\ncw,0.1,0.2\nccw,,0.1\n", "line 3: x_m is not a finite number (empty)"),
    ],
)
def test_cli_bad_umbmark_logs(content: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log, out = tmp_path / "runs.csv", tmp_path / "v.toml"
    log.write_text(content)
    assert main(["identify", "umbmark", "--log", str(log), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err
    assert not out.exists()


def test_cli_identify_needs_a_source(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["identify", "friction"]) == 2
    assert main(["identify", "mass", "--left", "30"]) == 2
    assert main(["identify", "umbmark", "--simulate", "--noise", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 3
