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


# A quantity the docs state: a number with a unit or a count ("0.5 m/s", "±2 %", "40 ms", "500 scenarios",
# "199/200", "499 of 500", "×1.14"), not an equation's or a section's number.
_UNIT = (
    r"mm/s|m/s²|m/s\^?2|m/s³|m/s|rad/s²|rad/s|rad|mm|cm|km|µm|m|ms|µs|s|min|h|°|%|V|A|N\s?m|kg|g|t|Hz|dB|mΩ|kΩ|Ω"
    r"|runs?|scenarios?|trials?|samples?|laps?|seeds?|times|vehicles?|experiments?|fixes|steps?|iterations?"
    r"|cores?|workers?|jobs?|failures?|crash(?:es)?|passed|failed|per second"
)
_NUMBER = r"[-+−±]?(?:\d{1,3}(?:[ ,]\d{3})+|\d+)(?:\.\d+)?(?:e[-+]?\d+)?"
_RANGE = _NUMBER + r"(?:\s?(?:–|-|…|\.\.\.?|to)\s?" + _NUMBER + r")?"
QUANTITY = re.compile(
    r"(?<![\w.\-/])(?:" + _RANGE + r"\s?(?:" + _UNIT + r")(?![\w/²³])|\d+ of \d+|\d+/\d+(?![\w/])|×\s?\d+(?:\.\d+)?)"
)
_CITATION = re.compile(r"(?:\beqs?|§|\bnotes?|\bsection|\brecord|\bappendix)\.?\s*$", flags=re.IGNORECASE)

# Pages whose numbers a script writes (as docs/benchmarks/regenerate.py writes results.md), or that no page states by
# hand yet: each with its reason.
NUMBERS_WRITTEN_ELSEWHERE = {
    "docs/benchmarks/results.md": "written by docs/benchmarks/regenerate.py",
    "docs/guide/broken-controllers.md": "written by experiments/robustness/broken_controllers.py",
}

