"""The LTV MPC's QP solver as generated C: OSQP's code generation, fixed to compile with warnings as errors, holds no
heap and no I/O, and solves the steps of the figure-8 closed loop as the Python OSQP solver does."""

from __future__ import annotations

import re
import shutil
import subprocess
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import osqp
import pytest

from agvctl.controllers.mpc.c_qp import STRICT_C_FLAGS, generate_qp_c, write_qp_c
from agvctl.controllers.mpc.c_solver import CompiledQp, QpSolution
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.osqp_fixes import OSQP_FIXES, OSQP_VERSION, SourceFix
from agvctl.errors import AgvctlError
from agvctl.plant.codegen import c_compiler
from agvctl.scenario.experiment import load_experiment, run_experiment

needs_cc = pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")
pytestmark = pytest.mark.skipif(
    osqp.__version__ != OSQP_VERSION, reason=f"the QP's C is generated with osqp {OSQP_VERSION} only"
)

ALLOWED_EXTERNAL_SYMBOLS = {"sqrt", "memset", "memcpy"}
"""What the compiled solver may take from outside its own objects: libm's sqrt and what the compiler emits for
struct and array copies."""


@pytest.fixture(scope="module")
def figure8():
    return load_experiment("experiments/figure8.toml")


def _controller(experiment, **osqp_settings: Any) -> LtvMpcController:
    return LtvMpcController(
        experiment.controller_vehicle, experiment.spec.controller.pose_settings, osqp_settings=osqp_settings
    )


@dataclass
class _SideBySide:
    """Stands in for the controller's OSQP solver: hands every call to it and the same updates, warm starts and step
    sizes to the generated C solver, and keeps both answers of every solve (``cold``: the C solver starts each solve
    from zero instead)."""

    python: Any
    c: CompiledQp
    cold: bool = False
    steps: list[tuple[Any, QpSolution]] = field(default_factory=list)
    matrices: list[tuple[bool, bool]] = field(default_factory=list)
    """Per solve: whether P's, and A's, varying entries were handed over."""
    _update: dict[str, Any] = field(default_factory=dict)

    def update(self, **arguments: Any) -> None:
        self.python.update(**arguments)
        self._update = arguments

    def warm_start(self, x: Any, y: Any) -> None:
        self.python.warm_start(x=x, y=y)
        self.c.warm_start(x, y)

    def update_settings(self, **settings: Any) -> None:
        self.python.update_settings(**settings)
        self.c.set_rho(settings.pop("rho"))
        assert not settings, "only the step size changes during a run"

    def solve(self, raise_error: bool = False) -> Any:
        result = self.python.solve(raise_error=raise_error)
        u = self._update
        if self.cold:
            self.c.warm_start(np.zeros_like(result.x), np.zeros_like(result.y))
        self.steps.append((result, self.c.solve(u["q"], u["l"], u["u"], u.get("Px"), u.get("Ax"))))
        self.matrices.append(("Px" in u, "Ax" in u))
        return result


def _side_by_side_run(
    experiment, *, prefix: str, cold: bool = False, **osqp_settings: Any
) -> tuple[_SideBySide, LtvMpcController]:
    """The figure-8 closed loop with its MPC's solver beside a C solver generated for its QP (``prefix``: each run
    its own generated code, so its own library and static workspace)."""
    controller = _controller(experiment, **osqp_settings)
    code = generate_qp_c(
        controller._qp, controller.osqp_settings, origin="figure8 (tests)", generator="agvctl tests", prefix=prefix
    )
    side = _SideBySide(controller._solver, CompiledQp(code), cold=cold)
    controller._solver = side
    run_experiment(experiment, pose_controller=controller)
    return side, controller


@pytest.fixture(scope="module")
def warm_run(figure8):
    return _side_by_side_run(figure8, prefix="agv_mpc_qp_warm")


