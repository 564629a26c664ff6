"""The pose EKF's odometry calibration: learnt from the fixes on the figure-8 to the accuracy its σ claims, with
the pose consistent (NEES in its chi-square interval) while it learns; summarised against the truth and written
back as a vehicle."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from cli_runs import run
from scipy.stats import chi2

from agvctl.checks.summary import run_summary
from agvctl.estimation.calibration import calibrated_vehicle, calibration_summary, calibration_truth
from agvctl.estimation.offline import filter_log, resense_log
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"
N_RUNS = 50
# the right wheel 1 % larger and the wheel base 2 % wider than believed: the edges of the vehicle file's tolerances
PLANT = ["wheels.right.radius_m=0.101", f"wheels.separation_m={0.54 * 1.02!r}"]


@pytest.fixture(scope="module")
def miscalibrated():
    exp = load_experiment(EXPERIMENTS / "figure8_ekf.toml")
    exp = dataclasses.replace(exp, plant_vehicle=exp.plant_vehicle.with_overrides(PLANT))
    return exp, run_experiment(exp)


@pytest.fixture(scope="module")
def monte_carlo(miscalibrated):
    """50 sensor realisations of the run, each filtered from an initial error drawn from the filter's prior."""
    exp, result = miscalibrated
    log = result.log
    rng = np.random.default_rng(7)
    start = np.array([log["x_m"][0], log["y_m"][0], log["theta_rad"][0]])
    p0 = np.array([0.005, 0.005, 0.005])  # EkfSettings' initial pose σ
    return [
        filter_log(
            resense_log(log, exp.plant_vehicle, seed=2000 + i),
            exp.controller_vehicle,
            initial_pose=start + p0 * rng.standard_normal(3),
        )
        for i in range(N_RUNS)
    ]


def test_nees_while_learning_a_miscalibrated_geometry_is_in_the_chi_square_interval(monte_carlo):
    # the average NEES over runs and samples: chi-square(3·50)/50 at each sample (Bar-Shalom)
    lo, hi = chi2.ppf([0.025, 0.975], 3 * N_RUNS) / N_RUNS
    anees = float(np.mean([run["nees"] for run in monte_carlo]))
    assert lo <= anees <= hi, (anees, lo, hi)


STATES = ("radius_error_left", "radius_error_right", "separation_error")


def test_one_lap_of_the_figure8_calibrates_the_radii_and_the_wheel_base(miscalibrated, monte_carlo):
    exp, result = miscalibrated
    truth = calibration_truth(exp.controller_vehicle, exp.plant_vehicle)
    assert truth == pytest.approx([0.0, 0.01, 0.02])
    believed = np.array([0.1, 0.1, 0.54])

    def relative_error(eps):
        return believed * (1 + np.asarray(eps)) / (believed * (1 + truth)) - 1

    # the run itself, after its one lap: radii within 0.2 %, the wheel base within 0.3 %
    rel = relative_error([result.log["est_" + c][-1] for c in STATES])
    assert np.all(np.abs(rel[:2]) <= 0.002) and abs(rel[2]) <= 0.003, rel
    # over 50 sensor realisations: no bias beyond a tenth of that, and the σ the filter claims (about 0.08 % of
    # each, so 0.2 % is 2.6σ) is what the runs scatter by, within the sampling error of 50 runs
    final = np.array([[run[c][-1] for c in STATES] for run in monte_carlo])
    rel = np.array([relative_error(eps) for eps in final])
    assert np.all(np.abs(rel.mean(axis=0)) <= [0.0002, 0.0002, 0.0003]), rel.mean(axis=0)
    claimed = np.array([[run[c + "_sigma"][-1] for c in STATES] for run in monte_carlo])
    z2 = np.sum(((final - truth) / claimed) ** 2, axis=0)  # per state: the runs are independent, the states not
    assert np.all((chi2.ppf(0.001, N_RUNS) < z2) & (z2 < chi2.ppf(0.999, N_RUNS))), z2 / N_RUNS


def test_the_run_summary_reports_the_calibration_against_the_truth(miscalibrated):
    exp, result = miscalibrated
    summary = run_summary(exp, result)
    cal = summary["calibration"]
    assert cal["wheels.separation_m"]["truth"] == pytest.approx(0.54 * 1.02)
    for entry in cal.values():
        assert abs(entry["estimate"] - entry["truth"]) < 3 * entry["sigma"]
    assert summary["metrics"]["fixes_rejected"] == 0  # the default fixes never fail the gate here


def test_the_calibrated_vehicle_reads_back_and_closes_the_loop_on_the_true_geometry(miscalibrated, tmp_path):
    exp, result = miscalibrated
    log = result.log
    eps = np.array([log[c][-1] for c in ("est_radius_error_left", "est_radius_error_right", "est_separation_error")])
    sig = np.array(
        [
            log[c][-1]
            for c in ("est_sigma_radius_error_left", "est_sigma_radius_error_right", "est_sigma_separation_error")
        ]
    )
    vehicle = calibrated_vehicle(exp.controller_vehicle, eps, sig)
    residual = calibration_truth(vehicle, exp.plant_vehicle)
    assert np.all(np.abs(residual) < 3 * sig)
    assert vehicle.wheels.separation_tolerance == pytest.approx(3 * sig[2])
    assert calibration_summary(log, vehicle) is not None
    again = calibration_truth(load_vehicle(None, [f"wheels.separation_m={vehicle.wheels.separation_m!r}"]), vehicle)
    assert again[2] == 0.0


def test_agvctl_run_writes_the_calibrated_vehicle_that_an_experiment_then_takes(tmp_path, capsys):
    code, out, _ = run(capsys, "run", EXPERIMENTS / "figure8_ekf.toml", "--no-plot", "--out", tmp_path / "out")
    assert code == 0 and "calibration       wheels.right.radius_m" in out
    path = tmp_path / "out" / "calibrated_vehicle.toml"
    text = path.read_text()
    assert text.startswith("# 'IAU AGV' calibrated online by the pose EKF in the run of figure8_ekf")
    vehicle = load_vehicle(path)
    plant = load_vehicle(None, ["wheels.right.radius_m=0.1005"])  # figure8_ekf.toml's plant
    assert np.all(np.abs(calibration_truth(vehicle, plant)) < 3 * vehicle.wheels.radius_tolerance)
    # the calibrated vehicle as an experiment's believed vehicle: its odometry now matches the plant
    src = (EXPERIMENTS / "figure8_odometry.toml").read_text().replace("../", f"{EXPERIMENTS.parent}/")
    exp_file = tmp_path / "odometry.toml"
    exp_file.write_text(src.replace('vehicle = "default"', f'vehicle = "{path}"'))
    calibrated = run_experiment(load_experiment(exp_file))
    nominal = run_experiment(load_experiment(EXPERIMENTS / "figure8_odometry.toml"))
    assert (
        closed_loop_metrics(calibrated)["estimate_error_max_m"]
        < 0.2 * closed_loop_metrics(nominal)["estimate_error_max_m"]
    )
