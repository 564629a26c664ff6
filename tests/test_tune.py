"""`agvctl tune`: margins checked independently on the loop rebuilt from the printed C(z) and a ZOH plant
built here from the report's constants; spec handling; the gains file; plots; bad input."""

import json
import math

import control
import numpy as np
import pytest

from agvctl.cli import main
from agvctl.controllers.pi.gains_file import load_gains
from agvctl.controllers.pi.tuning import TuningSpec, design_pi
from agvctl.errors import ConfigError

# the report's constants (appendix A; k_t from ERRATA), and the decoupled model of eqs 1, 47, 49, 60
J, R, K_E, K_T, F_M = 2.5e-5, 0.38, 0.027, 0.027, 0.0
M, I_O, B, RADIUS, N = 85.0, 5.46, 0.54, 0.10, 36.0  # I about the point of rotation (ERRATA)
T_S = 0.040
K_LL = RADIUS**2 / N**2 * (M / 4 + I_O / B**2)  # eq 47
K_LR = RADIUS**2 / N**2 * (M / 4 - I_O / B**2)  # eq 49
J_EQ = J + K_LL - K_LR**2 / (J + K_LL)  # eq 60 (both sides alike)
DAMPING = K_E * K_T / R + F_M  # J̃ ω̇ = k_t/R u − (k_e k_t/R + f_m) ω
GAIN_DC = (K_T / R) / DAMPING  # rad/s per V
A_POLE = math.exp(-DAMPING / J_EQ * T_S)  # exact ZOH: G(z) = K (1 − a)/(z − a)
CHAIN = 2.0 * 1.0 / 2.0  # controller volts ÷ k_pow → DA (1 V/V) → × k_pow


def plant_z(z):
    return GAIN_DC * (1 - A_POLE) / (z - A_POLE)


def independent_margins(num, den):
    """Margins of L = C·G on a dense grid up to and including z = −1, written independently of agvctl."""
    w = np.linspace(1e-3, math.pi / T_S, 400_001)  # includes π/T_s
    z = np.exp(1j * w * T_S)
    L = np.polyval(num, z) / np.polyval(den, z) * CHAIN * plant_z(z)
    mag = np.abs(L)
    i = np.nonzero((mag[:-1] >= 1) & (mag[1:] < 1))[0]
    assert len(i) == 1  # one gain crossover
    k = i[0]
    frac = (0 - np.log(mag[k])) / (np.log(mag[k + 1]) - np.log(mag[k]))
    wc = w[k] + frac * (w[k + 1] - w[k])
    ph = np.unwrap(np.angle(L))
    pm = 180 + math.degrees(ph[k] + frac * (ph[k + 1] - ph[k]))
    # phase crossings: only at the Nyquist frequency, where L is real and negative
    assert np.all(ph[:-1] > -math.pi)
    assert abs(L[-1].imag) < 1e-12 and L[-1].real < 0
    gm = -20 * math.log10(abs(L[-1]))
    return gm, pm, wc


@pytest.fixture(scope="module")
def tune_json():
    import io
    from contextlib import redirect_stdout

    buf = io.StringIO()
    with redirect_stdout(buf):
        code = main(["tune", "--json"])
    assert code == 0
    return json.loads(buf.getvalue())


def test_json_shape(tune_json):
    assert set(tune_json) == {"controller", "margins", "step"}
    assert set(tune_json["controller"]) == {"kp", "ki", "num", "den", "dt"}
    assert set(tune_json["margins"]) == {"gain_margin_db", "phase_margin_deg", "crossover_rad_s"}
    assert set(tune_json["step"]) == {
        "rise_time_s",
        "overshoot_pct",
        "settling_time_s",
        "steady_state_error_pct",
    }
    c = tune_json["controller"]
    assert c["dt"] == T_S
    assert c["num"] == pytest.approx([c["kp"] + c["ki"] * T_S, -c["kp"]])
    assert c["den"] == [1.0, -1.0]


