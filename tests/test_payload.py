"""What a payload feels: the body's accelerations at a point, through the accelerometer's filter, against rigid-body
kinematics (eqs 39-41) and the closed loop's planned motion; an experiment places the accelerometer and judges the
readings in its limits and requirements."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from cli_runs import one_line, run

from agvctl.errors import ConfigError
from agvctl.evaluation.formula import parse_formula
from agvctl.evaluation.limits import LimitsSpec, judge_run
from agvctl.evaluation.metrics import closed_loop_metrics, signal_values
from agvctl.evaluation.payload import HELD_WHEEL_SPEED_M_S, PAYLOAD_LOG_COLUMNS, RECOVERY_S, PayloadAccelerometer
from agvctl.evaluation.requirements import evaluate_requirement
from agvctl.fuzz import generate_scenario, load_fuzz_config
from agvctl.fuzz.generate import scenario_files
from agvctl.log import SimLog
from agvctl.params import load_vehicle
from agvctl.plots import render_run_panel
from agvctl.plots.figures import subplots
from agvctl.plots.payload import draw_body_accel
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"
TS = 0.04


def steady(reading: np.ndarray) -> float:
    """The reading once the filter has settled (the last samples)."""
    return float(np.mean(reading[-10:]))


def test_a_turn_in_place_reads_the_centripetal_acceleration_of_the_point():
    w = np.full(200, 0.8)  # a steady turn in place at 0.8 rad/s, U = 0
    ahead = PayloadAccelerometer(x_m=0.3).read(np.zeros(200), w, TS)
    assert steady(ahead["body_linear_accel_m_s2"]) == pytest.approx(-(0.8**2) * 0.3, rel=1e-9)  # towards the axle
    assert steady(ahead["body_lateral_accel_m_s2"]) == pytest.approx(0.0, abs=1e-12)
    left = PayloadAccelerometer(y_m=0.2).read(np.zeros(200), w, TS)
    assert steady(left["body_lateral_accel_m_s2"]) == pytest.approx(-(0.8**2) * 0.2, rel=1e-9)
    assert steady(left["body_linear_accel_m_s2"]) == pytest.approx(0.0, abs=1e-12)


def test_a_steady_curve_reads_u_squared_over_r_across_and_an_angular_acceleration_reads_at_a_lever():
    u, r = 0.6, 1.5
    reading = PayloadAccelerometer().read(np.full(200, u), np.full(200, u / r), TS)
    assert steady(reading["body_lateral_accel_m_s2"]) == pytest.approx(u * u / r, rel=1e-9)
    alpha = 0.5  # spinning up from rest at 0.5 rad/s²: at 0.4 m ahead, 0.2 m/s² across
    w = alpha * TS * np.arange(20)
    reading = PayloadAccelerometer(x_m=0.4).read(np.zeros(20), w, TS)
    assert reading["body_angular_accel_rad_s2"][-1] == pytest.approx(alpha, rel=0.01)
    assert reading["body_lateral_accel_m_s2"][-1] == pytest.approx(alpha * 0.4, rel=0.01)


def test_the_reading_never_overshoots_a_constant_acceleration_and_settles_within_200_ms():
    a = 0.4
    u = np.concatenate((np.zeros(5), a * TS * np.arange(1, 60)))
    reading = PayloadAccelerometer().read(u, np.zeros_like(u), TS)["body_linear_accel_m_s2"]
    assert np.all(reading <= a * (1 + 1e-12))
    start = 5  # the first sample of the ramp
    assert reading[start + int(round(0.2 / TS))] >= 0.9 * a


def test_a_break_away_spike_of_one_sample_is_averaged_with_its_neighbours():
    u = np.zeros(40)
    u[10:] = 0.04  # one sample at 1 m/s² (a wheel breaking away), then coasting
    reading = PayloadAccelerometer().read(u, np.zeros_like(u), TS)["body_linear_accel_m_s2"]
    assert 0.2 < np.max(reading) <= 0.5
    wide = PayloadAccelerometer(bandwidth_hz=50.0).read(u, np.zeros_like(u), TS)["body_linear_accel_m_s2"]
    assert np.max(wide) > 0.9  # a wide band reads the spike nearly in full


def test_on_the_shipped_circle_the_payload_feels_the_planned_motion():
    result = run_experiment(load_experiment(EXPERIMENTS / "circle.toml"))
    log, ref = result.log, result.reference
    for name in PAYLOAD_LOG_COLUMNS:
        assert np.all(np.isfinite(log[name])), name
    radius = 1.0
    u_max = float(np.max(ref.sample(np.linspace(0, ref.duration_s, 2001)).speed_m_s))
    metrics = closed_loop_metrics(result)
    assert metrics["peak_body_lateral_accel_m_s2"] == pytest.approx(u_max**2 / radius, rel=0.03)
    assert metrics["peak_body_linear_speed_m_s"] == pytest.approx(u_max, rel=0.02)
    # on a circle the angular acceleration is the linear one over the radius
    assert metrics["peak_body_angular_accel_rad_s2"] == pytest.approx(
        metrics["peak_body_linear_accel_m_s2"] / radius, rel=0.05
    )


def test_an_experiment_places_the_accelerometer_and_judges_its_readings(tmp_path: Path, capsys):
    path = (EXPERIMENTS.parent / "trajectories" / "line.toml").as_posix()
    text = f'name = "load"\ntrajectory = "{path}"\n[payload]\nx_m = 0.2\n[limits]\npeak_body_linear_accel_m_s2 = {{}}\n'
    exp = tmp_path / "load.toml"
    exp.write_text(text.format(0.3), encoding="utf-8")
    assert load_experiment(exp).spec.payload == PayloadAccelerometer(x_m=0.2)
    code, out, _ = run(capsys, "check", exp, "--jobs", "1")
    assert code == 1 and "peak_body_linear_accel_m_s2" in out and "VIOLATED" in out
    exp.write_text(text.format(0.8), encoding="utf-8")
    code, out, _ = run(capsys, "check", exp, "--jobs", "1")
    assert code == 0, out
    exp.write_text(text.format(0.8).replace("x_m = 0.2", "x = 0.2"), encoding="utf-8")
    code, _, err = run(capsys, "check", exp, "--jobs", "1")
    assert code == 2
    one_line(err, str(exp), "payload.x")


def test_a_requirement_names_the_payloads_readings(tmp_path: Path):
    path = (EXPERIMENTS.parent / "trajectories" / "line.toml").as_posix()
    exp = tmp_path / "req.toml"
    exp.write_text(
        f'name = "req"\ntrajectory = "{path}"\n[[requirements]]\nname = "gentle"\n'
        'formula = "always abs(body_linear_accel_m_s2) <= 0.8"\n',
        encoding="utf-8",
    )
    assert load_experiment(exp).spec.requirements[0].name == "gentle"


def _wheels_log(
    left_m_s: list[float], right_m_s: list[float], limited_right: list[int], loop_limited_left: list[int] | None = None
) -> SimLog:
    n = len(left_m_s)
    return SimLog(
        {
            "t_s": np.arange(n) * TS,
            "wheel_speed_left_m_s": np.array(left_m_s),
            "wheel_speed_right_m_s": np.array(right_m_s),
            "current_limited_left": np.zeros(n),
            "current_limited_right": np.array(limited_right, dtype=np.float64),
            "wheel_loop_limited_left": np.array(loop_limited_left or [0] * n, dtype=np.float64),
            "wheel_loop_limited_right": np.zeros(n),
        }
    )


def test_a_wheel_is_held_below_a_centimetre_a_second_or_by_a_limit_and_recovers_for_0_4_s():
    recovery = round(RECOVERY_S / TS)  # 10 samples
    n = 40
    moving = [0.2] * n
    slow = [0.2] * n
    slow[3] = -0.5 * HELD_WHEEL_SPEED_M_S  # held by stiction, either direction
    held = signal_values(_wheels_log(slow, moving, [0] * n), "wheel_held", TS)
    assert held.tolist() == [0.0] * 3 + [1.0] * (1 + recovery) + [0.0] * (n - 4 - recovery)
    limited = [0] * n
    limited[20] = 1  # the right wheel's current limit acted in the interval
    held = signal_values(_wheels_log(moving, moving, limited), "wheel_held", TS)
    assert held.tolist() == [0.0] * 20 + [1.0] * (1 + recovery) + [0.0] * (n - 21 - recovery)
    held = signal_values(_wheels_log(moving, moving, [0] * n, limited), "wheel_held", TS)  # its loop clamped
    assert held.tolist() == [0.0] * 20 + [1.0] * (1 + recovery) + [0.0] * (n - 21 - recovery)
    assert not signal_values(_wheels_log(moving, [HELD_WHEEL_SPEED_M_S] * n, [0] * n), "wheel_held", TS).any()


def test_a_requirement_judges_the_payload_away_from_a_break_away():
    """A wheel held by stiction breaks away with a jolt (0.45 m/s² against 0.25 m/s² while moving): judged away from
    held wheels, a 0.3 m/s² bound is kept with the moving samples' margin; judged everywhere, it is not."""
    n = 40
    left = [0.0] * 5 + [0.2] * (n - 5)  # held at rest, then moving
    log = _wheels_log(left, [0.2] * n, [0] * n)
    reading = np.full(n, 0.25)
    reading[6] = 0.45  # the break-away, within the recovery
    log.columns["body_linear_accel_m_s2"] = reading
    away = parse_formula("always (not wheel_held -> abs(body_linear_accel_m_s2) <= 0.3)")
    everywhere = parse_formula("always abs(body_linear_accel_m_s2) <= 0.3")
    assert evaluate_requirement(away, log, TS, None).margin == pytest.approx(0.05)
    assert evaluate_requirement(everywhere, log, TS, None).margin == pytest.approx(-0.15)


