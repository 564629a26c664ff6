"""agvctl check: exit codes, JUnit XML, Monte Carlo on every executor, bad input."""

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from agvctl.checks.report import TIMING_METRICS
from agvctl.checks.runner import check_experiments, monte_carlo_samples
from agvctl.cli import main
from agvctl.scenario.experiment import load_experiment

DATA = Path(__file__).resolve().parent / "data"


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_impossible_limit_fails_with_junit_failure(capsys, tmp_path):
    junit, js = tmp_path / "report.xml", tmp_path / "report.json"
    code, out, _ = run(capsys, "check", DATA / "line_impossible.toml", "--junit", junit, "--json", js, "--jobs", "1")
    assert code == 1
    assert "FAIL" in out and "tracking_error_max_m" in out
    root = ET.parse(junit).getroot()
    assert root.tag == "testsuites" and root.get("failures") == "1"
    cases = {c.get("name"): c for c in root.iter("testcase")}
    assert {"tracking_error_max_m", "peak_motor_current_a", "peak_wheel_accel_m_s2"} <= set(cases)
    assert {"final_position_error_m", "cross_track_error_max_m", "non_finite_commands"} <= set(
        cases
    )  # the default gate's limits too
    failure = cases["tracking_error_max_m"].find("failure")
    assert failure is not None
    msg = failure.get("message")
    assert (
        "tracking_error_max_m" in msg and "1e-06" in msg and "worst at t = " in msg and "first exceeded at t = " in msg
    )
    assert cases["peak_motor_current_a"].find("failure") is None
    data = json.loads(js.read_text())
    (exp,) = data["experiments"]
    verdict = next(v for v in exp["limits"] if v["limit"] == "tracking_error_max_m")
    assert not verdict["passed"] and verdict["value"] > 1e-6 and verdict["first_time_s"] is not None


def test_nominal_experiment_passes(capsys, tmp_path):
    exp = Path(__file__).resolve().parent.parent / "experiments" / "line.toml"
    code, out, _ = run(capsys, "check", exp, "--junit", tmp_path / "r.xml", "--jobs", "1")
    assert code == 0 and "PASS" in out
    assert ET.parse(tmp_path / "r.xml").getroot().get("failures") == "0"


def _physical(report):
    return [
        [(o.task.sample, {k: v for k, v in o.metrics.items() if k not in TIMING_METRICS}) for o in e.outcomes]
        for e in report.experiments
    ]


@pytest.mark.slow
def test_monte_carlo_identical_on_every_executor():
    from dask.distributed import Client, LocalCluster

    serial = check_experiments([DATA / "line_mc.toml"], jobs=1)
    parallel = check_experiments([DATA / "line_mc.toml"], jobs=2)
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        Client(cluster),
    ):
        on_dask = check_experiments([DATA / "line_mc.toml"], executor="dask", scheduler=cluster.scheduler_address)
    assert len(serial.experiments[0].outcomes) == 6
    assert _physical(serial) == _physical(parallel) == _physical(on_dask)
    # the samples really differ, and each verdict names the worst sample and its parameters
    values = {o.metrics["tracking_error_max_m"] for o in serial.experiments[0].outcomes}
    assert len(values) == 6
    verdict = serial.experiments[0].verdicts[0]
    assert verdict.sample is not None and "body.mass_kg" in verdict.parameters


def _bad(tmp_path, text, name="bad.toml"):
    path = tmp_path / name
    path.write_text(text)
    traj = Path(__file__).resolve().parent.parent / "trajectories"
    shutil.copy(traj / "line.toml", tmp_path / "line.toml")
    return path


BASE = 'name = "x"\ntrajectory = "line.toml"\n'


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            BASE + "[limits]\ntracking_eror_max_m = 0.1\n",
            "limits.tracking_eror_max_m: unknown key (did you mean limits.tracking_error_max_m?)",
        ),
        (BASE + "[limits]\ntracking_error_max_m = -0.1\n", "limits.tracking_error_max_m: must be > 0"),
        ('name = "x"\ntrajectory = "nowhere.toml"\n', "trajectory: file not found"),
        (BASE + "[limits\n", "malformed TOML"),
        (BASE + "[controller]\nhorizn = 3\n", "controller.horizn: unknown key (did you mean controller.horizon?)"),
        (BASE + '[plant]\nset = { "wheels.radius_rght_m" = 0.1 }\n', "wheels.radius_rght_m: unknown key"),
        (
            BASE + '[plant]\nset = { "wheels.radius_left_m" = 0.1 }\n',
            "plant.set: wheels.radius_left_m: renamed; use wheels.left.radius_m",
        ),
        (
            BASE + '[robustness]\nsamples = 5\n[robustness.spread]\n"wheels.radius_right_m" = 0.01\n',
            "robustness.spread.wheels.radius_right_m: renamed; use wheels.right.radius_m",
        ),
        (
            BASE + '[robustness]\nsamples = 5\n[robustness.spread]\n"motor.coulomb_friction_n_m" = 0.2\n',
            "robustness (sample ",
        ),
        (
            BASE + '[robustness]\nsamples = 5\n[robustness.spread]\n"body.mass_kg" = 1.5\n',
            "robustness.spread.body.mass_kg",
        ),
    ],
)
def test_bad_input_exits_2_and_writes_nothing(capsys, tmp_path, text, message):
    path = _bad(tmp_path, text)
    junit, js = tmp_path / "r.xml", tmp_path / "r.json"
    code, out, err = run(capsys, "check", path, "--junit", junit, "--json", js, "--jobs", "1")
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err and message in err, err
    assert str(path) in err
    assert not junit.exists() and not js.exists()


def test_monte_carlo_draws_one_side_of_a_shared_value(tmp_path):
    """The default vehicle has one wheel radius for both sides: ``wheels.left.radius_m`` varies the left one, and
    ``wheels.radius_m`` the shared one, which the left's own value leaves to the right."""
    spread = '"wheels.left.radius_m" = 0.01\n"wheels.radius_m" = 0.02\n'
    path = _bad(tmp_path, BASE + f"[robustness]\nsamples = 3\nseed = 1\n[robustness.spread]\n{spread}", "mc.toml")
    exp = load_experiment(path)
    samples = monte_carlo_samples(exp)
    assert len(samples) == 3
    for (left_key, left), (common_key, common) in samples:
        assert (left_key, common_key) == ("wheels.left.radius_m", "wheels.radius_m")
        v = exp.plant_vehicle.with_overrides([(left_key, left), (common_key, common)])
        assert (v.wheels.left.radius_m, v.wheels.right.radius_m) == (left, common)
        assert left != 0.10 and common != 0.10


def test_bad_input_in_a_later_file_runs_nothing(capsys, tmp_path):
    good = Path(__file__).resolve().parent.parent / "experiments" / "line.toml"
    bad = _bad(tmp_path, BASE + "[limits]\nbogus = 1\n")
    code, out, err = run(capsys, "check", good, bad, "--jobs", "1")
    assert code == 2 and out == "" and "limits.bogus" in err