def test_margins_agree_with_an_independent_computation(tune_json):
    c, m = tune_json["controller"], tune_json["margins"]
    gm, pm, wc = independent_margins(c["num"], c["den"])
    assert m["gain_margin_db"] == pytest.approx(gm, abs=1e-3)
    assert m["phase_margin_deg"] == pytest.approx(pm, abs=1e-3)
    assert m["crossover_rad_s"] == pytest.approx(wc, rel=1e-4)
    # the spec, met
    assert m["phase_margin_deg"] >= 60.0
    assert m["gain_margin_db"] >= 10.0
    # closed form at z = −1: |L(−1)| = C(−1) K (1 − a)/(1 + a), C(−1) = kp + ki T/2
    c_nyq = c["kp"] + c["ki"] * T_S / 2
    assert m["gain_margin_db"] == pytest.approx(
        -20 * math.log10(c_nyq * GAIN_DC * (1 - A_POLE) / (1 + A_POLE)), abs=1e-6
    )


def test_python_control_agrees_where_it_is_sane(tune_json):
    """python-control's phase margin and crossover match; its gain margin misses the crossing at z = −1."""
    c, m = tune_json["controller"], tune_json["margins"]
    g = control.tf([GAIN_DC * (1 - A_POLE)], [1, -A_POLE], T_S)
    loop = control.tf(c["num"], c["den"], T_S) * g
    gm, pm, _wg, wc = control.margin(loop)
    assert pm == pytest.approx(m["phase_margin_deg"], abs=1e-3)
    assert wc == pytest.approx(m["crossover_rad_s"], rel=1e-4)
    # its gain margin is infinite or from a spurious crossing at ω = 0, never the true 10 dB at Nyquist
    assert not (np.isfinite(gm) and gm > 0 and abs(20 * math.log10(gm) - m["gain_margin_db"]) < 0.1)


def test_design_is_the_fastest_the_margins_allow(vehicle):
    best = design_pi(vehicle)
    wc = best.margins.crossover_rad_s
    assert wc == pytest.approx(best.max_crossover_rad_s, rel=1e-4)
    with pytest.raises(ConfigError, match="crossover can be at most"):
        design_pi(vehicle, TuningSpec(crossover_rad_s=wc * 1.01))
    slower = design_pi(vehicle, TuningSpec(crossover_rad_s=wc * 0.5))
    assert slower.margins.crossover_rad_s == pytest.approx(wc * 0.5, rel=1e-6)
    assert slower.margins.phase_margin_deg >= 60.0 and slower.margins.gain_margin_db >= 10.0
    # a laxer phase margin allows a faster loop
    assert design_pi(vehicle, TuningSpec(phase_margin_deg=45.0)).margins.crossover_rad_s > wc


def test_step_figures_are_physical(tune_json):
    """0.3 m/s step: the current limit bounds the acceleration to a_lim = 0.657 m/s² (eq 5), so the 10-90 %
    rise takes at least 0.8·0.3/a_lim; the integrator leaves no steady-state error despite Coulomb
    friction."""
    s = tune_json["step"]
    bound = 0.8 * 0.3 / 0.657
    assert bound * 0.97 <= s["rise_time_s"] <= 1.5 * bound
    assert 0.0 <= s["overshoot_pct"] < 5.0
    assert s["rise_time_s"] < s["settling_time_s"] < 1.5
    assert s["steady_state_error_pct"] < 0.2


def test_readable_report(capsys):
    assert main(["tune"]) == 0
    out = capsys.readouterr().out
    for text in ("kp =", "ki =", "PM", "GM", "rise", "overshoot", "settling", "steady-state error"):
        assert text in out