def test_a_broken_payload_limit_says_how_the_run_fares_where_the_wheels_move_freely(tmp_path: Path, capsys):
    """A sticky plant (break-away torque 0.11 N m over 0.045 N m of Coulomb friction) jolts the load as a wheel
    breaks away at the start: the default gate breaks the path's 0.3 m/s², and its verdict says the run kept it
    where the wheels move freely."""
    path = tmp_path / "gentle.toml"
    path.write_text(
        'name = "gentle"\n[limits]\nlinear_accel_m_s2 = 0.3\n[[segments]]\ntype = "line"\nlength_m = 1.0\n',
        encoding="utf-8",
    )
    exp = tmp_path / "sticky.toml"
    exp.write_text(
        f'name = "sticky"\ntrajectory = "{path.as_posix()}"\n[plant]\n'
        'set = { "motor.coulomb_friction_n_m" = 0.045, "motor.stiction_n_m" = 0.11 }\n',
        encoding="utf-8",
    )
    experiment = load_experiment(exp)
    verdict = judge_run(run_experiment(experiment), experiment.spec.limits, experiment.controller_vehicle)
    judged = {r.limit: r for r in verdict.limits}["peak_body_linear_accel_m_s2"]
    assert not judged.passed and judged.worst_time_s is not None and judged.worst_time_s < RECOVERY_S + 0.2
    assert "where the wheels move freely (not wheel_held) kept" in judged.note and judged.note in judged.message
    assert all(not r.note for r in verdict.limits if r.passed)
    code, out, _ = run(capsys, "check", exp, "--jobs", "1")  # the gate's line says it too
    assert code == 1 and judged.note in next(line for line in out.splitlines() if "peak_body_linear_accel" in line)


