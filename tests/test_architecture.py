"""The package's shape: no import cycle (imports inside functions included), no long module or function."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent.parent / "agvctl"
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 80
BEING_SPLIT: frozenset[str] = frozenset()
"""Modules exempt from the length limits (none)."""


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out[name] = path
    return out


def _imports(path: Path, name: str, modules: dict[str, Path]) -> set[str]:
    """The agvctl modules ``name`` imports anywhere in its body, functions and ``if TYPE_CHECKING:`` blocks
    included (``from pkg import sub`` counts ``pkg.sub``)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(
                    [*package.split(".")[: len(package.split(".")) - node.level + 1], *filter(None, [base])]
                )
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return {m for m in found if m in modules and m != name}


def test_no_import_cycle_between_modules() -> None:
    modules = _modules()
    graph = {name: _imports(path, name, modules) for name, path in modules.items()}
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycle = path[path.index(nxt) :] + [nxt]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if nxt not in state:
                visit(nxt)
        path.pop()
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name)
    # the walk sees imports inside functions too: sim.experiment → sim.controllers would be caught either way
    assert "agvctl.controllers.registry" in graph["agvctl.scenario.experiment"]


def test_no_module_or_function_too_long() -> None:
    long_modules, long_functions = [], []
    for name, path in _modules().items():
        if name in BEING_SPLIT:
            continue
        text = path.read_text(encoding="utf-8")
        if len(text.splitlines()) > MAX_MODULE_LINES:
            long_modules.append(f"{name}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = (node.end_lineno or node.lineno) - node.lineno + 1
                if length > MAX_FUNCTION_LINES:
                    long_functions.append(f"{name}.{node.name}: {length} lines")
    assert not long_modules and not long_functions, long_modules + long_functions


def test_the_loop_probes_no_component_for_hidden_attributes() -> None:
    # the optional parts of controllers and estimators are protocols, checked once at set-up
    for module in ("sim/loop.py", "sim/records.py", "estimation/base.py"):
        tree = ast.parse((PACKAGE / module).read_text(encoding="utf-8"))
        probes = [
            node.lineno
            for node in ast.walk(tree)
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "hasattr")
        ]
        assert not probes, f"{module}: getattr/hasattr at lines {probes}"


def test_estimators_receive_what_a_real_one_would() -> None:
    import dataclasses
    import inspect

    from agvctl.estimation.base import WheelSpeedEstimator
    from agvctl.sensing import Measurements

    assert not [f.name for f in dataclasses.fields(Measurements) if f.name.startswith("true")]
    assert list(inspect.signature(WheelSpeedEstimator.update).parameters) == ["self", "encoder_counts"]


def test_only_the_mpc_strategies_ask_which_prediction_model_or_error_frame_is_in_use() -> None:
    # the prediction model and the error frame are strategies chosen once by name: nothing else compares the name
    chooser = {"prediction.py", "error_frames.py"}
    asks = []
    for path in sorted((PACKAGE / "controllers" / "mpc").glob("*.py")):
        if path.name in chooser:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Compare):
                names = [n.attr for n in ast.walk(node) if isinstance(n, ast.Attribute)]
                if "prediction_model" in names or "error_frame" in names:
                    asks.append(f"{path.name}:{node.lineno}")
    assert not asks, asks


def test_a_worker_of_the_gate_imports_neither_python_control_nor_matplotlib() -> None:
    """Every worker of ``check``, ``fuzz`` and ``tune`` imports the run's code as it starts and designs the default
    wheel loops at its first run; python-control (which imports matplotlib's pyplot) is for the linear models and
    the tuning reports only, so a worker does neither with it."""
    import subprocess
    import sys

    code = (
        "import sys, agvctl.fuzz.run, agvctl.checks.runner, agvctl.cli; "
        "from agvctl.params import load_vehicle; "
        "from agvctl.controllers.pi.tuning import default_pi_gains; "
        "default_pi_gains(load_vehicle(None)); "
        "print(sorted(m for m in ('control', 'matplotlib', 'optuna', 'dask') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=PACKAGE.parent)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