def test_out_and_plot(tmp_path, capsys):
    gains = tmp_path / "gains" / "pi.toml"
    plots = tmp_path / "plots"
    assert main(["tune", "--json", "--out", str(gains), "--plot", str(plots), "--coulomb-feedforward"]) == 0
    data = json.loads(capsys.readouterr().out)
    settings = load_gains(gains)
    assert settings.kp_v_s_rad == data["controller"]["kp"]
    assert settings.ki_v_rad == data["controller"]["ki"]
    assert settings.dt_s == T_S
    assert settings.coulomb_feedforward is True
    for name in ("bode.png", "nyquist.png", "step.png"):
        assert (plots / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--phase-margin", "-5"], "--phase-margin"),
        (["--phase-margin", "nan"], "--phase-margin"),
        (["--gain-margin", "-1"], "--gain-margin"),
        (["--bandwidth", "0"], "--bandwidth"),
        (["--bandwidth", "100"], "Nyquist"),
        (["--phase-margin", "89.9", "--bandwidth", "20"], "crossover can be at most"),
        (["--phase-margin", "abc"], "invalid float"),
        (["--set", "motor.resistence_ohm=1"], "did you mean"),
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, argv, needle):
    out_file = tmp_path / "g.toml"
    plot_dir = tmp_path / "plots"
    code = main(["tune", *argv, "--out", str(out_file), "--plot", str(plot_dir)])
    _out, err = capsys.readouterr()
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert needle in err
    assert not out_file.exists() and not plot_dir.exists()


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[pi]\nkp_v_s_rad = 0.06\nki_v_rad = 0.7\ndt_s = 0.04\ncoulomb_feedfoward = true\n", "did you mean"),
        ("[pi]\nkp_v_s_rad = -0.06\nki_v_rad = 0.7\ndt_s = 0.04\n", "pi.kp_v_s_rad: must be >= 0"),
        ("[pi]\nkp_v_s_rad = 0.06\nki_v_rad = 0.7\n", "pi.dt_s: missing key"),
        ("[pi]\nkp_v_s_rad = 0\nki_v_rad = 0\ndt_s = 0.04\n", "both zero"),
        ("[pi]\nkp_v_s_rad = '0.06'\nki_v_rad = 0.7\ndt_s = 0.04\n", "expected a number"),
    ],
)
def test_load_gains_is_strict(tmp_path, text, needle):
    path = tmp_path / "g.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_gains(path)
    msg = str(info.value)
    assert "\n" not in msg and str(path) in msg and needle in msg


def test_help():
    assert main(["tune", "--help"]) == 0


@pytest.mark.parametrize("mass_kg", [None, 75.0, 140.0])
def test_the_design_samples_the_wheel_models_as_python_control_does(vehicle, mass_kg):
    """The design works on polynomials (so a run designs its loops without python-control); they are python-control's
    ZOH-sampled models' coefficients, and the wheel loops' time constant fits python-control's step response."""
    from agvctl.controllers.pi.margins import sampled_wheel_models, sampled_wheel_polynomials, tf_polynomials
    from agvctl.controllers.pi.tuning import closed_loop_time_constant_s, loop_polynomials

    v = vehicle if mass_kg is None else vehicle.with_overrides([("body.mass_kg", mass_kg)])
    for (num, den), tf in zip(sampled_wheel_polynomials(v), sampled_wheel_models(v), strict=True):
        tf_num, tf_den = tf_polynomials(tf)
        assert np.array_equal(num, tf_num) and np.array_equal(den, tf_den)
    gains = design_pi(v).gains
    ts, n = gains.dt_s, 15
    taus = []
    for tf in sampled_wheel_models(v):
        closed = control.feedback(control.tf(*loop_polynomials(gains, tf), ts), 1)
        y = np.asarray(control.step_response(closed, np.arange(n) * ts).outputs, dtype=float).ravel()
        poles = np.linspace(1e-3, 0.999, 999)
        a = poles[int(np.argmin([np.sum((y - (1.0 - p ** np.arange(n))) ** 2) for p in poles]))]
        taus.append(-ts / math.log(a))
    assert closed_loop_time_constant_s(v, gains) == max(taus)
