"""Requirements a user writes: the shipped experiment's four, kept by the healthy run with a margin and each broken
by a controller built to break it; bad formulas are one-line errors; limits are judged by the same formulas."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.cli import main
from agvctl.evaluation.limits import LIMITS, judge_run
from agvctl.scenario.experiment import load_experiment, run_experiment

ROOT = Path(__file__).resolve().parents[1]
EXPERIMENT = ROOT / "experiments" / "requirements.toml"
FAULTS = Path(__file__).resolve().parent / "requirement_faults.py"


def _judged(path: Path):
    experiment = load_experiment(path)
    result = run_experiment(experiment)
    verdict = judge_run(result, experiment.spec.limits, experiment.controller_vehicle, experiment.spec.requirements)
    return result, {r.limit: r for r in verdict.limits}


def _with(tmp_path: Path, **replace: str) -> Path:
    text = EXPERIMENT.read_text(encoding="utf-8").replace(
        'trajectory = "../trajectories/dock.toml"', f'trajectory = "{ROOT / "trajectories" / "dock.toml"}"'
    )
    for old, new in replace.items():
        text = text.replace(old, new)
    path = tmp_path / "requirements.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def healthy():
    return _judged(EXPERIMENT)


REQUIREMENTS = ("settles_within_3_s", "slow_on_the_dock", "turns_on_the_pivot", "wheels_track_their_setpoints")


@pytest.mark.parametrize("name", REQUIREMENTS)
def test_the_healthy_run_keeps_each_shipped_requirement_with_a_margin(healthy, name):
    result, verdicts = healthy
    r = verdicts[name]
    assert r.kind == "requirement" and r.passed and 0 < r.margin < math.inf, r.message
    assert r.window_s is not None and r.window_s[0] <= r.worst_time_s <= r.window_s[1]
    assert r.note == ""


def test_settling_is_judged_from_the_reference_end(healthy):
    result, verdicts = healthy
    r = verdicts["settles_within_3_s"]
    assert r.window_s[0] == pytest.approx(result.reference.duration_s, abs=result.sample_period_s)
    # the margin is the bound less the error at the deciding sample, which lies in the window
    k = int(np.argmin(np.abs(result.log["t_s"] - r.worst_time_s)))
    assert r.margin == pytest.approx(0.005 - result.log["position_error_m"][k])


@pytest.mark.parametrize(
    ("fault", "broken"),
    [
        ("Offset", "settles_within_3_s"),
        ("Late", "slow_on_the_dock"),
        ("Offset", "turns_on_the_pivot"),
        ("Dither", "wheels_track_their_setpoints"),
    ],
)
def test_a_controller_built_to_break_a_requirement_breaks_it_with_a_negative_margin(tmp_path, fault, broken):
    path = _with(tmp_path, **{'pose = "mpc"': f'pose = "{FAULTS}:{fault}"'})
    _, verdicts = _judged(path)
    r = verdicts[broken]
    assert not r.passed and r.margin < 0, r.message
    assert "BROKEN" in r.message and f"margin {r.margin:+.6g}" in r.message


def test_a_limit_on_the_worst_sample_is_judged_as_always_signal_within_its_bound(healthy):
    result, verdicts = healthy
    r = verdicts["cross_track_error_max_m"]
    assert r.formula == "always abs(cross_track_error_m) <= 0.1"
    assert r.margin == pytest.approx(r.bound - r.value, abs=1e-15)
    cross = np.abs(result.log["cross_track_error_m"])
    assert r.worst_time_s == result.log["t_s"][int(np.argmax(cross))]
    assert r.window_s == (0.0, float(result.log["t_s"][-1]))
    final = verdicts["final_position_error_m"]
    assert final.worst_time_s == final.window_s[0] == final.window_s[1] == result.log["t_s"][-1]
    assert set(LIMITS) >= {k for k, v in verdicts.items() if v.kind == "limit"}


def test_a_part_the_path_has_not_breaks_the_requirement_and_says_so(tmp_path):
    path = _with(tmp_path, **{"on_segment(-1)": "on_segment(7)"})
    _, verdicts = _judged(path)
    r = verdicts["slow_on_the_dock"]
    assert not r.passed and math.isnan(r.margin) and "the path has 4 segments" in r.message


def test_a_condition_that_never_holds_keeps_the_requirement_vacuously(tmp_path):
    path = _with(tmp_path, **{"turning_in_place ->": "turning_in_place and after_reference_end ->"})
    _, verdicts = _judged(path)
    r = verdicts["turns_on_the_pivot"]
    assert r.passed and r.margin == math.inf and "vacuously" in r.message


@pytest.mark.parametrize(
    ("old", "new", "says"),
    [
        ("position_error_m <= 0.005", "position_error_m <= ", "requirements[0].formula: expected a number"),
        ("abs(speed_m_s)", "abs(sped_m_s)", "requirements[1].formula: unknown signal 'sped_m_s'"),
        ("turning_in_place", "turning_in_plac", "requirements[2].formula: unknown signal or part 'turning_in_plac'"),
        ('anchor = "reference_end"', 'anchor = "end"', "requirements[0].anchor: must be one of"),
        ('name = "slow_on_the_dock"', 'name = "settles_within_3_s"', "requirements[1].name:"),
    ],
)
def test_a_bad_requirement_is_one_line_naming_the_file_and_key(tmp_path, capsys, old, new, says):
    path = _with(tmp_path, **{old: new})
    code = main(["run", str(path), "--no-plot", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and str(path) in err and says in err, err
    assert not (tmp_path / "out").exists()


def test_every_output_of_check_gives_each_verdict_its_margin(tmp_path, capsys):
    import json
    import xml.etree.ElementTree as ET

    out = {k: tmp_path / f"c.{k}" for k in ("json", "xml", "html")}
    argv = ["check", str(EXPERIMENT), "--jobs", "1", "--margins", "3"]
    argv += ["--json", str(out["json"]), "--junit", str(out["xml"]), "--html", str(out["html"])]
    assert main(argv) == 0
    text = capsys.readouterr().out
    (exp,) = json.loads(out["json"].read_text())["experiments"]
    verdicts = {v["limit"]: v for v in exp["limits"]}
    assert set(REQUIREMENTS) <= set(verdicts)
    for v in verdicts.values():
        assert v["margin"] > 0 and len(v["window_s"]) == 2 and v["window_s"][0] <= v["window_s"][1], v
        assert f"margin {v['margin']:+.6g}" in v["message"]
    assert exp["min_normalised_margin"] == min(v["normalised_margin"] for v in verdicts.values())
    cases = ET.parse(out["xml"]).getroot().iter("testcase")
    properties = {c.get("name"): {p.get("name"): p.get("value") for p in c.iter("property")} for c in cases}
    for name, v in verdicts.items():
        assert float(properties[name]["margin"]) == pytest.approx(v["margin"], rel=1e-5)
        assert float(properties[name]["window_end_s"]) == pytest.approx(v["window_s"][1], rel=1e-5)
    page = out["html"].read_text()
    assert all(name in page for name in REQUIREMENTS) and "margin / bound" in page
    # --margins: the three verdicts with the smallest margin over bound, the smallest first
    after = text[text.index("closest to failing") :].splitlines()[1:]
    listed = after[: next((k for k, line in enumerate(after) if not line.startswith("  ")), len(after))]
    ranked = sorted(verdicts.values(), key=lambda v: v["normalised_margin"])[:3]
    assert [line.split()[2].rstrip(":") for line in listed] == [v["limit"] for v in ranked]


def test_run_writes_the_smallest_normalised_margin_into_the_summary(tmp_path):
    import json

    assert main(["run", str(EXPERIMENT), "--no-plot", "--out", str(tmp_path / "out")]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    kinds = {v["kind"] for v in summary["limits"]}
    assert kinds == {"limit", "requirement"}
    assert summary["min_normalised_margin"] == min(v["normalised_margin"] for v in summary["limits"]) > 0


def test_a_fuzz_file_carries_its_requirements_into_every_run_and_refuses_a_bad_one(tmp_path, capsys):
    import json

    text = (
        'seed = 3\nscenarios = 2\ncontrollers = ["mpc"]\nsettle_s = 1.0\n'
        '[[requirements]]\nname = "near_the_path"\nformula = "always abs(cross_track_error_m) <= 0.5"\n'
    )
    config = tmp_path / "f.toml"
    config.write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["fuzz", str(config), "--jobs", "1", "--out", str(out), "--no-plot"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["requirements"][0]["name"] == "near_the_path"
    assert all(r["min_normalised_margin"] > 0 for r in summary["runs"])
    capsys.readouterr()
    config.write_text(text.replace("<= 0.5", "<= 0.5 and"), encoding="utf-8")
    assert main(["fuzz", str(config), "--out", str(tmp_path / "out2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(config) in err[0] and "requirements[0].formula" in err[0], err
