"""The falsification search: proposals inside the fuzz envelope, the same runs for a seed whatever the number of
jobs and after a resume, and what the command writes and exits with."""

from __future__ import annotations

import json
import math
from pathlib import Path

import optuna
import pytest

from agvctl.cli import main
from agvctl.falsify import TrialDraws, falsify
from agvctl.fuzz.generate import RandomDraws, draw_scenario, generate_scenario
from agvctl.fuzz.spec import FuzzSpec, load_fuzz_config
from agvctl.params import VehicleParams

SHORT = """
seed = 3
scenarios = 10
controllers = ["mpc"]
settle_s = 2.0

[paths]
segments = [1, 2]
segment_types = ["line", "turn"]
line_length_m = [0.2, 0.4]
turn_angle_deg = [20.0, 60.0]

[start]
offset_max_m = 0.01
heading_max_deg = 1.0
"""
"""Short paths (a few seconds simulated each) from a start close to the path, so a run takes a fraction of a
second and passes the default gate."""


def _config(tmp_path: Path, text: str = SHORT, name: str = "short.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_random_draws_give_the_fuzz_scenarios(vehicle: VehicleParams) -> None:
    import numpy as np

    spec = FuzzSpec(seed=5, scenarios=20)
    for i in range(20):
        drawn = draw_scenario(spec, vehicle, RandomDraws(np.random.default_rng([5, i])), i)
        assert drawn == generate_scenario(spec, vehicle, i)


def test_proposals_stay_within_the_envelope_and_cover_its_discrete_structure(vehicle: VehicleParams) -> None:
    spec = FuzzSpec(seed=1, scenarios=1)
    p = spec.paths
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=0))
    counts, kinds = set(), set()
    for i in range(60):
        trial = study.ask()
        s = draw_scenario(spec, vehicle, TrialDraws(trial), i, prefix="search")
        segments = s.path["segments"]
        assert p.segments[0] <= len(segments) <= p.segments[1]
        assert any(seg["type"] != "turn" for seg in segments)
        assert trial.params["segments"] == len(segments)
        counts.add(len(segments))
        kinds.update(seg["type"] for seg in segments)
        for seg in segments:
            if seg["type"] == "line":
                assert p.line_length_m[0] - 1e-3 <= seg["length_m"] <= p.line_length_m[1] + 1e-3
            else:
                bounds = p.arc_angle_deg if seg["type"] == "arc" else p.turn_angle_deg
                assert bounds[0] - 0.05 <= abs(seg["angle_deg"]) <= bounds[1] + 0.05
        offset = math.hypot(s.initial_pose["x_m"], s.initial_pose["y_m"])
        assert offset <= spec.start.offset_max_m + 1e-4
        assert abs(s.initial_pose["theta_deg"]) <= spec.start.heading_max_deg + 0.01
        assert s.name == f"search1_{i:05d}"
        study.tell(trial, 0.0)
    assert counts == set(range(p.segments[0], p.segments[1] + 1))
    assert kinds == {"line", "arc", "turn"}


@pytest.fixture(scope="module")
def short_spec(tmp_path_factory: pytest.TempPathFactory) -> FuzzSpec:
    return load_fuzz_config(_config(tmp_path_factory.mktemp("short")))


def _trace(result: object) -> list[tuple[dict[str, object], float]]:
    return [(r.params, r.margin) for r in result.runs]  # type: ignore[attr-defined]


def test_a_search_is_the_same_for_any_number_of_jobs_and_after_a_resume(short_spec: FuzzSpec, tmp_path: Path) -> None:
    one = falsify(short_spec, budget_runs=4, batch=2, seed=7, jobs=1)
    two = falsify(short_spec, budget_runs=4, batch=2, seed=7, jobs=2)
    assert len(one.runs) == 4
    assert _trace(one) == _trace(two)
    journal = tmp_path / "search.journal"
    first = falsify(short_spec, budget_runs=2, batch=2, seed=7, jobs=1, storage=journal)
    resumed = falsify(short_spec, budget_runs=4, batch=2, seed=7, jobs=1, storage=journal)
    assert (first.resumed, resumed.resumed) == (0, 2)
    assert _trace(resumed) == _trace(one)
    other = falsify(short_spec, budget_runs=2, batch=2, seed=8, jobs=1)
    assert _trace(other) != _trace(one)[:2]
    assert all(r.margin > 0 and r.error is None for r in one.runs)