@needs_cc
def test_the_generated_solver_compiles_with_warnings_as_errors_and_needs_no_heap_no_io(figure8, tmp_path):
    controller = _controller(figure8)
    code = write_qp_c(tmp_path, controller._qp, controller.osqp_settings, origin="figure8", generator="agvctl")
    includes = [f"-I{d}" for d in code.include_dirs]
    objects = []
    for source in code.sources:
        obj = tmp_path / (source.replace("/", "_") + ".o")
        done = subprocess.run(
            [c_compiler(), *STRICT_C_FLAGS, *includes, "-c", source, "-o", str(obj)],
            cwd=tmp_path,
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0 and done.stderr == "", f"{source}: {done.stderr}"
        objects.append(str(obj))
    assert len(objects) == 15  # OSQP's 13 library sources, the workspace and the entry point
    if shutil.which("nm") is None:
        pytest.skip("no nm to list the objects' symbols")

    def symbols(*options: str) -> set[str]:
        out = subprocess.run(["nm", *options, *objects], check=True, capture_output=True, text=True).stdout
        return {line.split()[-1] for line in out.splitlines() if re.match(r"^\s*[0-9a-f]*\s+[A-Za-z]\s+\S+$", line)}

    external = symbols("-u") - symbols("--defined-only")
    assert external <= ALLOWED_EXTERNAL_SYMBOLS, external
    assert "sqrt" in external  # the check sees the objects' symbols at all


@needs_cc
def test_without_the_fixes_each_file_they_change_warns(figure8, tmp_path):
    """OSQP's files as generated, compiled with the strict flags less ``-Werror``: every file a warning fix changes
    warns (17 warnings with gcc 12), so none of the fixes is there for nothing."""
    controller = _controller(figure8)
    fixes = [fix for fix in OSQP_FIXES if fix.reason.startswith("-W")]
    code = write_qp_c(
        tmp_path, controller._qp, controller.osqp_settings, origin="figure8", generator="agvctl", fixes=()
    )
    includes = [f"-I{d}" for d in code.include_dirs]
    flags = [f for f in STRICT_C_FLAGS if f != "-Werror"]
    for path in sorted({fix.path.format(workspace=f"{code.prefix}_workspace") for fix in fixes}):
        done = subprocess.run(
            [c_compiler(), *flags, *includes, "-c", path, "-o", "/dev/null"],
            cwd=tmp_path,
            capture_output=True,
            text=True,
        )
        assert done.returncode == 0 and "warning:" in done.stderr, path


def test_the_same_qp_generates_the_same_files(figure8):
    """OSQP writes the generation time into its files; the generator replaces it, so the cached library of a QP is
    reused across runs."""
    controller = _controller(figure8)
    first, second = (
        generate_qp_c(controller._qp, controller.osqp_settings, origin="figure8", generator="agvctl") for _ in range(2)
    )
    assert first.files == second.files
    assert not any("autogenerated by OSQP on" in text for text in first.files.values())
    assert not any(name.endswith("emosqp.c") for name in first.files)  # OSQP's example caller prints: left out


def test_a_fix_whose_text_osqp_no_longer_writes_fails_loudly():
    with pytest.raises(AgvctlError, match="not the text the fix expects"):
        OSQP_FIXES[0].apply("/* an OSQP whose auxil.c was rewritten */")
    twice = SourceFix("x.c", "a", "b", 1, "an example")
    with pytest.raises(AgvctlError, match="2 matches, not 1"):
        twice.apply("aa")


@needs_cc
def test_warm_started_alike_the_c_solver_gives_the_python_solvers_answers_bit_for_bit(warm_run):
    """Every solve of the figure-8 closed loop: the C solver, generated from the state of a Python solver just set
    up on the same QP and given the same updates, warm starts and step sizes, ends with the same status after the
    same iterations at the same primal and dual solution, to the last bit: the same code on the same data."""
    side, _ = warm_run
    assert len(side.steps) > 600
    p_updates, a_updates = np.sum(side.matrices, axis=0)
    assert p_updates >= 1 and a_updates > 100  # both matrices' updates are exercised (A's wherever curvature changes)
    for python, c in side.steps:
        assert c.status == python.info.status_val == 1
        assert c.iterations == python.info.iter
        np.testing.assert_array_equal(c.x, python.x)
        np.testing.assert_array_equal(c.y, python.y)


@needs_cc
def test_at_the_iteration_limit_the_c_solver_says_so_and_stays_with_the_python_one_through_the_fallback(figure8):
    """With 20 iterations at most, some steps stop solved inaccurately and some at the limit, which the controller
    answers with its fallback and a warm start from zero: the C solver reports the same statuses, and is given the
    same warm starts, so every solution stays bit-identical."""
    side, _ = _side_by_side_run(figure8, prefix="agv_mpc_qp_limit", max_iter=20)
    statuses = [python.info.status_val for python, _ in side.steps]
    assert statuses.count(osqp.SolverStatus.OSQP_MAX_ITER_REACHED) > 0
    assert statuses.count(osqp.SolverStatus.OSQP_SOLVED_INACCURATE) > 0
    for python, c in side.steps:
        assert c.status == python.info.status_val and c.iterations == python.info.iter
        np.testing.assert_array_equal(c.x, python.x)
        np.testing.assert_array_equal(c.y, python.y)


@needs_cc
def test_started_from_zero_the_c_solver_solves_each_step_within_osqps_tolerance(figure8, warm_run):
    """The C solver started from zero at every solve, the Python one from its last solution: both solve every step,
    and their solutions agree within 10 ε, ε = 10⁻³ the controller's ``eps_abs`` = ``eps_rel``. Each passes OSQP's
    test, primal and dual residuals within ε_abs + ε_rel·(the norms of Az, z, Pz, Aᵀy and q, of order 1 here in m/s,
    m and rad), so 2ε each; two such points differ by at most the sum of their distances from the optimum, 4ε times
    the magnification by the QP's conditioning, for which the bound leaves a factor 2.5 (measured: 1.7·10⁻³). The
    first setpoints, the ones applied, agree within 10⁻³ m/s, the bound ``tests/test_mpc.py`` sets for a solver that
    refactorises (measured: 4·10⁻⁵)."""
    side, controller = _side_by_side_run(figure8, prefix="agv_mpc_qp_cold", cold=True)
    eps = controller.config.tolerance
    first = slice(controller._i_setpoints, controller._i_setpoints + 2)
    assert len(side.steps) == len(warm_run[0].steps)
    iterations = []
    for python, c in side.steps:
        assert c.status == python.info.status_val == 1
        assert np.max(np.abs(c.x - python.x)) < 10 * eps
        assert np.max(np.abs(c.x[first] - python.x[first])) < 1e-3
        iterations.append((c.iterations, python.info.iter))
    cold, warm = np.median(iterations, axis=0)
    assert cold > warm  # the C solver did start from zero: warm starting is what saves iterations


def test_without_a_compiler_the_c_solver_says_so_in_one_line(figure8, tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    controller = _controller(figure8)
    code = generate_qp_c(controller._qp, controller.osqp_settings, origin="figure8", generator="agvctl")
    with pytest.raises(AgvctlError, match="cannot be compiled") as caught:
        CompiledQp(code)
    assert "\n" not in str(caught.value)
    assert list(tmp_path.iterdir()) == []  # nothing half-written left in the cache
