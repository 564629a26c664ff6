"""The example files installed with the package: every experiment and path file of the repository, and the code of
one's own they name, is package data of ``agvctl.examples``, reachable from Python and copied out by
``agvctl examples DIR`` (a folder that is new or empty: nothing of the user's is replaced), where they run."""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

import pytest
from cli_runs import one_line, run

from agvctl.errors import ConfigError
from agvctl.examples import EXAMPLE_FOLDERS, example_files, example_path
from agvctl.fuzz import load_fuzz_config
from agvctl.scenario.experiment import load_experiment

ROOT = Path(__file__).resolve().parent.parent
SHIPPED_TOML = sorted(str(p.relative_to(ROOT)) for f in EXAMPLE_FOLDERS for p in (ROOT / f).rglob("*.toml"))
# The code of one's own that shipped files name by a file reference: a copied example must find it beside it.
NAMED_CODE = ["experiments/falsify/weak_braking.py", "experiments/own_controller/pure_pursuit.py"]
SHIPPED = sorted(SHIPPED_TOML + NAMED_CODE)


def test_every_example_file_is_package_data():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = config["tool"]["setuptools"]["package-data"]["agvctl.examples"]
    assert len(SHIPPED) > 40 and example_files() == SHIPPED
    for name in SHIPPED:  # fnmatch's * crosses folders; each pattern's depth must be the file's
        assert any(fnmatch.fnmatch(name, p) and name.count("/") == p.count("/") for p in patterns), name
        assert example_path(name).read_bytes() == (ROOT / name).read_bytes()


def test_a_name_outside_the_examples_is_refused():
    for name in ("experiments/nope.toml", "../pyproject.toml", "agvctl/vehicles/iau_agv.toml"):
        with pytest.raises(ConfigError, match="no shipped example file"):
            example_path(name)


def test_agvctl_examples_copies_them_out_and_never_over_a_folder_in_use(tmp_path, capsys):
    code, out, _ = run(capsys, "examples", tmp_path / "ex")
    assert code == 0 and "wrote" in out
    copied = sorted(str(p.relative_to(tmp_path / "ex")) for p in (tmp_path / "ex").rglob("*") if p.is_file())
    assert copied == SHIPPED
    (tmp_path / "used").mkdir()
    (tmp_path / "used" / "mine.toml").write_text("x = 1\n", encoding="utf-8")
    code, _, err = run(capsys, "examples", tmp_path / "used")
    assert code == 2
    one_line(err, "used", "not an empty folder")
    assert [p.name for p in (tmp_path / "used").iterdir()] == ["mine.toml"]


def test_the_copied_examples_that_name_code_of_ones_own_load_with_it(tmp_path, capsys):
    code, _, _ = run(capsys, "examples", tmp_path / "ex")
    assert code == 0
    experiment = load_experiment(tmp_path / "ex" / "experiments" / "own_controller" / "figure8.toml")
    assert experiment.spec.controller.pose.endswith("pure_pursuit.py:PurePursuit")
    for name in ("experiments/own_controller/fuzz.toml", "experiments/falsify/weak.toml"):
        assert load_fuzz_config(tmp_path / "ex" / name).controllers