def test_on_the_shipped_line_the_wheels_are_held_at_rest_and_free_while_they_drive():
    result = run_experiment(load_experiment(EXPERIMENTS / "line.toml"))
    held = signal_values(result.log, "wheel_held", result.sample_period_s)
    speed = np.abs(np.asarray(result.log["speed_m_s"]))
    t = np.asarray(result.log["t_s"])
    assert held[0] == 1.0 and held[-1] == 1.0
    cruising = (speed > 0.1) & (t > t[0] + RECOVERY_S + 0.5)
    assert cruising.any() and not held[cruising].any()


def test_the_api_refuses_an_accelerometer_that_is_not_one():
    with pytest.raises(ConfigError, match="bandwidth_hz"):
        PayloadAccelerometer(bandwidth_hz=0.0)
    with pytest.raises(ConfigError, match="x_m"):
        PayloadAccelerometer(x_m=math.inf)


def test_the_run_panel_draws_the_payloads_readings_against_a_load_bound_and_shades_the_held_wheels():
    result = run_experiment(load_experiment(EXPERIMENTS / "line.toml"))
    _, ax = subplots(figsize=(4, 3))
    draw_body_accel(ax, result.log, {"peak_body_linear_accel_m_s2": 0.5})
    labels = [line.get_label() for line in ax.lines]
    assert "payload: body_linear_accel_m_s2" in labels and "peak_body_linear_accel_m_s2 0.5" in labels
    assert not any("lateral" in label for label in labels)  # only the bounds the experiment sets
    shaded = [c.get_label() for c in ax.collections]
    assert shaded == ["a wheel held or recovering (wheel_held)"]  # the line starts and ends at rest
    assert not ax.figure.axes[1:]  # no angular bound, no second axis
    angular = draw_body_accel(ax, result.log, {"peak_body_angular_accel_rad_s2": 1.0})
    labels = [line.get_label() for line in angular.lines]
    assert "payload: body_angular_accel_rad_s2 (right axis)" in labels and "peak_body_angular_accel_rad_s2 1" in labels
    _, alone = subplots(figsize=(4, 3))
    draw_body_accel(alone, result.log, {"peak_body_angular_accel_rad_s2": 1.0})  # the shading is in a legend too
    assert [t.get_text() for t in alone.get_legend().get_texts()] == ["a wheel held or recovering (wheel_held)"]


