"""Sensors and estimation: encoder and fix models, wheel-speed estimators, the pose EKF's consistency (NEES against
the chi-square interval), its latency handling, offline filtering and smoothing, and the wheel loops at rest."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from agvctl.angles import wrap_angle
from agvctl.errors import ConfigError
from agvctl.estimation.ekf import EkfSettings
from agvctl.estimation.offline import filter_log, read_log, resense_log, smooth_log
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment, run_experiment
from agvctl.sensing import Sensors, fix_delay_samples

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"
N_RUNS = 50


@pytest.fixture(scope="module")
def ekf_run():
    exp = load_experiment(EXPERIMENTS / "figure8_ekf.toml")
    return exp, run_experiment(exp)


def variant(exp, *, settle_s=None, **controller):
    c = dataclasses.replace(exp.spec.controller, **controller)
    spec = dataclasses.replace(exp.spec, controller=c, settle_s=exp.spec.settle_s if settle_s is None else settle_s)
    return dataclasses.replace(exp, spec=spec)


def test_encoder_counts_are_the_shaft_angle_within_one_count(ekf_run):
    exp, result = ekf_run
    log = result.log
    q = 2 * math.pi / exp.plant_vehicle.sensors.encoder_counts_per_rev
    for side in ("left", "right"):
        counts = log[f"encoder_count_{side}"]
        assert np.all(counts == np.round(counts))  # whole counts
        turned = (counts - counts[0]) * q
        assert np.max(np.abs(turned - log[f"motor_angle_{side}_rad"])) < q * (1 + 1e-9)  # one latch per end
    # the shaft angle is the integral of the motor speed: trapezoid over each sample, to the rule's own error
    dphi = np.diff(log["motor_angle_left_rad"])
    trap = 0.5 * (log["omega_motor_left_rad_s"][1:] + log["omega_motor_left_rad_s"][:-1]) * 0.04
    assert np.max(np.abs(dphi - trap)) < 0.02 * np.max(np.abs(dphi))


def test_fixes_arrive_at_the_rate_and_latency_of_the_sensor_table(ekf_run):
    exp, result = ekf_run
    log, s = result.log, exp.plant_vehicle.sensors
    arrived = np.isfinite(log["fix_measured_t_s"])
    duration = log["t_s"][-1]
    assert abs(np.count_nonzero(arrived) - s.position_fix_rate_hz * duration) <= 2
    delay = log["t_s"][arrived] - log["fix_measured_t_s"][arrived]
    assert np.all(delay >= s.position_fix_latency_s - 1e-12)
    assert np.all(delay < s.position_fix_latency_s + 0.04)  # delivered at the first sample after arrival
    assert fix_delay_samples(exp.plant_vehicle) == 2  # 50 ms at 40 ms
    # the noise: normalised fix errors against the truth at the measurement time are N(0, 1) (chi-square, 3 dof)
    k_meas = np.round(log["fix_measured_t_s"][arrived] / 0.04).astype(int)
    err = np.column_stack(
        [log[c][arrived] - log[t][k_meas] for c, t in (("fix_x_m", "x_m"), ("fix_y_m", "y_m"))]
        + [wrap_angle(log["fix_theta_rad"][arrived] - log["theta_rad"][k_meas])]
    )
    sig = np.array([s.position_fix_sigma_m, s.position_fix_sigma_m, math.radians(s.heading_fix_sigma_deg)])
    stat = float(np.sum((err / sig) ** 2))
    dof = err.size
    assert chi2.ppf(0.001, dof) < stat < chi2.ppf(0.999, dof)


def test_sensor_noise_follows_the_seed(vehicle):
    a, b = Sensors(vehicle, seed=3), Sensors(vehicle, seed=3)
    pose = np.array([1.0, 2.0, 0.3])
    ra = [a.read(k, np.zeros(2, dtype=np.int64), pose, np.zeros(2)) for k in range(20)]
    rb = [b.read(k, np.zeros(2, dtype=np.int64), pose, np.zeros(2)) for k in range(20)]
    fa = [f.pose for r in ra for f in r.fixes]
    assert fa and np.array_equal(fa, [f.pose for r in rb for f in r.fixes])
    c = Sensors(vehicle, seed=4)
    fc = [f.pose for k in range(20) for f in c.read(k, np.zeros(2, dtype=np.int64), pose, np.zeros(2)).fixes]
    assert not np.array_equal(fa, fc[: len(fa)])


def test_kalman_wheel_speed_beats_the_count_difference(ekf_run):
    exp, result = ekf_run
    errors = {}
    for name in ("kalman", "count_difference"):
        log = result.log if name == "kalman" else run_experiment(variant(exp, wheel_speed=name)).log
        err = log["measured_omega_motor_left_rad_s"] - log["omega_motor_left_rad_s"]
        errors[name] = float(np.sqrt(np.mean(err**2)))
    # the count difference is the mean speed over the last sample: half a sample late, so during the figure-8's
    # accelerations its error is of the order a·T_s/2; the filter predicts with eqs 60-61 to t_k
    assert errors["kalman"] < 0.5 * errors["count_difference"], errors


def test_ekf_tracks_the_figure8_and_odometry_drifts(ekf_run):
    exp, result = ekf_run
    m = closed_loop_metrics(result)
    assert m["tracking_error_rms_m"] <= 0.005 and m["estimate_error_rms_m"] <= 0.005
    odo = closed_loop_metrics(run_experiment(load_experiment(EXPERIMENTS / "figure8_odometry.toml")))
    # a 0.5 % larger right wheel the odometry does not know: its heading drifts by 0.005·s/b, the position with it
    assert odo["estimate_error_max_m"] > 10 * m["estimate_error_max_m"]


def test_nees_over_seeded_runs_is_in_the_chi_square_interval_and_needs_the_latency_handling(ekf_run):
    # 50 sensor realisations (encoder phases, fix noise) of one true run, each filter started from an initial
    # error drawn from its prior P0; the average NEES at a sample is then chi-square(3·50)/50 (Bar-Shalom)
    exp, result = ekf_run
    log = result.log
    lo, hi = chi2.ppf([0.025, 0.975], 3 * N_RUNS) / N_RUNS
    rng = np.random.default_rng(12)
    start = np.array([log["x_m"][0], log["y_m"][0], log["theta_rad"][0]])
    logs = [resense_log(log, exp.plant_vehicle, seed=1000 + i) for i in range(N_RUNS)]
    anees = {}
    for name, settings in (("replay", EkfSettings()), ("ignored", EkfSettings(latency_compensation=False))):
        p0 = np.array([settings.initial_position_sigma_m] * 2 + [settings.initial_heading_sigma_rad])
        runs = [
            filter_log(one, exp.controller_vehicle, settings, initial_pose=start + p0 * rng.standard_normal(3))["nees"]
            for one in logs
        ]
        anees[name] = float(np.mean(runs))
    assert lo <= anees["replay"] <= hi, (anees, lo, hi)
    assert anees["ignored"] > 10 * hi, (anees, lo, hi)  # 80 ms late at 0.5 m/s: 4 cm against σ = 1 cm


def test_offline_filter_reproduces_the_loop_and_the_smoother_improves_on_it(ekf_run, tmp_path):
    exp, result = ekf_run
    result.log.to_csv(tmp_path / "log.csv")
    log = read_log(tmp_path / "log.csv")
    filtered = filter_log(log, exp.controller_vehicle)
    for c in ("est_x_m", "est_y_m", "est_theta_rad"):
        np.testing.assert_allclose(filtered[c], result.log[c], atol=1e-9)
    # the loop's NEES (Cramer's rule in floats) and the offline one (numpy's solve) agree
    np.testing.assert_allclose(filtered["nees"], result.log["nees"], rtol=1e-6, atol=1e-9)
    smoothed = smooth_log(log, exp.controller_vehicle)

    def rms(est):
        return float(np.sqrt(np.mean((est["est_x_m"] - log["x_m"]) ** 2 + (est["est_y_m"] - log["y_m"]) ** 2)))

    assert rms(smoothed) < rms(filtered)
    assert np.all(smoothed["est_sigma_x_m"] <= filtered["est_sigma_x_m"] + 1e-12)
    # the radius error the plant has (right wheel 0.5 % larger) is what the ε states find
    assert abs(smoothed["radius_error_right"][-1] - smoothed["radius_error_left"][-1] - 0.005) < 0.002


def test_encoder_quantisation_does_not_make_the_wheel_loops_limit_cycle_at_rest():
    exp = load_experiment(EXPERIMENTS / "line.toml")
    for wheel_speed in ("kalman", "count_difference"):
        run = variant(exp, pose="none", pose_settings=None, wheel_speed=wheel_speed, settle_s=4.0)
        log = run_experiment(run).log
        rest = log["t_s"] >= exp.reference.duration_s + 2.0  # setpoints zero for 2 s
        for side in ("left", "right"):
            assert np.count_nonzero(np.diff(log[f"da_code_{side}"][rest])) == 0, (wheel_speed, side)
            assert np.all(log[f"omega_motor_{side}_rad_s"][rest] == 0.0)  # held by stiction


def test_bad_sensor_and_estimator_keys_are_one_line_errors(tmp_path):
    src = (EXPERIMENTS / "figure8_ekf.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(
        src.replace('wheel_speed = "kalman"', 'wheel_speed = "kalmann"').replace("../", f"{EXPERIMENTS}/../")
    )
    with pytest.raises(ConfigError, match=r"controller.wheel_speed: must be one of 'exact'"):
        load_experiment(bad)
    bad.write_text(src.replace("sensor_seed = 1", "sensor_seed = -1").replace("../", f"{EXPERIMENTS}/../"))
    with pytest.raises(ConfigError, match=r"plant.sensor_seed: must be >= 0"):
        load_experiment(bad)
    with pytest.raises(ConfigError, match=r"sensors.encoder_counts_per_rev: must be > 0"):
        load_vehicle(None, ["sensors.encoder_counts_per_rev=0"])
    with pytest.raises(ConfigError, match=r"sensors.position_fix_sigma_m"):
        load_vehicle(None, ["sensors.position_fix_sigma_m=-0.01"])


def test_monte_carlo_samples_get_their_own_sensor_noise_and_check_reports_consistency(tmp_path, capsys):
    from agvctl.checks.report import CheckReport, ExperimentReport, RunTask
    from agvctl.checks.runner import run_task
    from agvctl.cli.check_cmd import format_report

    src = (EXPERIMENTS / "robustness" / "figure8_ekf_mc.toml").read_text()
    src = src.replace("../../trajectories/figure8.toml", str(EXPERIMENTS.parent / "trajectories" / "line.toml"))
    path = tmp_path / "line_ekf_mc.toml"
    path.write_text(src.replace("samples = 50", "samples = 3"))
    outcomes = [run_task(RunTask(str(path), sample)) for sample in (None, 0, 1)]
    nees = [o.metrics["nees_mean"] for o in outcomes]
    assert len(set(nees)) == 3  # the nominal run and each sample: another sensor realisation
    assert run_task(RunTask(str(path), 1)).metrics["nees_mean"] == nees[2]  # and the same again for the same sample
    report = ExperimentReport("line_ekf_mc", str(path), [], outcomes, 0.0)
    c = report.consistency()
    lo, hi = chi2.ppf([0.025, 0.975], 9) / 3
    assert c is not None and c["nees_mean"]["interval_95"] == pytest.approx([lo, hi])
    assert c["nees_mean"]["value"] == pytest.approx(np.mean(nees))
    assert report.as_dict()["consistency"]["nis_mean"]["runs"] == 3
    text = format_report(CheckReport([report], 0.0))
    assert "NEES  mean" in text and "NIS   mean" in text


def test_gyro_reads_the_mean_yaw_rate_and_the_ekf_fuses_it(ekf_run):
    exp, _ = ekf_run
    on = ["sensors.gyro_enabled=true"]
    gyro_exp = dataclasses.replace(
        exp,
        controller_vehicle=exp.controller_vehicle.with_overrides(on),
        plant_vehicle=exp.plant_vehicle.with_overrides(on),
    )
    result = run_experiment(gyro_exp)
    log, s = result.log, gyro_exp.plant_vehicle.sensors
    mean_rate = np.diff(log["theta_rad"]) / 0.04  # eq 40 over each sample
    err = log["gyro_rate_rad_s"][1:] - mean_rate - s.gyro_bias_rad_s
    assert np.isnan(log["gyro_rate_rad_s"][0])
    var = s.gyro_sigma_rad_s**2 + s.gyro_quantum_rad_s**2 / 12  # white noise and the reading's rounding
    stat, dof = float(np.sum(err**2) / var), err.size
    assert chi2.ppf(0.001, dof) < stat < chi2.ppf(0.999, dof)
    m = closed_loop_metrics(result)
    assert m["estimate_error_rms_m"] <= 0.005 and m["tracking_error_rms_m"] <= 0.005
    assert 1.0 < m["nees_mean"] < 6.0  # of the order of its 3 degrees of freedom (one run: no tight interval)


@pytest.mark.parametrize("wheel_speed", ["kalman", "count_difference"])
def test_encoder_speeds_do_not_make_the_wheels_stick_slip_at_low_speed(vehicle, wheel_speed):
    from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
    from agvctl.controllers.pi.tuning import default_pi_gains
    from agvctl.controllers.pi.wheel_loop import PIWheelController
    from agvctl.planning import LineSegment, WheelLimits, plan_segments
    from agvctl.sim.loop import run_closed_loop

    speed = 0.005  # 5 mm/s: 1.8 rad/s at the motor, 23 counts per sample
    limits = WheelLimits(wheel_speed_m_s=0.8, wheel_accel_m_s2=0.5, wheel_jerk_m_s3=3.0)
    ref = plan_segments(
        [LineSegment(length_m=0.05, speed_m_s=speed)], limits=limits, separation_m=0.54, sample_period_s=0.04
    )
    gains, _tau = default_pi_gains(vehicle)
    log = run_closed_loop(
        plant_vehicle=vehicle,
        controller_vehicle=vehicle,
        reference=ref,
        pose_controller=FeedForwardPoseController(),
        wheel_controller=PIWheelController(vehicle, gains),
        wheel_speed=wheel_speed,
    ).log
    cruise = (log["t_s"] > 2.0) & (log["t_s"] < ref.duration_s - 2.0)
    for side in ("left", "right"):
        w = log[f"wheel_speed_{side}_m_s"][cruise]
        assert np.all(w > 0)  # never stuck: stiction would hold a wheel whose loop limit-cycles through zero
        assert abs(w.mean() - speed) < 0.01 * speed and w.std() < 0.05 * speed


def test_a_late_fix_replayed_gives_the_estimate_of_one_that_came_on_time(vehicle):
    from agvctl.estimation.ekf import PoseEkf
    from agvctl.sensing import PositionFix

    rng = np.random.default_rng(21)
    counts = np.cumsum(rng.integers(900, 1400, size=(30, 2)), axis=0)  # a turning drive, about 0.5 m/s
    fix = PositionFix(10, 0.4, np.array([0.21, 0.03, 0.05]))
    on_time, late = PoseEkf(vehicle), PoseEkf(vehicle)
    for ekf in (on_time, late):
        ekf.reset(np.zeros(3))
    for k in range(30):
        a = on_time.step(k, counts[k], math.nan, (fix,) if k == 10 else ())
        b = late.step(k, counts[k], math.nan, (fix,) if k == 12 else ())
        if k >= 12:  # the replay makes the late filter the on-time one, state and covariance
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-12)
            np.testing.assert_allclose(late.P, on_time.P, rtol=1e-9, atol=1e-18)
    assert late.dropped_fixes == 0


def test_more_fixes_than_samples_is_a_one_line_error():
    with pytest.raises(ConfigError, match=r"sensors.position_fix_rate_hz: at most one fix per control sample"):
        load_vehicle(None, ["sensors.position_fix_rate_hz=30"])


def test_every_estimator_runs_on_a_logged_run_as_in_the_loop(ekf_run):
    from agvctl.estimation.offline import estimate_log, wheel_speeds_log

    exp, result = ekf_run
    log = result.log
    again = estimate_log(log, exp.controller_vehicle, "ekf")
    for c in ("est_x_m", "est_y_m", "est_theta_rad"):
        np.testing.assert_allclose(again[c], log[c], atol=1e-12)
    speeds = wheel_speeds_log(log, exp.controller_vehicle, "kalman")
    for side in ("left", "right"):
        np.testing.assert_allclose(speeds[f"omega_motor_{side}_rad_s"], log[f"measured_omega_motor_{side}_rad_s"])
    odo = load_experiment(EXPERIMENTS / "figure8_odometry.toml")
    odo_log = run_experiment(odo).log
    np.testing.assert_allclose(estimate_log(odo_log, odo.controller_vehicle)["est_x_m"], odo_log["est_x_m"])


def test_plant_set_makes_the_true_sensors_differ_from_the_belief(ekf_run):
    exp, result = ekf_run
    worse = exp.plant_vehicle.with_overrides(["sensors.position_fix_sigma_m=0.03"])
    assert exp.controller_vehicle.sensors.position_fix_sigma_m == 0.01  # the EKF still believes 1 cm
    noisy = closed_loop_metrics(run_experiment(dataclasses.replace(exp, plant_vehicle=worse)))
    matched = closed_loop_metrics(result)
    # position innovations 3x larger than believed: the NIS's two position terms grow about ninefold
    assert noisy["nis_mean"] > 3 * matched["nis_mean"]
    assert noisy["estimate_error_rms_m"] > matched["estimate_error_rms_m"]
