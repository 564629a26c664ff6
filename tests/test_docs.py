"""The README stays a landing page and the documentation stays inside the repository."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"


def _documentation_files() -> list[Path]:
    files = [README, ROOT / "CHANGELOG.md"]
    for folder, pattern in (("docs", "*.md"), ("docs", "*.rst"), ("docs", "*.py"), ("agvctl", "*.py")):
        files += [
            p for p in (ROOT / folder).rglob(pattern) if not {"_build", "generated", "auto_examples"} & set(p.parts)
        ]
    return files


def test_readme_is_a_landing_page():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= 250
    # the two set-up commands come first, before any section
    first_section = next(i for i, line in enumerate(lines) if line.startswith("## "))
    commands = [line for line in lines[:first_section] if line.startswith("python3 -m venv .venv")]
    assert len(commands) == 2


def test_no_issue_numbers_and_no_paths_outside_the_repository():
    for path in _documentation_files():
        text = path.read_text(encoding="utf-8")
        assert not re.search(r"issue [0-9]+", text, flags=re.IGNORECASE), path
        assert "../shared" not in text and "/work/" not in text, path


def test_readme_picture_and_links_exist():
    text = README.read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#]+)\)", text):
        if not target.startswith("http"):
            assert (ROOT / target).exists(), target


def test_the_experiment_file_reference_names_every_mpc_setting():
    import dataclasses

    from agvctl.controllers.mpc.config import MpcConfig

    text = (ROOT / "docs" / "guide" / "experiments.md").read_text(encoding="utf-8")
    start = text.index("horizon = 20")
    listed = set(re.findall(r"\b[a-z][a-z0-9_]+\b", text[start : text.index("[limits]", start)]))
    settings = {f.name for f in dataclasses.fields(MpcConfig)}
    assert settings <= listed, sorted(settings - listed)


FILE_SUFFIXES = {"css", "csv", "html", "json", "md", "png", "py", "toml", "xml", "yml"}


def _resolves(dotted: str) -> bool:
    """``agvctl.a.b.C.d`` is a module, or an object reached from one by attributes (an instance attribute of a class
    counts when the class assigns it to ``self``)."""
    import importlib
    import inspect

    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if hasattr(obj, name):
                obj = getattr(obj, name)
            elif inspect.isclass(obj) and f"self.{name} " in inspect.getsource(obj):
                return name == parts[-1]
            else:
                return False
        return True
    return False


def test_every_module_and_object_the_docs_and_docstrings_name_exists():
    files = [p for p in _documentation_files() if "decisions" not in p.parts and p.name != "CHANGELOG.md"]
    files += [ROOT / "trajectories" / "README.md", *(ROOT / "experiments").rglob("*.py")]
    named: dict[str, set[str]] = {}
    for path in files:
        # a dotted name followed by ``.<`` or ``.{`` is a pattern (a JUnit class name ``agvctl.check.<experiment>``)
        for match in re.finditer(r"\bagvctl(?:\.[A-Za-z_]\w*)+(?!\.?[<{\w])", path.read_text(encoding="utf-8")):
            if match.group(0).rsplit(".", 1)[1] not in FILE_SUFFIXES:  # agvctl.css is a file
                named.setdefault(match.group(0), set()).add(str(path.relative_to(ROOT)))
    # the package's picture of the data flow names each part from ``agvctl``
    import agvctl

    picture = agvctl.__doc__.split("::")[1].split("\n\n")[1]
    for match in re.finditer(r"\b[a-z_]+(?:\.[A-Za-z_]\w*)+", picture):
        named.setdefault(f"agvctl.{match.group(0)}", set()).add("agvctl/__init__.py")
    assert len(named) > 100
    # entry-point groups (``agvctl.pose_controllers``) are names installed packages register under, not modules
    from agvctl.controllers.registry import pose_controllers, wheel_loops
    from agvctl.estimation.registry import pose_estimators, wheel_speed_estimators

    groups = {r.group for r in (pose_controllers, wheel_loops, pose_estimators, wheel_speed_estimators)}
    missing = {name: sorted(where) for name, where in named.items() if name not in groups and not _resolves(name)}
    assert not missing, missing


def test_the_table_of_shipped_paths_gives_what_planning_them_gives():
    """Every figure of the table in ``trajectories/README.md`` (shown in the planning guide), to the digits shown."""
    import dataclasses

    from agvctl.params import load_vehicle
    from agvctl.planning import load_path, plan

    vehicle = load_vehicle()
    text = (ROOT / "trajectories" / "README.md").read_text(encoding="utf-8")
    rows = [line.split("|")[1:-1] for line in text.splitlines() if line.startswith("| `")]
    assert len(rows) == len(list((ROOT / "trajectories").glob("*.toml")))
    for name, _what, duration, stopping, length, deviation in (map(str.strip, row) for row in rows):
        path = load_path(ROOT / "trajectories" / name.strip("`"))
        summary = plan(path, vehicle).summary()
        assert duration == f"{summary['duration_s']:.2f} s", name
        assert length == f"{summary['path_length_m']:.2f} m", name
        deviation_mm = summary["drawn_path_deviation_m"] * 1e3
        if deviation == "0":
            assert deviation_mm == 0.0, name
        elif deviation.startswith("<"):
            assert 0.0 < deviation_mm < float(deviation.split()[1]), name
        else:
            assert deviation == f"{deviation_mm:.1f} mm", name
        if stopping == "—":
            continue
        stopped = plan(dataclasses.replace(path, join="stop"), vehicle).summary()
        assert stopping == f"{stopped['duration_s']:.2f} s", name