def test_a_falsified_limit_exits_1_with_a_regression_experiment_that_check_reproduces(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    config = _config(tmp_path, SHORT + "\n[limits]\ncross_track_error_max_m = 0.0001\n")
    out = tmp_path / "out"
    assert main(["falsify", str(config), "--budget", "3", "--batch", "1", "--jobs", "1", "--out", str(out)]) == 1
    report = json.loads((out / "report.json").read_text())
    assert report["falsified"] and report["first_falsifying_run"] == 0 and report["runs"] == 1  # stops at once
    assert report["worst"]["binding"] == "cross_track_error_max_m"
    assert report["min_normalised_margin"] < 0
    assert (out / "search.png").stat().st_size > 0 and (out / "search.journal").is_file()
    [regression] = [p for p in (out / "falsified").glob("*.toml") if not p.name.endswith(".path.toml")]
    assert main(["check", str(regression), "--jobs", "1"]) == 1


def test_nothing_falsified_exits_0(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code = main(["falsify", str(_config(tmp_path)), "--budget", "2", "--batch", "2", "--jobs", "1", "--out", str(out)])
    assert code == 0
    report = json.loads((out / "report.json").read_text())
    assert not report["falsified"] and report["min_normalised_margin"] > 0
    assert len(list((out / "worst").glob("*.toml"))) == 2


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--budget", "0"], "--budget"),
        (["--batch", "0"], "--batch"),
        (["--seed", "-1"], "--seed"),
        (["--controller", "nope"], "controllers[0]"),
    ],
)
def test_bad_options_exit_2_in_one_line_and_write_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], named: str
) -> None:
    out = tmp_path / "out"
    assert main(["falsify", str(_config(tmp_path)), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and named in err[0]
    assert not out.exists()


def test_a_bad_key_in_the_file_exits_2_naming_file_and_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = _config(tmp_path, SHORT.replace("[start]", "[start]\noffset_max = 0.01"))
    assert main(["falsify", str(config), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert "short.toml" in err and "start.offset_max" in err and "\n" not in err


def test_a_folder_of_the_users_is_refused_and_kept(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    assert main(["falsify", str(_config(tmp_path)), "--budget", "1", "--out", str(out)]) == 2
    assert (out / "notes.txt").read_text() == "keep me" and sorted(p.name for p in out.iterdir()) == ["notes.txt"]
    assert "--out" in capsys.readouterr().err


def test_local_moves_start_from_the_runs_closest_to_failing_each_of_the_verdicts_closest_to_failing() -> None:
    from agvctl.falsify.proposals import LOCAL_CENTRES, LOCAL_VERDICTS, _centres

    # Verdict "a" binds every run (margins 0.1-0.3); "b" comes as close as 0.4 in runs that "a" ranks last, "c"
    # to 0.6, "d" never below 0.9: the smallest margin of a run hides how close "b" and "c" come.
    study = optuna.create_study()
    x = optuna.distributions.FloatDistribution(0.0, 1.0)
    for i in range(12):
        verdicts = [
            {"name": "a", "normalised_margin": 0.1 + 0.2 * i / 11},
            {"name": "b", "normalised_margin": 0.4 + 0.1 * (11 - i)},
            {"name": "c", "normalised_margin": 0.6 + 0.01 * abs(i - 5)},
            {"name": "d", "normalised_margin": 0.9},
            {"name": "solve_time_p99_ms", "normalised_margin": -1.0},
        ]
        value = min(v["normalised_margin"] for v in verdicts[:4])
        study.add_trial(
            optuna.trial.create_trial(
                params={"x": i / 11}, distributions={"x": x}, value=value, user_attrs={"verdicts": verdicts}
            )
        )
    complete = study.get_trials(deepcopy=False)
    groups = [[t.number for t in g] for g in _centres(complete, None)]
    assert LOCAL_VERDICTS == 3 and LOCAL_CENTRES == 3
    assert groups == [[0, 1, 2], [11, 10, 9], [5, 4, 6]]
    assert [[t.number for t in g] for g in _centres(complete, "c")] == [[5, 4, 6]]


def test_the_html_page_names_each_verdict_embeds_the_search_and_reproduces_the_worst_scenario(
    tmp_path: Path,
) -> None:
    from html_pages import png_size, read_page

    config = _config(tmp_path, SHORT + "\n[limits]\ncross_track_error_max_m = 0.0001\n")
    out, html = tmp_path / "out", tmp_path / "page" / "search.html"
    argv = ["falsify", str(config), "--budget", "4", "--batch", "2", "--jobs", "1", "--out", str(out)]
    assert main([*argv, "--html", str(html)]) == 1
    report = json.loads((out / "report.json").read_text())
    page = read_page(html.read_text(encoding="utf-8"))
    assert "FALSIFIED" in page.text and "exit 1" in page.text
    rows = {r[0]: r for r in page.tables["margins-table"][1:]}
    assert {v["name"] for v in report["worst"]["verdicts"]} <= set(rows)
    assert float(rows["cross_track_error_max_m"][2]) == pytest.approx(report["min_normalised_margin"], rel=1e-3)
    assert int(rows["cross_track_error_max_m"][3]) == report["worst"]["run"]
    assert page.scripts == 0 and len(page.images) == 1
    assert min(png_size(page.images[0])) > 100
    worst = next(p for p in (out / "worst").glob("*.toml") if not p.name.endswith(".path.toml"))
    assert f"agvctl check {worst.as_posix()}" in page.text
    for name, value in report["worst"]["params"].items():  # the worst scenario's parameters
        assert name in page.text and (str(value) if not isinstance(value, float) else "") in page.text
    assert (out / "falsified").is_dir() and f"{(out / 'falsified').as_posix()}/" in page.text


def test_an_html_path_that_cannot_be_written_stops_the_search_before_it_runs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _config(tmp_path)
    (tmp_path / "adir").mkdir()
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    out = tmp_path / "out"
    assert main(["falsify", str(config), "--out", str(out), "--html", str(tmp_path / "adir")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("agvctl: --html: ") and "is a directory" in err[0]
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before  # nothing written, no folder
