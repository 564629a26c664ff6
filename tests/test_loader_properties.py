"""Loaders never crash: random and mutated documents, values and command lines end in success or one clean line.

Every file loader and CLI argument parser is fed random documents and values (wrong types, NaN, ±inf, huge and
tiny numbers, negative, zero, empty strings, tables and arrays, unknown keys, nested garbage), and the shipped
files mutated key by key. The only accepted outcomes are success, or an :class:`~agvctl.errors.AgvctlError` whose
message is one line starting with the file (or flag) it names; through :func:`agvctl.cli.main`: exit 0 or 1, or
exit 2 with one line on stderr and no output file written. Any other exception, or a multi-line message, fails.

Each loader gets :data:`EXAMPLES` examples, drawn deterministically (the ``loaders`` settings profile); the
loaded paths are also planned in :data:`PLANNED_EXAMPLES` examples (planning costs more than loading).
"""

from __future__ import annotations

import contextlib
import datetime
import functools
import io
import json
import math
import tempfile
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from cli_runs import assert_clean
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from agvctl.calibration import read_friction_log, read_umbmark_log
from agvctl.cli import main
from agvctl.config import parse_override
from agvctl.controllers.pi.gains_file import load_gains
from agvctl.fuzz.run import fuzz_tasks
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.params import default_vehicle_path, load_vehicle
from agvctl.planning import load_path, plan
from agvctl.scenario.experiment import load_experiment
from agvctl.sim.open_loop import load_input_profile

EXAMPLES = 1000
PLANNED_EXAMPLES = 250
settings.register_profile(
    "loaders",
    parent=settings.get_profile("agvctl"),
    max_examples=EXAMPLES,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
)
LOADERS = settings.get_profile("loaders")

ROOT = Path(__file__).resolve().parent.parent
TRAJECTORIES = sorted((ROOT / "trajectories").glob("*.toml"))
EXPERIMENTS = sorted((ROOT / "experiments").glob("*.toml")) + [ROOT / "experiments" / "robustness" / "figure8_mc.toml"]
VEHICLE_FILE = default_vehicle_path()
GAINS_DOC = {"pi": {"kp_v_s_rad": 0.02, "ki_v_rad": 0.3, "dt_s": 0.04, "coulomb_feedforward": False}}
FRICTION_COLUMNS = (
    "t_s",
    "phase",
    "setpoint_omega_motor_left_rad_s",
    "setpoint_omega_motor_right_rad_s",
    "omega_motor_left_rad_s",
    "omega_motor_right_rad_s",
    "da_voltage_left_v",
    "da_voltage_right_v",
)
UMBMARK_COLUMNS = ("direction", "x_m", "y_m", "est_x_m", "est_y_m")
WORK = Path(tempfile.mkdtemp(prefix="agvctl-loaders-"))


def _read(path: Path) -> dict[str, Any]:
    return tomllib.loads(path.read_text(encoding="utf-8"))


def _known_keys() -> list[str]:
    keys: set[str] = set()

    def walk(node: Any) -> None:
        if isinstance(node, dict):
            for k, v in node.items():
                keys.add(k)
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    for path in [*TRAJECTORIES, *EXPERIMENTS, VEHICLE_FILE]:
        walk(_read(path))
    return sorted(keys)


KNOWN_KEYS = _known_keys()

# ----------------------------------------------------------------------------------------------------------------
# Values and documents

NASTY_NUMBERS = [
    0,
    -1,
    1,
    2,
    0.0,
    -0.0,
    0.5,
    -0.5,
    1e-300,
    5e-324,
    -1e-9,
    1e6,
    1e12,
    -1e12,
    1e308,
    -1e308,
    2**63 - 1,
    -(2**63),
    math.nan,
    math.inf,
    -math.inf,
]
numbers = st.sampled_from(NASTY_NUMBERS) | st.floats() | st.integers(-(2**63), 2**63 - 1)
words = st.sampled_from(["", " ", "line", "turn", "arc", "mpc", "nmpc", "none", "default", "nan", "cw", "x\ny"])
scalars = numbers | st.booleans() | words | st.text(max_size=6) | st.dates()
keys = st.sampled_from(KNOWN_KEYS) | st.text(max_size=6)
values = st.recursive(
    scalars, lambda inner: st.lists(inner, max_size=3) | st.dictionaries(keys, inner, max_size=3), max_leaves=4
)


