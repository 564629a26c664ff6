"""What CI tools read from ``agvctl check``: the JUnit XML counts and failures, and the worst Monte Carlo sample."""

import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from agvctl.checks.report import RunOutcome, RunTask, worst_run_verdicts
from agvctl.cli import main
from agvctl.evaluation.limits import LimitResult

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "tests" / "data"
EXPERIMENTS = [DATA / "line_impossible.toml", DATA / "line_mc_impossible.toml", ROOT / "experiments" / "line.toml"]


@pytest.fixture(scope="module")
def checked(tmp_path_factory):
    """One ``agvctl check`` of a failing nominal run, a failing Monte Carlo and a passing run: exit code, XML, JSON."""
    out = tmp_path_factory.mktemp("check")
    junit, js = out / "report.xml", out / "report.json"
    argv = ["check", *EXPERIMENTS, "--junit", junit, "--json", js, "--jobs", "1", "--report-dir", out / "hist"]
    code = main([str(a) for a in argv])
    return code, ET.parse(junit).getroot(), json.loads(js.read_text())


def _count(cases, tag):
    return sum(c.find(tag) is not None for c in cases)


def test_junit_counts_are_those_of_the_test_cases(checked):
    code, root, _ = checked
    assert code == 1
    assert root.tag == "testsuites"
    suites = root.findall("testsuite")
    assert [s.get("name") for s in suites] == ["line_impossible", "line_mc_impossible", "line"]
    totals = dict.fromkeys(("tests", "failures", "errors", "skipped"), 0)
    for suite in suites:
        cases = suite.findall("testcase")
        counts = {
            "tests": len(cases),
            "failures": _count(cases, "failure"),
            "errors": _count(cases, "error"),
            "skipped": _count(cases, "skipped"),
        }
        assert {k: int(suite.get(k)) for k in counts} == counts, suite.get("name")
        assert float(suite.get("time")) >= 0
        for k, v in counts.items():
            totals[k] += v
    assert {k: int(root.get(k)) for k in totals} == totals
    # the deliberate failures are there and the passing experiment has none
    assert [int(s.get("failures")) for s in suites] == [1, 1, 0]
    assert totals["errors"] == totals["skipped"] == 0


def test_each_failing_case_carries_its_limit_message(checked):
    _, root, data = checked
    for suite, exp in zip(root.findall("testsuite"), data["experiments"], strict=True):
        verdicts = {v["limit"]: v for v in exp["limits"]}
        cases = {c.get("name"): c for c in suite.findall("testcase")}
        assert set(cases) == set(verdicts)
        for name, case in cases.items():
            verdict = verdicts[name]
            failure = case.find("failure")
            assert case.find("error") is None and case.find("skipped") is None
            if verdict["passed"]:
                assert failure is None, name
                continue
            assert failure is not None, name
            message = failure.get("message")
            assert message == verdict["message"] == failure.text
            assert message.startswith(f"{name}: ") and "VIOLATED" in message
            assert f"against the limit {verdict['bound']:.6g}" in message


def test_monte_carlo_report_names_the_worst_sample(checked):
    _, _, data = checked
    exp = next(e for e in data["experiments"] if e["experiment"] == "line_mc_impossible")
    samples = exp["metrics"]
    assert exp["runs"] == len(samples) == 4
    for verdict in exp["limits"]:
        values = [s[verdict["limit"]] for s in samples]
        if verdict["limit"] == "non_finite_commands":  # the default gate: no sample commanded NaN or infinity
            assert verdict["default"] and verdict["passed"] and values == [0] * 4
            continue
        if verdict["default"] and len(set(values)) == 1:
            continue  # a default no sample comes near (e.g. no solver failure in any): nothing to rank
        assert len(set(values)) == len(values), f"{verdict['limit']}: the samples must differ to tell worst from best"
        worst = max(range(len(values)), key=values.__getitem__)
        assert verdict["sample"] == samples[worst]["sample"] == worst, verdict["limit"]
        assert verdict["value"] == max(values)
        assert verdict["parameters"].keys() == {"body.mass_kg", "wheels.right.radius_m"}
    tracking = next(v for v in exp["limits"] if v["limit"] == "tracking_error_max_m")
    assert not tracking["passed"] and tracking["failed_runs"] == 4
    assert re.search(rf"; sample {tracking['sample']} of 4 \(4 failed\): body\.mass_kg = ", tracking["message"])


def _outcome(sample, value, bound=0.3):
    result = LimitResult("tracking_error_max_m", bound, value, value <= bound, 1.0, 0.5 if value > bound else None)
    task = RunTask("x.toml", sample, (("body.mass_kg", 20.0 + sample),))
    return RunOutcome(task, {"tracking_error_max_m": value}, (result,), 0.0)


def test_the_worst_run_decides_a_verdict():
    (verdict,) = worst_run_verdicts([_outcome(0, 0.2), _outcome(1, 0.5), _outcome(2, 0.1), _outcome(3, 0.4)])
    assert (verdict.sample, verdict.value, verdict.parameters) == (1, 0.5, {"body.mass_kg": 21.0})
    assert not verdict.passed and (verdict.runs, verdict.failed_runs) == (4, 2)
    (verdict,) = worst_run_verdicts([_outcome(0, 0.2), _outcome(1, 0.25)])
    assert verdict.passed and verdict.sample == 1 and verdict.failed_runs == 0


def test_check_ends_by_saying_what_it_wrote(tmp_path, capsys):
    junit, hist = tmp_path / "report.xml", tmp_path / "hist"
    argv = ["check", DATA / "line_mc_impossible.toml", "--junit", junit, "--jobs", "1", "--report-dir", hist]
    assert main([str(a) for a in argv]) == 1
    last = capsys.readouterr().out.splitlines()[-1]
    pngs = sorted(hist.glob("*.png"))
    assert pngs and last == f"wrote {junit}, {hist}/ ({len(pngs)} histograms)"