# The numbers the docs state that are definitions, not results: inputs of a shipped file, the package's constants
# and defaults, the report's figures (which the tests check the code against), and arithmetic on those.
DEFINITIONS: dict[str, dict[str, str]] = {
    "README.md": {"0.5 m/s": "the cruise speed experiments/figure8.toml plans for (an input)"},
    "docs/getting-started.md": {"0.5 m/s": "the cruise speed experiments/figure8.toml plans for (an input)"},
    "trajectories/README.md": {
        "20 %": "the feedback headroom the default limits leave, a design constant (decision record 0001)",
        "5 mm": "the default drawn-path tolerance, a constant of the planner (decision record 0038)",
        "2 mm": "the tolerance the example file sets (an input)",
        "0.5 m/s": "the figure-8 file's cruise speed (an input)",
        "25.1 s": "4π m at 0.5 m/s, arithmetic on the file's own numbers",
    },
    "docs/guide/estimation.md": {
        "×4": "quadrature decoding counts four edges per line, a definition",
        "50 ms": "the default fix latency of the vehicle file's [sensors] table (an input)",
        "±1 %": "the vehicle file's wheel-radius tolerance, and the fuzz file's envelope (inputs)",
        "±2 %": "the vehicle file's wheel-base tolerance, and the fuzz file's envelope (inputs)",
        "0.05 %": "the EKF's relative slip σ, a default of EkfSettings",
        "1 %": "the calibration comparison's plant: the right wheel 1 % larger (an input of the script)",
        "2 %": "the calibration comparison's plant: the base 2 % wider (an input of the script)",
        "1 mm": "the rest rule's floor on the estimate's covariance, a default of RestConfig",
        "0.003 rad": "the rest rule's floor on the estimate's covariance, a default of RestConfig",
        "5 mm": "the rest rule's band, a default of RestConfig",
        "0 V": "what a released wheel is driven with, a definition",
        "0.5 %": "the radius error experiments/figure8_ekf.toml gives its plant (an input)",
        "500 scenarios": "experiments/fuzz/estimation.toml's scenarios (an input)",
        "75-100 %": "experiments/fuzz/estimation.toml's envelope of the fixes (an input)",
        "2-4 Hz": "experiments/fuzz/estimation.toml's envelope of the fixes (an input)",
        "10-100 ms": "experiments/fuzz/estimation.toml's envelope of the fixes (an input)",
    },
    "docs/guide/experiments.md": {
        "180°": "a vehicle turned around, the definition of the path heading error's top",
        "600 s": "the bound on settle_s, a constant of the experiment schema",
        "2 rad/s": "the band over which the Coulomb feed-forward ramps in, a constant of the PI loop",
        "60°": "the default phase margin of TuningSpec",
        "10 dB": "the default gain margin of TuningSpec",
        "10 cm": "the start offset experiments/figure8_offpath.toml sets (an input)",
        "−180°": "the phase that defines the gain margin's crossing, a definition",
        "0.3 m/s": "the wheel-speed step agvctl tune verifies its design with, a constant of the command",
    },
    "docs/guide/fuzzing.md": {
        "±1 %": "the fuzzer's default plant envelope (an input of the fuzz file)",
        "±2 %": "the fuzzer's default plant envelope (an input of the fuzz file)",
        "−10…+30 %": "the fuzzer's default plant envelope (an input of the fuzz file)",
        "±50 %": "the fuzzer's default plant envelope (an input of the fuzz file)",
        "5 cm": "the fuzzer's default start offset (an input of the fuzz file)",
        "5°": "the fuzzer's default start heading (an input of the fuzz file)",
        "500 scenarios": "experiments/fuzz/acceptance.toml's scenarios (an input)",
        "1000 runs": "500 scenarios × 2 controllers of experiments/fuzz/acceptance.toml (inputs)",
        "10 scenarios": "the build's smaller run of the acceptance fuzz (--scenarios 10, an input)",
        "1 mm": "the comparison's tie tolerance, COMPARISON_TOLERANCE_M of agvctl.fuzz.report",
        "30 scenarios": "experiments/fuzz/ci.toml's scenarios (an input)",
        "300 scenarios": "experiments/fuzz/gentle.toml's scenarios (an input)",
    },
    "docs/guide/planning.md": {
        "20 %": "the feedback headroom of the feasible limits, a design constant (decision record 0001)",
        "10 %": "the headroom below which the planner warns, MIN_HEADROOM of agvctl.feasibility",
        "1.5 m": "the doctest's example path (an input)",
        "90°": "the doctest's example path (an input)",
        "0.8 m": "the doctest's example path (an input)",
        "2 m": "the doctest's example path (an input)",
        "1 m": "the doctest's example path and tolerance (inputs)",
    },
    "docs/guide/requirements.md": {
        "0.3 m": "trajectories/dock.toml's last segment (an input)",
        "0.1 m/s": "trajectories/dock.toml's docking speed (an input)",
        "3 s": "a requirement's window and a broken controller's delay (inputs)",
        "5 mm": "a requirement's bound (an input of experiments/requirements.toml)",
        "0.2 m/s": "a requirement's bound (an input of experiments/requirements.toml)",
        "2 cm": "a requirement's bound (an input of experiments/requirements.toml)",
        "3 cm": "a broken controller's believed offset (an input of the test)",
    },
    "docs/guide/tuning.md": {
        "200 scenarios": "the default of --validation-scenarios",
        "1 cm": "the objective's unit of cross-track error, a definition (decision record 0025)",
        "2.5 cm": "the objective's weight 100 over 40 training scenarios, arithmetic on its definition",
        "2 cm": "the band that defines 'once on the path' and the completion time (decision record 0025)",
    },
    "docs/guide/falsify.md": {
        "1 %": "an example of a rare weakness, and the planted weakness's design bound (decision record 0039)",
        "20 runs": "the random start before the local moves, LOCAL_AFTER of agvctl.falsify.proposals",
        "15 %": "a local move's step, LOCAL_STEP of agvctl.falsify.proposals",
    },
    "docs/guide/vehicles.md": {
        "7 samples": "10^7, the bound on a run's samples, MAX_SAMPLES_PER_RUN (decision record 0021)",
        "0.1 ms": "the bounds on the sample period, constants of the vehicle schema (decision record 0021)",
        "1 s": "the bounds on the sample period, constants of the vehicle schema (decision record 0021)",
        "1 mm": "the bounds on lengths (decision record 0021), and the simulator test's tolerance on the pose",
        "100 m": "the bounds on lengths (decision record 0021)",
        "1 g": "the bounds on masses (decision record 0021)",
        "1000 t": "the bounds on masses (decision record 0021)",
        "0.1 mΩ": "the bounds on armature resistance (decision record 0021)",
        "10 kΩ": "the bounds on armature resistance (decision record 0021)",
        "5 %": "the encoder rule's bound, a constant of agvctl.params.rules",
        "5 ms": "the longest RK4 substep, a constant of agvctl.plant.integrator",
        "0.1 %": "the simulator test's tolerance on the motor speeds",
        "10 s": "the length of the simulator test's profile (an input of the test)",
    },
    "docs/guide/codegen.md": {
        "5 cm": "the docking's backing step, BACKING_STEP_M of agvctl.controllers.mpc.docking (decision record 0043)",
        "0.15 to 0.5 m": "the fewest and most backing steps, BACKING_STEPS of the same module",
    },
    "docs/guide/ci-gate.md": {
        "0.4 s": "a held wheel's recovery, RECOVERY_S of agvctl.evaluation.payload (decision record 0041)",
        "0.4 m/s²": "the planning limit the doctest's example path sets (an input)",
        "1 mm": "how far a fault must move a run to harm it, defined in experiments/robustness/broken_controllers.py",
        "0.5°": "how far a fault must turn a run to harm it, a definition of the same script",
        "2 cm": "the arrival band of the same script, a definition",
        "90°": "a vehicle facing across its path, the definition of turned around",
        "200 samples": "experiments/robustness/figure8_mc.toml's samples (an input)",
        "95 %": "the chi-square interval the consistency test uses, a definition",
    },
    "docs/model-notes.md": {
        "±5 V": "the report's DA range (§2.2)",
        "±5.5 A": "the report's current limit",
        "0.657 m/s²": "the report's table, which tests/test_params.py checks eq 5 gives",
        "0.065 N m": "the report's table",
        "5.46 kg": "the report's table (kg m²), which tests/test_params.py checks eq 64 gives",
        "0.12 m": "the report's table",
        "0.129 m": "appendix A's mass assumptions put into eq 63, arithmetic on the report's figures",
        "+5 V": "the report's DA range",
        "4.9976 V": "code 2047 · 10 V/4096, arithmetic on the DA's definition (tests/test_actuator.py checks it)",
        "40 ms": "the report's sample period",
        "±10 V": "the amplifier's gain 2 on the DA's ±5 V, arithmetic on the report's figures",
    },
}