def test_the_panel_of_a_run_with_a_paths_body_limits_draws_them_and_the_next_panel_starts_clean():
    experiment = load_experiment(EXPERIMENTS / "payload" / "bend_nominal.toml")
    result = run_experiment(experiment)
    verdict = judge_run(result, experiment.spec.limits, experiment.controller_vehicle)
    bounds = {r.limit: r.bound for r in verdict.limits}
    assert bounds["peak_body_angular_accel_rad_s2"] == 1.0  # the path's, judged by default
    plain = {k: v for k, v in bounds.items() if not k.startswith("peak_body")}
    before = render_run_panel(result.log, experiment.controller_vehicle, title="bend", bounds=plain)
    first = render_run_panel(result.log, experiment.controller_vehicle, title="bend", bounds=bounds)
    again = render_run_panel(result.log, experiment.controller_vehicle, title="bend", bounds=bounds)
    after = render_run_panel(result.log, experiment.controller_vehicle, title="bend", bounds=plain)
    assert first == again and before == after != first  # each drawing starts clean: no second axis left behind


def test_a_fuzz_file_places_the_accelerometer_of_every_run(tmp_path: Path):
    text = (EXPERIMENTS / "fuzz" / "ci.toml").read_text(encoding="utf-8")
    fuzz_file = tmp_path / "load.toml"
    fuzz_file.write_text(text + "\n[payload]\nx_m = 0.3\n", encoding="utf-8")
    spec = load_fuzz_config(fuzz_file)
    assert spec.payload == PayloadAccelerometer(x_m=0.3)
    scenario = generate_scenario(spec, load_vehicle(None), 0)
    files = scenario_files(spec, scenario, spec.controllers[0])
    for name, content in files.items():
        (tmp_path / name).write_text(content, encoding="utf-8")
    (experiment,) = [name for name in files if not name.endswith(".path.toml")]
    assert load_experiment(tmp_path / experiment).spec.payload == PayloadAccelerometer(x_m=0.3)


def test_the_default_gate_judges_a_paths_body_limits_and_a_files_limit_replaces_one(tmp_path: Path):
    path = tmp_path / "gentle.toml"
    path.write_text(
        'name = "gentle"\n[limits]\nlinear_accel_m_s2 = 0.3\nangular_speed_rad_s = 1.0\n'
        '[[segments]]\ntype = "line"\nlength_m = 1.0\n',
        encoding="utf-8",
    )
    exp = tmp_path / "gentle-exp.toml"
    exp.write_text(f'name = "gentle"\ntrajectory = "{path.as_posix()}"\n', encoding="utf-8")
    experiment = load_experiment(exp)
    verdict = judge_run(run_experiment(experiment), experiment.spec.limits, experiment.controller_vehicle)
    judged = {r.limit: r for r in verdict.limits}
    for key, bound in (("peak_body_linear_accel_m_s2", 0.3), ("peak_body_angular_speed_rad_s", 1.0)):
        assert judged[key].default and judged[key].bound == bound and "limits." in judged[key].reason
    assert "peak_body_lateral_accel_m_s2" not in judged  # the path sets no lateral limit
    verdict = judge_run(
        run_experiment(experiment), LimitsSpec({"peak_body_linear_accel_m_s2": 0.9}), experiment.controller_vehicle
    )
    judged = {r.limit: r for r in verdict.limits}
    assert not judged["peak_body_linear_accel_m_s2"].default and judged["peak_body_linear_accel_m_s2"].bound == 0.9
