"""The scenario fuzzer: scenarios from (seed, index) alone, inside the envelope, written files that load and run,
what the CLI writes and exits with, and results independent of the number of jobs."""

from __future__ import annotations

import json
import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agvctl.checks.report import TIMING_METRICS
from agvctl.cli import main
from agvctl.evaluation.limits import evaluate_limits
from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.report import FuzzOutcome, FuzzReport, FuzzTask
from agvctl.fuzz.run import fuzz, fuzz_tasks, run_fuzz_task
from agvctl.fuzz.spec import DEFAULT_ENVELOPE, FuzzSpec, StartSpec, load_fuzz_config, nominal_value
from agvctl.params import VehicleParams
from agvctl.planning import load_path
from agvctl.scenario.experiment import load_experiment, run_experiment

ROOT = Path(__file__).resolve().parent.parent
FUZZ = ROOT / "experiments" / "fuzz"


def _config(tmp_path: Path, text: str, name: str = "fuzz.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# -- generation -------------------------------------------------------------------------------------------------


def test_a_scenario_depends_on_seed_and_index_alone(vehicle: VehicleParams) -> None:
    spec = load_fuzz_config(FUZZ / "acceptance.toml")
    alone = fuzz_tasks(spec, [7]).tasks
    among = [t for t in fuzz_tasks(spec, [9, 3, 7]).tasks if t.scenario == 7]
    assert alone == among  # the same files whatever else is drawn, in any order
    assert generate_scenario(spec, vehicle, 7) == generate_scenario(spec, vehicle, 7)
    other_seed = FuzzSpec(seed=spec.seed + 1, scenarios=1, source=spec.source, name=spec.name)
    assert generate_scenario(other_seed, vehicle, 7) != generate_scenario(spec, vehicle, 7)
    assert generate_scenario(spec, vehicle, 8) != generate_scenario(spec, vehicle, 7)


def test_scenarios_stay_within_the_envelope(vehicle: VehicleParams) -> None:
    spec = FuzzSpec(seed=3, scenarios=400)
    p = spec.paths
    top, a_lim = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2
    seen_types, seen_joins, explicit = set(), set(), 0
    for i in range(spec.scenarios):
        s = generate_scenario(spec, vehicle, i)
        segments = s.path["segments"]
        assert p.segments[0] <= len(segments) <= p.segments[1]
        assert any(seg["type"] != "turn" for seg in segments)  # something to follow
        for seg in segments:
            seen_types.add(seg["type"])
            if seg["type"] == "line":
                assert p.line_length_m[0] - 5e-4 <= seg["length_m"] <= p.line_length_m[1] + 5e-4
            elif seg["type"] == "arc":
                assert p.arc_radius_m[0] - 5e-4 <= seg["radius_m"] <= p.arc_radius_m[1] + 5e-4
                assert p.arc_angle_deg[0] - 0.05 <= abs(seg["angle_deg"]) <= p.arc_angle_deg[1] + 0.05
            else:
                assert p.turn_angle_deg[0] - 0.05 <= abs(seg["angle_deg"]) <= p.turn_angle_deg[1] + 0.05
        seen_joins.add(s.path["join"])
        if "limits" in s.path:  # explicit limits: never above the vehicle's physical maxima
            explicit += 1
            lim = s.path["limits"]
            assert p.wheel_speed_fraction[0] * top - 1e-3 <= lim["wheel_speed_m_s"] <= top
            assert p.wheel_accel_fraction[0] * a_lim - 1e-3 <= lim["wheel_accel_m_s2"] <= a_lim
        for key, (lo, hi) in DEFAULT_ENVELOPE.items():
            nominal = nominal_value(vehicle, key)
            assert nominal is not None
            assert nominal * (1 + lo) * (1 - 1e-5) <= s.plant_set[key] <= nominal * (1 + hi) * (1 + 1e-5), key
        for side in ("left", "right"):
            assert s.plant_set[f"motor.{side}.stiction_n_m"] >= s.plant_set[f"motor.{side}.coulomb_friction_n_m"]
        pose = s.initial_pose
        assert math.hypot(pose["x_m"], pose["y_m"]) <= spec.start.offset_max_m + 1e-4
        assert abs(pose["theta_deg"]) <= spec.start.heading_max_deg
        vehicle.with_overrides(list(s.plant_set.items()), source="test")  # a valid vehicle
    assert seen_types == {"line", "arc", "turn"} and seen_joins == {"smooth", "stop"}
    assert 0.35 * spec.scenarios < explicit < 0.65 * spec.scenarios  # about half


def test_a_zero_width_range_written_minus_zero_draws_its_one_value(vehicle: VehicleParams) -> None:
    spec = FuzzSpec(
        seed=1,
        scenarios=1,
        plant={"body.mass_kg": (0.0, -0.0)},
        start=StartSpec(offset_max_m=-0.0, heading_max_deg=-0.0),
    )
    s = generate_scenario(spec, vehicle, 0)
    assert s.plant_set["body.mass_kg"] == pytest.approx(nominal_value(vehicle, "body.mass_kg"), rel=1e-6)
    assert s.initial_pose["x_m"] == s.initial_pose["y_m"] == s.initial_pose["theta_deg"] == 0.0


def test_written_files_load_as_the_scenario(tmp_path: Path, vehicle: VehicleParams) -> None:
    spec = load_fuzz_config(FUZZ / "acceptance.toml")
    for i in range(5):
        s = generate_scenario(spec, vehicle, i)
        files = scenario_files(spec, s, "ramsete")
        for name, text in files.items():
            (tmp_path / name).write_text(text, encoding="utf-8")
        path_file, exp_file = (tmp_path / name for name in files)
        path = load_path(path_file)
        assert len(path.segments) == len(s.path["segments"])
        assert path.join == s.path["join"]
        with warnings.catch_warnings():  # explicit limits may leave little headroom: the planner warns
            warnings.simplefilter("ignore")
            exp = load_experiment(exp_file)
        assert exp.spec.controller.pose == "ramsete"
        assert exp.reference.duration_s > 0
        for key, value in s.plant_set.items():
            assert nominal_value(exp.plant_vehicle, key) == value
        x, y, theta = exp.spec.plant.start_pose() or (0.0, 0.0, 0.0)
        assert (x, y, math.degrees(theta)) == pytest.approx(
            (s.initial_pose["x_m"], s.initial_pose["y_m"], s.initial_pose["theta_deg"])
        )
        assert dict(exp.spec.limits.items()) == dict(spec.limits.items())


def test_a_crash_is_an_outcome_not_an_exception() -> None:
    broken = FuzzTask(0, "s0_00000", "mpc", (("e.toml", 'name = "e"\ntrajectory = "missing.toml"\n'),))
    outcome = run_fuzz_task(broken)
    assert not outcome.passed
    assert outcome.error is not None and "missing.toml" in outcome.error and "\n" not in outcome.error
    assert outcome.reasons == [outcome.error]


# -- statistics -------------------------------------------------------------------------------------------------


def _outcome(scenario: int, controller: str, cross_m: float, rms_m: float) -> FuzzOutcome:
    metrics = {} if math.isnan(cross_m) else {"cross_track_error_max_m": cross_m, "cross_track_error_rms_m": rms_m}
    error = "RuntimeError: boom" if math.isnan(cross_m) else None
    return FuzzOutcome(scenario, controller, error is None, metrics, (), error, (), 0.1, 1.0)


def test_comparison_counts_scenario_by_scenario_with_a_millimetre_tie() -> None:
    spec = FuzzSpec(seed=0, scenarios=6, controllers=("mpc", "ramsete"))
    a = [(0.01, 0.001), (0.02, 0.002), (0.05, 0.003), (0.04, 0.004), (math.nan, math.nan), (0.0209, 0.005)]
    b = [(0.02, 0.010), (0.02, 0.010), (0.03, 0.010), (0.01, 0.010), (0.50, 0.010), (0.0200, 0.010)]
    outcomes = []
    for i, ((xa, ra), (xb, rb)) in enumerate(zip(a, b, strict=True)):
        outcomes += [_outcome(i, "mpc", xa, ra), _outcome(i, "ramsete", xb, rb)]
    tasks = [FuzzTask(o.scenario, f"s0_{o.scenario:05d}", o.controller, ()) for o in outcomes]
    report = FuzzReport(spec, tasks, outcomes, 1.0)
    (cmp,) = report.comparisons()
    # A no worse than B in scenarios 0, 1 and 5 (0.9 mm worse is a tie); A crashed in 4: infinitely far off
    assert cmp["scenarios"] == 6 and cmp["a_cross_track_max_le_b_fraction"] == pytest.approx(3 / 6)
    assert cmp["a_cross_track_max_above_b"] == [2, 3, 4]
    assert cmp["median_rms_ratio"] == pytest.approx(0.003 / 0.010)  # cross-track RMS
    stats = report.statistics()
    assert stats["mpc"]["crashed"] == 1 and stats["mpc"]["runs"] == 6
    assert stats["mpc"]["cross_track_error_max_m"]["max"] == pytest.approx(0.05)
    assert stats["mpc"]["cross_track_error_max_m"]["p50"] == pytest.approx(np.median([0.01, 0.02, 0.05, 0.04, 0.0209]))
    assert report.worst("mpc", 1)[0].scenario == 4  # the crash first


# -- the command line -------------------------------------------------------------------------------------------


def test_an_impossible_criterion_fails_and_writes_a_file_that_reproduces_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _config(
        tmp_path,
        'seed = 5\nscenarios = 2\ncontrollers = ["ramsete"]\nsettle_s = 1.0\n'
        "[paths]\nsegments = [2, 2]\nline_length_m = [0.3, 0.6]\narc_radius_m = [0.3, 0.5]\n"
        "arc_angle_deg = [20.0, 60.0]\n[limits]\ncross_track_error_max_m = 1e-6\n",
    )
    out, junit = tmp_path / "out", tmp_path / "fuzz.xml"
    assert main(["fuzz", str(config), "--jobs", "1", "--out", str(out), "--junit", str(junit)]) == 1
    printed = capsys.readouterr().out
    assert "FAIL  ramsete: 0 of 2 passed" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["passed"] is False and len(summary["runs"]) == 2
    assert summary["statistics"]["ramsete"]["failed"] == 2
    assert (out / "fuzz.png").stat().st_size > 1000
    root = ET.parse(junit).getroot()
    assert (root.get("tests"), root.get("failures"), root.get("errors")) == ("2", "2", "0")
    row = summary["runs"][0]
    failing = out / "failures" / row["experiment_file"]
    assert failing.exists()
    # the written file, run as a user would, gives the same verdict and the same value
    with warnings.catch_warnings():  # explicit limits may leave little headroom: the planner warns
        warnings.simplefilter("ignore")
        assert main(["run", str(failing), "--no-plot", "--out", str(tmp_path / "rerun")]) == 0
    rerun = json.loads((tmp_path / "rerun" / "summary.json").read_text())
    assert rerun["passed"] is False
    assert rerun["metrics"]["cross_track_error_max_m"] == row["metrics"]["cross_track_error_max_m"]


def test_help_and_only_some_scenarios(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fuzz", "--help"]) == 0
    assert "--jobs" in capsys.readouterr().out
    config = _config(tmp_path, 'seed = 4\nscenarios = 100\ncontrollers = ["ramsete"]\nsettle_s = 0.5\n')
    out = tmp_path / "out"
    main(["fuzz", str(config), "--only", "17", "--jobs", "1", "--out", str(out), "--no-plot"])
    rows = json.loads((out / "summary.json").read_text())["runs"]
    assert [(r["scenario"], r["name"]) for r in rows] == [(17, "s4_00017")]
    assert main(["fuzz", str(config), "--only", "x", "--out", str(out)]) == 2
    assert "--only" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('seed = 1\nscenarioz = 3\ncontrollers = ["mpc"]\n', "scenarioz"),
        ('scenarios = 3\ncontrollers = ["mpc"]\n', "seed"),
        ('seed = 1\nscenarios = 3\ncontrollers = ["mpc", "nope"]\n', "controllers[1]"),
        ('seed = 1\nscenarios = 3\n[plant]\n"body.mass_kg" = [0.3, -0.1]\n', "plant.body.mass_kg"),
        ('seed = 1\nscenarios = 3\n[plant]\n"body.mass_kgg" = [0.0, 0.1]\n', "plant.body.mass_kgg"),
        (
            'seed = 1\nscenarios = 3\n[plant]\n"wheels.radius_left_m" = [0.0, 0.1]\n',
            "plant.wheels.radius_left_m: renamed; use wheels.left.radius_m",
        ),
        ("seed = 1\nscenarios = 3\n[paths]\nsegments = [0, 3]\n", "paths.segments"),
        ('seed = 1\nscenarios = 3\n[paths]\nsegment_types = ["line", "spiral"]\n', "paths.segment_types[1]"),
        ("seed = 1\nscenarios = 3\n[limits]\ncross_track_eror_max_m = 0.1\n", "limits.cross_track_eror_max_m"),
        ('seed = 1\nscenarios = 3\ncontrollers = ["ramsete"]\n[controller]\nhorizon = 20\n', "controller.horizon"),
        ('seed = 1\nscenarios = 3\nname = "../up"\n', "name: must be a plain name"),
        ("seed = 1\nscenarios = 3\n[start]\noffset_max_m = -0.1\n", "start.offset_max_m"),
    ],
)
def test_bad_config_is_one_line_naming_file_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, key: str
) -> None:
    config = _config(tmp_path, text)
    assert main(["fuzz", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(config) in err[0] and key in err[0], err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_results_do_not_depend_on_the_number_of_jobs_or_the_executor() -> None:
    from dask.distributed import Client, LocalCluster

    spec = load_fuzz_config(FUZZ / "ci.toml")
    serial = fuzz(spec, jobs=1, scenarios=[0, 1, 2])
    parallel = fuzz(spec, jobs=2, scenarios=[2, 0, 1])
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster,
        Client(cluster),
    ):
        on_dask = fuzz(spec, executor="dask", scheduler=cluster.scheduler_address, scenarios=[0, 1, 2])

    def physical(report: FuzzReport) -> dict[int, tuple[object, ...]]:
        return {
            o.scenario: (
                o.controller,
                o.passed,
                o.error,
                {k: v for k, v in o.metrics.items() if k not in TIMING_METRICS},
            )
            for o in report.outcomes
        }

    assert physical(serial) == physical(parallel) == physical(on_dask)
    assert len({o.metrics["cross_track_error_max_m"] for o in serial.outcomes}) == 3  # three different scenarios


@pytest.fixture(scope="module")
def ci_fuzz(tmp_path_factory: pytest.TempPathFactory) -> tuple[int, dict[str, Any]]:
    out = tmp_path_factory.mktemp("ci_fuzz")
    code = main(["fuzz", str(FUZZ / "ci.toml"), "--jobs", "2", "--out", str(out), "--no-plot"])
    return code, json.loads((out / "summary.json").read_text())


@pytest.mark.slow
def test_the_ci_fuzz_never_crashes_loses_the_end_or_turns_around(ci_fuzz: tuple[int, dict[str, Any]]) -> None:
    """Every CI scenario, read back from the summary: a finite run that ends within 1 cm of the path's end and
    never heads more than 90° from the path (the next test is the command's own verdict, cross-track included)."""
    _, summary = ci_fuzz
    for run in summary["runs"]:
        assert run["error"] is None, (run["experiment_file"], run["error"])
        m = run["metrics"]
        assert m["final_position_error_m"] <= 0.01 and m["path_heading_error_max_deg"] <= 90.0, run["experiment_file"]


@pytest.mark.slow
def test_the_ci_fuzz_configuration_passes(ci_fuzz: tuple[int, dict[str, Any]]) -> None:
    code, summary = ci_fuzz
    failing = [(r["experiment_file"], r["reasons"]) for r in summary["runs"] if not r["passed"]]
    assert code == 0, failing


REGRESSIONS = sorted((FUZZ / "regressions").glob("*_mpc.toml"))


@pytest.mark.slow
@pytest.mark.parametrize("path", REGRESSIONS, ids=[p.stem for p in REGRESSIONS])
def test_kept_generated_cases_pass_their_limits(path: Path) -> None:
    with warnings.catch_warnings():  # a generated path may plan with little headroom: warned, as the fuzzer records
        warnings.simplefilter("ignore")
        exp = load_experiment(path)
    result = run_experiment(exp)
    verdicts = evaluate_limits(exp.spec.limits, result.log, exp.controller_vehicle, result.sample_period_s)
    assert all(v.passed for v in verdicts if not v.default), [v.message for v in verdicts if not v.passed]