def _stated_quantities(path: Path) -> list[tuple[int, str]]:
    """The quantities a page states by hand: outside a fenced block that holds a doctest (its output is checked), and
    outside the rows of ``trajectories/README.md``'s table (checked against planning each file by a test above)."""
    found = []
    fence, doctest = False, False
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        stripped = line.strip()
        if stripped.startswith("```"):
            fence, doctest = (True, False) if not fence else (stripped != "```", doctest)
            continue
        doctest = doctest or (fence and stripped.startswith(">>>"))
        if (fence and doctest) or (
            path.name == "README.md" and path.parent.name == "trajectories" and line.startswith("| `")
        ):
            continue
        for match in QUANTITY.finditer(line):
            if not _CITATION.search(line[: match.start()]):
                found.append((number, match.group(0)))
    return found


def test_every_number_the_docs_state_is_produced_by_the_build_a_doctest_or_a_definition():
    """Decision record 0036: a result the docs state comes from the docs build (an included command output) or a
    doctest; what a page states by hand is a definition, listed in :data:`DEFINITIONS` with its reason."""
    pages = [README, ROOT / "trajectories" / "README.md", *(ROOT / "docs").rglob("*.md")]
    unexplained: dict[str, list[str]] = {}
    used: set[tuple[str, str]] = set()
    for path in pages:
        name = path.relative_to(ROOT).as_posix()
        if {"decisions", "_build", "_generated", "auto_examples", "generated"} & set(path.parts):
            continue
        if name in NUMBERS_WRITTEN_ELSEWHERE or name == "docs/changelog.md":
            continue
        allowed = DEFINITIONS.get(name, {})
        for number, quantity in _stated_quantities(path):
            if quantity in allowed:
                used.add((name, quantity))
            else:
                unexplained.setdefault(name, []).append(f"line {number}: {quantity}")
    assert not unexplained, unexplained
    stale = sorted(f"{name}: {q}" for name, table in DEFINITIONS.items() for q in table if (name, q) not in used)
    assert not stale, stale
