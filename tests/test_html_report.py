"""``check --html`` and ``fuzz --html``: one self-contained page whose verdicts, tables and figures are those of
the report, failures first; bad ``--html`` paths refused before anything runs."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import pytest
from cli_runs import one_line, run
from html_pages import FAILING, FUZZ_CONFIG, PASSING, ROOT, Page, png_size, read_page

from agvctl.checks.runner import check_experiments
from agvctl.htmlreport import check_html, check_run_figures

MC_FAILING = ROOT / "tests" / "data" / "line_mc_impossible.toml"


def _page(pages: dict[str, Any], name: str) -> Page:
    return read_page((pages["dir"] / name).read_text(encoding="utf-8"))


def _assert_self_contained(page: Page) -> None:
    assert page.scripts == 0  # readable without JavaScript
    assert page.images, "no figure on the page"
    for src in page.images:
        width, height = png_size(src)  # every image embedded, and a PNG that decodes
        assert width > 100 and height > 100
    assert all(link.startswith("#") for link in page.links), page.links  # no address outside the page


def test_a_failing_check_page_names_the_failing_limit_with_its_value_bound_and_times_first(
    pages: dict[str, Any],
) -> None:
    assert pages["codes"]["check_failing"] == 1
    report = json.loads((pages["dir"] / "f.json").read_text())
    failing = next(e for e in report["experiments"] if not e["passed"])
    violated = next(v for v in failing["limits"] if not v["passed"])
    page = _page(pages, "failing.html")
    summary = page.tables["summary"]
    assert summary[1][:3] == [failing["experiment"], "FAIL", violated["limit"]]  # the failure first, though given last
    assert f"{violated['value']:.6g} m" in summary[1][3] and f"{violated['bound']:.6g} m" in summary[1][4]
    assert f"t = {violated['worst_time_s']:.2f} s" in summary[1][5]
    assert f"t = {violated['first_time_s']:.2f} s" in summary[1][5]
    assert summary[2][:2] == ["line", "PASS"]
    assert page.headings == ["experiment-1", "experiment-0"]
    _assert_self_contained(page)
    assert len(page.images) == 2  # one figure per experiment


def test_the_limit_tables_mark_every_default_bound_with_its_reason(pages: dict[str, Any]) -> None:
    report = json.loads((pages["dir"] / "f.json").read_text())
    page = _page(pages, "failing.html")
    limit_tables = [rows for name, rows in page.tables.items() if name != "summary"]
    by_order = {e["experiment"]: e for e in report["experiments"]}
    for rows, name in zip(limit_tables, ("line_impossible", "line"), strict=True):
        verdicts = by_order[name]["limits"]
        assert [r[1] for r in rows[1:]] == [v["limit"] for v in verdicts]
        for row, v in zip(rows[1:], verdicts, strict=True):
            assert row[0] == ("ok" if v["passed"] else "FAIL")
            assert ("(default: " + v["reason"] + ")" in row[3]) == v["default"]


def test_each_experiment_shows_its_resolved_experiment_file(pages: dict[str, Any]) -> None:
    page = _page(pages, "failing.html")
    resolved = [tomllib.loads(text) for text in page.pre]
    assert [r["name"] for r in resolved] == ["line_impossible", "line"]
    assert resolved[0]["limits"]["tracking_error_max_m"] == 1e-6
    assert Path(resolved[0]["trajectory"]).is_absolute()


def test_a_passing_check_page_says_so(pages: dict[str, Any]) -> None:
    assert pages["codes"]["check_passing"] == 0
    page = _page(pages, "passing.html")
    assert page.tables["summary"][1] == ["line", "PASS", "every limit held"]
    assert "1 of 1 experiments passed" in page.text
    _assert_self_contained(page)


def test_a_monte_carlo_page_shows_the_sample_the_verdict_names() -> None:
    report = check_experiments([MC_FAILING], jobs=1, render=check_run_figures)
    (verdict,) = [v for v in report.experiments[0].verdicts if not v.passed]
    page = read_page(check_html(report))
    assert f"Monte Carlo sample {verdict.sample} of 4" in page.text
    assert f"sample {verdict.sample} of 4 ({verdict.failed_runs} failed)" in page.tables["summary"][1][5]
    _assert_self_contained(page)


def test_a_fuzz_page_gives_the_pass_counts_and_the_command_that_reproduces_each_worst_run(
    pages: dict[str, Any],
) -> None:
    assert pages["codes"]["fuzz"] == 1
    summary = json.loads((pages["dir"] / "fz" / "summary.json").read_text())
    page = _page(pages, "fuzz.html")
    rows = {r[0]: r for r in page.tables["summary"][1:]}
    for c, s in summary["statistics"].items():
        assert rows[c][2:6] == [str(s[k]) for k in ("runs", "passed", "failed", "crashed")]
    failed = [r for r in summary["runs"] if not r["passed"]]
    assert failed
    for r in failed:  # each reproducing command names a file the fuzz run wrote
        command = f"agvctl run {(pages['dir'] / 'fz' / 'failures' / r['experiment_file']).as_posix()}"
        assert command in page.text
        assert (pages["dir"] / "fz" / "failures" / r["experiment_file"]).is_file()
    assert "mpc vs ramsete" in page.text and "within 1 mm" in page.text  # the comparison with its tolerance
    _assert_self_contained(page)
    assert len(page.images) == 1 + len(summary["runs"])  # the distributions, and each worst run (2 per controller)


# -- bad --html paths: one line, exit 2, nothing run or written ------------------------------------------------


def _files(d: Path) -> dict[str, bytes]:
    return {str(p.relative_to(d)): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("command", ["check", "fuzz"])
@pytest.mark.parametrize(
    ("where", "problem"),
    [
        ("adir", "adir is a directory; expected a file name"),
        ("afile/r.html", "cannot write afile/r.html: afile is not a directory"),
        ("/proc/r.html", "cannot write /proc/r.html: cannot create a file in /proc"),
        ("input", "is an input of this command"),
    ],
)
def test_an_html_path_that_cannot_be_written_stops_the_command_before_it_runs(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: str,
    where: str,
    problem: str,
) -> None:
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("a file, not a directory\n")
    (tmp_path / "fz.toml").write_text(FUZZ_CONFIG, encoding="utf-8")
    (tmp_path / "exp.toml").write_text(FAILING.read_text().replace("../../trajectories", str(ROOT / "trajectories")))
    monkeypatch.chdir(tmp_path)
    given = "exp.toml" if command == "check" else "fz.toml"
    html = given if where == "input" else where
    before = _files(tmp_path)
    argv = ["check", given] if command == "check" else ["fuzz", given, "--out", "fz"]
    code, out, err = run(capsys, *argv, "--json" if command == "check" else "--junit", "r.out", "--html", html)
    assert code == 2 and out == ""
    one_line(err, "agvctl: --html: ", problem)
    assert _files(tmp_path) == before  # nothing written, the input untouched


def test_a_render_that_is_not_a_function_is_refused_before_anything_runs() -> None:
    from agvctl.errors import ConfigError

    with pytest.raises(ConfigError) as info:
        check_experiments([PASSING], jobs=1, render=42)  # type: ignore[arg-type]
    assert str(info.value).startswith("render: expected a function") and "\n" not in str(info.value)


def test_a_fuzz_page_repeats_no_warning_of_its_runs_naming_a_deleted_file(tmp_path, capsys):
    # seed 1's second scenario plans with an acceleration limit that leaves little headroom: a warning of its run
    (tmp_path / "fz.toml").write_text('seed = 1\nscenarios = 2\ncontrollers = ["ramsete"]\nsettle_s = 0.2\n')
    out, page = tmp_path / "fz", tmp_path / "fuzz.html"
    code, _, err = run(capsys, "fuzz", tmp_path / "fz.toml", "--jobs", "1", "--out", out, "--html", page, "--no-plot")
    assert code in (0, 1) and page.is_file()
    recorded = [w for r in json.loads((out / "summary.json").read_text())["runs"] for w in r["warnings"]]
    assert recorded  # the runs' warnings are in the summary ...
    for line in err.splitlines():  # ... and any warning on stderr names a file that is there to read
        if line.startswith("agvctl: warning: /"):
            assert Path(line.removeprefix("agvctl: warning: ").split(":")[0]).exists(), line