def toml_value(v: Any) -> str:
    """TOML text of a value, tables inline (so arrays of tables and nesting need no headers)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, (int, datetime.date)):
        return str(v) if isinstance(v, int) else v.isoformat()
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(x)}" for k, x in v.items()) + "}"


def toml_text(doc: dict[str, Any]) -> str:
    return "".join(f"{json.dumps(k)} = {toml_value(v)}\n" for k, v in doc.items())


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield (*prefix, k)
        yield from _paths(v, (*prefix, k))


@st.composite
def mutated(draw: st.DrawFn, originals: list[dict[str, Any]]) -> dict[str, Any]:
    """One of ``originals`` with one to three keys replaced by garbage, deleted, or given an unknown sibling."""
    doc = json.loads(json.dumps(draw(st.sampled_from(originals))))  # a deep copy
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(doc))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent: Any = doc
        for part in path[:-1]:
            parent = parent[part]
        action = draw(st.sampled_from(["number", "number", "value", "delete", "unknown", "empty"]))
        last = path[-1]
        if action == "number":
            parent[last] = draw(numbers)
        elif action == "value":
            parent[last] = draw(values)
        elif action == "empty":
            parent[last] = draw(st.sampled_from(["", [], {}]))
        elif action == "delete":
            del parent[last]
        elif isinstance(parent, dict):
            parent[draw(keys)] = draw(values)
    return doc


def documents(originals: list[dict[str, Any]]) -> st.SearchStrategy[str]:
    """TOML text: a shipped document mutated, a random document, or not TOML at all."""
    edited = mutated(originals).map(toml_text)
    return st.one_of(edited, edited, st.dictionaries(keys, values, max_size=5).map(toml_text), st.text(max_size=40))


def write(name: str, text: str | bytes) -> Path:
    path = WORK / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


# ----------------------------------------------------------------------------------------------------------------
# File loaders

VEHICLE_DOC = _read(VEHICLE_FILE)
BASE_VEHICLE = load_vehicle()


@LOADERS
@given(text=documents([VEHICLE_DOC]))
@example(text=toml_text({**VEHICLE_DOC, "amplifier": {**VEHICLE_DOC["amplifier"], "current_limit_a": 1e308}}))
def test_vehicle_file(text: str) -> None:
    path = write("vehicle.toml", text)
    vehicle = assert_clean(lambda: load_vehicle(path), str(path))
    if vehicle is not None:
        vehicle.derived  # noqa: B018  (a loaded vehicle's derived constants compute)


def _leaf_keys(node: dict[str, Any], prefix: str = "") -> list[str]:
    out = []
    for k, v in node.items():
        key = f"{prefix}.{k}" if prefix else k
        out += _leaf_keys(v, key) if isinstance(v, dict) else [key]
    return out


VEHICLE_KEYS = _leaf_keys(VEHICLE_DOC) + [
    "motor.left.gear_ratio",
    "motor.right.stiction_n_m",
    "motor",
    "wheels",
    "wheels.left.radius_m",
    "wheels.right",
    "wheels.radius_left_m",
]
override_values = numbers.map(lambda v: toml_value(v)) | st.text(max_size=8) | values.map(toml_value)
overrides = st.tuples(
    st.sampled_from(VEHICLE_KEYS) | st.text(max_size=8), st.sampled_from(["=", "", " = "]), override_values
).map("".join)


@LOADERS
@given(sets=st.lists(overrides, max_size=3))
@example(sets=["motor.resistance_ohm=1e-300"])
@example(sets=["wheels.left.radius_m=1e308"])
def test_vehicle_overrides(sets: list[str]) -> None:
    assert_clean(lambda: [parse_override(s) for s in sets], "--set")
    vehicle = assert_clean(lambda: load_vehicle(None, sets), str(VEHICLE_FILE), "--set")
    if vehicle is not None:
        vehicle.derived  # noqa: B018
    assert_clean(lambda: BASE_VEHICLE.with_overrides(sets), "--set")


PATH_DOCS = [_read(p) for p in TRAJECTORIES]


PATH_REGRESSIONS = [
    {"segments": [{"type": "line", "length_m": 1e12}]},  # Ruckig must not raise inside plan
    {"segments": [{"type": "line", "length_m": 1e8}]},
    {"segments": [{"type": "line", "length_m": 1e6}]},  # plannable, but a reference of twelve days
    {"segments": [{"type": "turn", "angle_deg": 1e10}]},
    {"segments": [{"type": "arc", "radius_m": 1e-12, "angle_deg": 90}]},
    {"segments": [{"type": "arc", "radius_m": 5e-324, "angle_deg": 90}]},  # an infinite curvature
    {"segments": [{"type": "turn", "angle_deg": 5e-324}]},
    {"segments": [{"type": [], "radius_m": 1.0, "angle_deg": 360}]},  # a type that is not a string
    {"waypoints": [{"x_m": 1e308, "y_m": 0.0}, {"x_m": 1.5, "y_m": 0.0}, {"x_m": 2.8, "y_m": 0.6}]},  # scipy raised
]


def check_path(text: str, *, planned: bool) -> None:
    path = write("path.toml", text)
    spec = assert_clean(lambda: load_path(path), str(path))
    if spec is not None and planned:
        ref = assert_clean(lambda: plan(spec), str(path))  # type: ignore[arg-type]
        if ref is not None:
            ref.summary()  # type: ignore[attr-defined]


@LOADERS
@given(text=documents(PATH_DOCS))
def test_path_file(text: str) -> None:
    check_path(text, planned=False)


@settings(LOADERS, max_examples=PLANNED_EXAMPLES)
@given(text=documents(PATH_DOCS))
def test_path_file_planned(text: str) -> None:
    """The loaded paths planned as well (fewer examples: planning a shipped path takes 10-90 ms)."""
    check_path(text, planned=True)


@pytest.mark.parametrize("doc", PATH_REGRESSIONS)
def test_path_regressions(doc: dict[str, Any]) -> None:
    check_path(toml_text(doc), planned=True)


def _experiment_doc(path: Path) -> dict[str, Any]:
    """A shipped experiment with the files it names made absolute, so that a copy elsewhere still finds them."""
    doc = _read(path)
    doc["trajectory"] = str((path.parent / doc["trajectory"]).resolve())
    if doc.get("vehicle", "default") != "default":
        doc["vehicle"] = str((path.parent / doc["vehicle"]).resolve())
    return doc


EXPERIMENT_DOCS = [_experiment_doc(p) for p in EXPERIMENTS]


@LOADERS
@given(text=documents(EXPERIMENT_DOCS))
def test_experiment_file(text: str) -> None:
    path = write("experiment.toml", text)
    assert_clean(lambda: load_experiment(path), str(path), str(WORK), str(ROOT / "trajectories"))


FUZZ_DOCS = [_read(p) for p in sorted((ROOT / "experiments" / "fuzz").glob("*.toml"))]


@LOADERS
@given(text=documents(FUZZ_DOCS))
def test_fuzz_file(text: str) -> None:
    """A fuzz configuration loads, then draws its first scenario, or is refused in one line naming the file."""
    path = write("fuzz.toml", text)

    def load_and_draw() -> object:
        return fuzz_tasks(load_fuzz_config(path), scenarios=[0])

    assert_clean(load_and_draw, str(path))


@LOADERS
@given(text=documents([GAINS_DOC]))
def test_gains_file(text: str) -> None:
    path = write("gains.toml", text)
    assert_clean(lambda: load_gains(path), str(path))


def csv_text(columns: tuple[str, ...], cells: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    """A CSV log: a header of (some of, shuffled, extra) ``columns`` and rows of random cells."""
    header = st.lists(st.sampled_from([*columns, "", "extra"]), max_size=len(columns) + 2) | st.permutations(columns)
    rows = st.lists(st.lists(cells, min_size=len(columns) - 1, max_size=len(columns) + 1), max_size=5)
    return st.tuples(header, rows).map(lambda hr: "\n".join(",".join(r) for r in [hr[0], *hr[1]]) + "\n")


CELLS = [*map(str, NASTY_NUMBERS), "", " 1.5 ", "-0.25", "0.04", "hold", "ramp", "idle", "cw", "ccw", "CW", "#", "x"]
cells = st.sampled_from(CELLS) | st.floats(-1e3, 1e3).map(repr)


@LOADERS
@given(
    text=csv_text(("t_s", "da_left_v", "da_right_v"), cells) | st.text(max_size=40),
    duration_s=st.sampled_from([0.04, 0.5, 2.0, 0.0, -1.0, math.nan, math.inf]),
)
def test_input_profile(text: str, duration_s: float) -> None:
    path = write("profile.csv", text)
    assert_clean(lambda: load_input_profile(path, 0.04, duration_s), str(path), "--duration")


@LOADERS
@given(text=csv_text(FRICTION_COLUMNS, cells) | st.text(max_size=40))
def test_friction_log(text: str) -> None:
    path = write("friction.csv", text)
    assert_clean(lambda: read_friction_log(path), str(path))


@LOADERS
@given(text=csv_text(UMBMARK_COLUMNS, cells) | st.text(max_size=40))
def test_umbmark_log(text: str) -> None:
    path = write("umbmark.csv", text)
    assert_clean(lambda: read_umbmark_log(path), str(path))


def test_unreadable_files() -> None:
    """Not UTF-8, a directory, a missing file: one line naming it, from every loader."""
    binary = write("binary.toml", b"\xff\xfe\x00name = 1\n")
    for path in (binary, WORK, WORK / "missing.toml"):
        for load in (load_vehicle, load_path, load_experiment, load_gains, read_friction_log, read_umbmark_log):
            assert_clean(functools.partial(load, path), str(path))
        assert_clean(functools.partial(load_input_profile, path, 0.04, 1.0), str(path))


# ----------------------------------------------------------------------------------------------------------------
# The command line, through main(argv)


def run_cli(argv: list[str], outputs: list[Path]) -> int:
    """``main(argv)``: exit 0/1, or exit 2 with one line on stderr (warnings aside) and no output written."""
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(argv)
    assert code in (0, 1, 2), (argv, code)
    if code == 2:
        lines = [line for line in err.getvalue().splitlines() if not line.startswith("agvctl: warning:")]
        assert len(lines) == 1 and lines[0].startswith("agvctl"), (argv, err.getvalue())
        for out in outputs:
            assert not out.exists(), (argv, out)
    return code


@contextlib.contextmanager
def scratch() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(dir=WORK) as d:
        yield Path(d)


EXISTING_FILE = write("existing.txt", "not an output\n")
flag_values = numbers.map(str) | words | st.text(max_size=6)


def out_target(d: Path) -> st.SearchStrategy[tuple[str, Path | None]]:
    """An output argument: a fresh file (must not appear on exit 2), an existing file or directory, a deep path."""
    return st.sampled_from(
        [
            (str(d / "out.file"), d / "out.file"),
            (str(d / "new" / "deeper" / "out.file"), d / "new"),
            (str(EXISTING_FILE), None),
            (str(WORK), None),
            ("", None),
        ]
    )


@st.composite
def vehicle_args(draw: st.DrawFn, d: Path) -> list[str]:
    args: list[str] = []
    choice = draw(st.sampled_from(["none", "none", "default", "mutated", "missing", "dir"]))
    if choice == "default":
        args += ["--vehicle", "default"]
    elif choice == "mutated":
        args += ["--vehicle", str(_write_in(d, "v.toml", draw(documents([VEHICLE_DOC]))))]
    elif choice == "missing":
        args += ["--vehicle", str(d / "missing.toml")]
    elif choice == "dir":
        args += ["--vehicle", str(d)]
    for s in draw(st.lists(overrides, max_size=2)):
        args += ["--set", s]
    return args


def _write_in(d: Path, name: str, text: str) -> Path:
    path = d / name
    path.write_text(text, encoding="utf-8")
    return path


@st.composite
def junk(draw: st.DrawFn) -> list[str]:
    return draw(st.lists(st.sampled_from(["--bogus", "-x", "extra", "--json", "--"]), max_size=1))


def params_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    return ["params", *data.draw(vehicle_args(d)), *data.draw(st.lists(st.just("--json"), max_size=1))], []


def plan_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    path = _write_in(d, "p.toml", data.draw(documents(PATH_DOCS)))
    target, fresh = data.draw(out_target(d))
    argv = ["plan", str(path), *data.draw(vehicle_args(d)), "--out", target]
    argv += data.draw(st.lists(st.sampled_from(["--json", "--force"]), max_size=2, unique=True))
    return argv, [fresh] if fresh else []


def simulate_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    duration = data.draw(st.sampled_from(["0.04", "0.12"]) | flag_values)
    argv = ["simulate", "--duration", duration, *data.draw(vehicle_args(d))]
    if data.draw(st.booleans()):
        text = data.draw(csv_text(("t_s", "da_left_v", "da_right_v"), cells))
        argv += ["--input", str(_write_in(d, "in.csv", text))]
    for flag in data.draw(st.lists(st.sampled_from(["--da-left", "--da-right"]), max_size=2, unique=True)):
        argv += [flag, data.draw(flag_values)]
    target, fresh = data.draw(out_target(d))
    return [*argv, "--out", target], [fresh] if fresh else []


def tune_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    """Margins and bandwidths; ``--plot`` names a file, so that a valid design is refused before it runs (a
    design takes a second; tests/test_tune.py runs valid ones)."""
    argv = ["tune", *data.draw(vehicle_args(d))]
    for flag in data.draw(
        st.lists(st.sampled_from(["--phase-margin", "--gain-margin", "--bandwidth"]), max_size=3, unique=True)
    ):
        argv += [flag, data.draw(flag_values)]
    return [*argv, "--out", str(d / "gains.toml"), "--plot", str(EXISTING_FILE)], [d / "gains.toml"]


def mass_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    argv = ["identify", "mass", *data.draw(vehicle_args(d))]
    for flag in data.draw(
        st.lists(
            st.sampled_from(["--left", "--right", "--castor", "--scale-stderr-kg", "--noise", "--seed"]),
            max_size=6,
            unique=True,
        )
    ):
        argv += [flag, data.draw(flag_values)]
    argv += data.draw(st.lists(st.sampled_from(["--simulate", "--json"]), max_size=2, unique=True))
    target, fresh = data.draw(out_target(d))
    return [*argv, "--out", target], [fresh] if fresh else []


def log_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    """``identify friction --log`` and ``identify umbmark --log`` on random logs and flags (the fit included)."""
    procedure = data.draw(st.sampled_from(["friction", "umbmark"]))
    columns = FRICTION_COLUMNS if procedure == "friction" else UMBMARK_COLUMNS
    log = _write_in(d, "log.csv", data.draw(csv_text(columns, cells)))
    argv = ["identify", procedure, "--log", str(log), *data.draw(vehicle_args(d))]
    extra = ["--noise", "--seed"] + (["--side-m", "--runs", "--method"] if procedure == "umbmark" else [])
    for flag in data.draw(st.lists(st.sampled_from(extra), max_size=3, unique=True)):
        argv += [flag, data.draw(flag_values | st.sampled_from(["exact", "first_order"]))]
    target, fresh = data.draw(out_target(d))
    return [*argv, "--out", target, "--json"], [fresh] if fresh else []


def run_check_argv(data: st.DataObject, d: Path) -> tuple[list[str], list[Path]]:
    """``run`` and ``check`` on mutated experiments, with an output that cannot be written (an existing file, a
    directory for the JUnit file), so that even a valid experiment is refused before anything runs."""
    exp = _write_in(d, "e.toml", data.draw(documents(EXPERIMENT_DOCS)))
    if data.draw(st.booleans()):
        return ["run", str(exp), "--out", str(EXISTING_FILE), "--no-plot"], []
    jobs = data.draw(st.sampled_from(["1", "0", "-1", "x"]))
    return ["check", str(exp), "--junit", str(WORK), "--json", str(d / "c.json"), "--jobs", jobs], [d / "c.json"]


COMMANDS = [params_argv, plan_argv, simulate_argv, tune_argv, mass_argv, log_argv, run_check_argv]
REFUSED = (tune_argv, run_check_argv)


@LOADERS
@given(data=st.data())
def test_command_line(data: st.DataObject) -> None:
    """Every command's arguments (files included) through main(argv)."""
    command = data.draw(st.sampled_from(COMMANDS))
    with scratch() as d:
        argv, outputs = command(data, d)
        code = run_cli([*argv, *data.draw(junk())], outputs)
    assert not (command in REFUSED and code != 2), argv


