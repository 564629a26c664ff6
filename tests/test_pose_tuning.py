"""Tuning a pose controller over a fuzz distribution: the search space and its errors, the objective, determinism,
resuming, the validation guard, and the settings file as experiments and fuzz files take it."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import matplotlib
import pytest
from cli_runs import one_line, run

from agvctl.errors import ConfigError
from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.report import FuzzOutcome
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment
from agvctl.scenario.pose_settings import load_pose_settings
from agvctl.tuning import ObjectiveWeights, evaluate_objective, search_space, settings_text, tune_pose
from agvctl.tuning.space import settings_table

pytest.importorskip("optuna")

SMALL = """\
seed = 3
scenarios = 4
controllers = ["ramsete"]
settle_s = 2.0
[paths]
segments = [1, 2]
segment_types = ["line", "arc"]
line_length_m = [0.3, 0.8]
arc_radius_m = [0.5, 1.0]
arc_angle_deg = [20.0, 60.0]
"""


def small(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "small.toml"
    path.write_text(SMALL + extra, encoding="utf-8")
    return path


def outcome(passed: bool, peak_m: float, rms_m: float, done_s: float = 5.0) -> FuzzOutcome:
    metrics = {
        "cross_track_error_max_joined_m": peak_m,
        "cross_track_error_rms_m": rms_m,
        "completion_time_s": done_s,
        "reference_duration_s": 5.0,
    }
    return FuzzOutcome(0, "mpc", passed, metrics, (), None, (), 0.0, 0.0)


def test_the_objective_puts_one_failed_run_above_centimetres_of_tracking():
    weights = ObjectiveWeights()
    clean = [outcome(True, 0.01, 0.005) for _ in range(40)]
    one_failed = [outcome(False, 0.01, 0.005), *clean[1:]]
    sloppier = [outcome(True, 0.03, 0.005) for _ in range(40)]
    j_clean, j_failed, j_sloppy = (evaluate_objective(o, weights).value for o in (clean, one_failed, sloppier))
    assert j_failed - j_clean == pytest.approx(100.0 / 40)
    assert j_sloppy - j_clean == pytest.approx(2.0)  # 2 cm more p90 at 1 per cm
    assert j_failed > j_sloppy
    late = [outcome(True, 0.01, 0.005, done_s=5.5) for _ in range(40)]
    assert evaluate_objective(late, weights).value - j_clean == pytest.approx(0.1)  # 10 % later


def test_a_run_that_never_reaches_the_end_counts_as_three_times_the_reference():
    value = evaluate_objective([outcome(True, 0.01, 0.005, done_s=math.inf)], ObjectiveWeights(0, 0, 0, 1))
    assert value.time_ratio == 3.0 and value.value == pytest.approx(2.0)


def test_the_default_spaces_lie_inside_every_settings_validity():
    for controller in ("mpc", "nmpc", "ramsete", "ltv_lqr"):
        space = search_space(controller, None, source="f.toml")
        assert space.params and all(p.low < p.high for p in space.params)


@pytest.mark.parametrize(
    ("table", "key", "problem"),
    [
        ('"no_such_gain" = [1.0, 2.0]', "search.ramsete.no_such_gain", "not a setting"),
        ("zeta = [0.5, 1.5]", "search.ramsete.zeta", "validity: high must be <= 1"),
        ("b_rad2_m2 = [0.0, 2.0]", "search.ramsete.b_rad2_m2", "validity: low must be > 0"),
        ("zeta = [0.8, 0.8]", "search.ramsete.zeta", "empty range"),
        ("zeta = { low = 0.0, high = 0.9, log = true }", "search.ramsete.zeta", "log range must be above 0"),
        ('zeta = ["a", 1.0]', "search.ramsete.zeta", "finite numbers"),
    ],
)
def test_a_bad_search_space_is_one_line_naming_the_file_and_key_and_writes_nothing(
    tmp_path, capsys, table, key, problem
):
    path = small(tmp_path, f"[search.ramsete]\n{table}\n")
    study = tmp_path / "study"
    code, out, err = run(capsys, "tune", "--pose", path, "--trials", 2, "--study", study)
    assert code == 2
    one_line(err, str(path), key, problem)
    assert not study.exists()


def test_a_setting_that_is_not_a_number_cannot_be_searched(tmp_path):
    with pytest.raises(ConfigError, match="search.mpc.prediction_model: not a numeric setting"):
        search_space("mpc", {"mpc": {"prediction_model": [0, 1]}}, source="f.toml")


def test_a_controller_without_settings_cannot_be_tuned(tmp_path, capsys):
    code, _out, err = run(capsys, "tune", "--pose", small(tmp_path), "--controller", "none", "--study", tmp_path / "s")
    assert code == 2
    one_line(err, "has no settings to tune")


def test_without_optuna_the_command_names_the_extra(tmp_path, capsys, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_optuna(name, *args, **kwargs):
        if name == "optuna" or name.startswith("optuna."):
            raise ImportError(name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_optuna)
    code, _out, err = run(capsys, "tune", "--pose", small(tmp_path), "--trials", 2, "--study", tmp_path / "s")
    assert code == 2
    one_line(err, "pip install 'agvctl[tune]'")


def test_pi_design_options_are_refused_with_pose(tmp_path, capsys):
    code, _out, err = run(capsys, "tune", "--pose", small(tmp_path), "--plot", tmp_path / "p")
    assert code == 2
    one_line(err, "--plot", "not with --pose")
    code, _out, err = run(capsys, "tune", "--trials", 3, "--controller", "mpc")
    assert code == 2
    one_line(err, "--controller", "only with --pose")


@pytest.fixture(scope="module")
def searched(tmp_path_factory):
    """One small search of Ramsete, in a study file."""
    folder = tmp_path_factory.mktemp("search")
    spec = load_fuzz_config(small(folder))
    result = tune_pose(spec, trials=6, validation_scenarios=4, jobs=1, storage=folder / "study.db")
    return folder, spec, result


def test_the_same_seed_finds_the_same_best_settings_whatever_the_jobs(searched):
    _folder, spec, first = searched
    again = tune_pose(spec, trials=6, validation_scenarios=4, jobs=2)
    assert again.best_values == first.best_values
    assert again.validation == first.validation


def test_the_first_trial_of_a_new_study_is_the_defaults(searched):
    _folder, _spec, result = searched
    assert result.study.trials[0].params == {"b_rad2_m2": 2.0, "zeta": 0.7}


def test_a_resumed_study_keeps_its_trials_and_continues(searched, tmp_path):
    folder, spec, result = searched
    before = [(t.params, t.value) for t in result.study.trials]
    resumed = tune_pose(spec, trials=8, validation_scenarios=4, jobs=1, storage=folder / "study.db")
    assert len(resumed.study.trials) == 8
    assert [(t.params, t.value) for t in resumed.study.trials[:6]] == before
    assert resumed.study.trials[6].params not in [p for p, _v in before]  # draws on, not the same again


def test_a_study_file_of_another_setup_is_refused(searched):
    folder, spec, _result = searched
    with pytest.raises(ConfigError, match="--study: .*another setup"):
        tune_pose(dataclasses.replace(spec, scenarios=3), trials=2, validation_scenarios=2, storage=folder / "study.db")


def test_the_result_is_never_worse_than_the_defaults_on_validation(searched):
    _folder, _spec, result = searched
    v = result.validation
    assert v.seed != result.spec.seed
    if v.kept:
        assert v.tuned.value < v.defaults.value and v.tuned.passed >= v.defaults.passed
        assert result.settings == settings_table(result.best_values)
    else:
        assert result.settings == {}


def test_an_experiment_takes_the_settings_file_and_its_own_keys_win(searched, tmp_path):
    _folder, spec, _result = searched
    (tmp_path / "tuned.toml").write_text('pose = "ramsete"\nb_rad2_m2 = 7.5\nzeta = 0.5\n', encoding="utf-8")
    scenario = generate_scenario(spec, load_vehicle(), 0)
    files = scenario_files(spec, scenario, "ramsete")
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    experiment_path = tmp_path / list(files)[-1]
    text = experiment_path.read_text(encoding="utf-8").replace(
        'pose = "ramsete"', 'pose = "ramsete"\npose_settings = "tuned.toml"\nzeta = 0.9'
    )
    experiment_path.write_text(text, encoding="utf-8")
    config = load_experiment(experiment_path).spec.controller.pose_settings
    assert (config.b_rad2_m2, config.zeta) == (7.5, 0.9)


def test_the_settings_file_written_holds_the_kept_settings(searched, tmp_path):
    _folder, _spec, result = searched
    (tmp_path / "tuned.toml").write_text(settings_text(result), encoding="utf-8")
    keys = load_pose_settings(tmp_path / "tuned.toml", "ramsete", source="test", key="pose_settings")
    assert keys == result.settings


def test_a_settings_file_of_another_controller_is_refused(tmp_path):
    (tmp_path / "tuned.toml").write_text('pose = "mpc"\nhorizon = 12\n', encoding="utf-8")
    path = small(tmp_path, '[pose_settings]\nramsete = "tuned.toml"\n')
    with pytest.raises(ConfigError, match=r"tuned.toml: pose: settings of 'mpc', used with pose = 'ramsete'"):
        load_fuzz_config(path)


def test_a_fuzz_file_runs_a_controller_with_its_settings_file(tmp_path):
    (tmp_path / "tuned.toml").write_text("b_rad2_m2 = 9.0\n", encoding="utf-8")
    spec = load_fuzz_config(small(tmp_path, '[pose_settings]\nramsete = "tuned.toml"\n'))
    files = scenario_files(spec, generate_scenario(spec, load_vehicle(), 1), "ramsete")
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    assert load_experiment(tmp_path / list(files)[-1]).spec.controller.pose_settings.b_rad2_m2 == 9.0


def test_the_command_writes_the_settings_file_the_report_and_the_figures(tmp_path, capsys, monkeypatch):
    study = tmp_path / "study"
    (tmp_path / "fuzz").mkdir()
    monkeypatch.chdir(tmp_path)  # the settings file named from the working directory, the fuzz file in a folder
    style = dict(matplotlib.rcParams)
    code, out, _err = run(
        capsys, "tune", "--pose", small(tmp_path / "fuzz"), "--trials", 3, "--validation-scenarios", 2, "--jobs", 1,
        "--study", study, "--out", "tuned.toml",
    )  # fmt: skip
    assert code == 0, out
    # the path suggested for the fuzz file is read from the fuzz file's folder, the one for an experiment anywhere
    hint = next(line for line in out.splitlines() if line.startswith("use it:"))
    from_fuzz_file, for_experiment = hint.split('"')[1], hint.split('"')[3]
    assert (tmp_path / "fuzz" / from_fuzz_file).resolve() == (tmp_path / "tuned.toml").resolve()
    assert Path(for_experiment).is_absolute() and Path(for_experiment).resolve() == (tmp_path / "tuned.toml").resolve()
    finished = int(out.split(" trials (")[1].split()[0])
    if "importance:" in out:  # importances from at most three trials come with their caveat
        assert f"from {finished} finished trials: too few to rank the settings" in out, out
    assert "validation: 2 scenarios of seed 4" in out
    text = (tmp_path / "tuned.toml").read_text(encoding="utf-8")
    assert text.startswith("# Settings of the 'ramsete' pose controller") and 'pose = "ramsete"' in text
    report = json.loads((study / "report.json").read_text(encoding="utf-8"))
    assert report["trials"]["complete"] + report["trials"]["pruned"] == 3
    assert (study / "history.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert dict(matplotlib.rcParams) == style  # Optuna's plots set a style of their own: the user's is kept