def test_help_and_version() -> None:
    assert run_cli(["--help"], []) == 0
    assert run_cli(["--version"], []) == 0
    assert run_cli(["identify", "mass", "-h"], []) == 0


# Cases the properties found (st.data() tests take no @example): each must end in exit 2 and one line.
REGRESSIONS = {
    "a path segment of 1e12 m": ["plan", "{d}/p.toml", "--out", "{d}/ref.csv"],
    "run --out naming an existing file": [
        "run",
        str(ROOT / "experiments" / "line.toml"),
        "--out",
        str(EXISTING_FILE),
        "--no-plot",
    ],
    "scale readings whose sum overflows": [
        "identify",
        "mass",
        "--left",
        "1e308",
        "--right",
        "1e308",
        "--castor",
        "1e308",
        "--out",
        "{d}/v.toml",
    ],
    "a duration too long to allocate": [
        "simulate",
        "--duration",
        "1e12",
        "--da-left",
        "1",
        "--da-right",
        "1",
        "--out",
        "{d}/log.csv",
    ],
    "a duration that overflows the sample count": [
        "simulate",
        "--duration",
        "1e308",
        "--da-left",
        "1",
        "--da-right",
        "1",
    ],
}


@pytest.mark.parametrize("argv", REGRESSIONS.values(), ids=REGRESSIONS.keys())
def test_cli_regressions(argv: list[str]) -> None:
    with scratch() as d:
        _write_in(d, "p.toml", toml_text({"segments": [{"type": "line", "length_m": 1e12}]}))
        args = [a.format(d=d) for a in argv]
        assert run_cli(args, [d / "ref.csv", d / "v.toml", d / "log.csv"]) == 2
