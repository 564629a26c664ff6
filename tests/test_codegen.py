"""The compiled plant's code generation: the disk cache, and CasADi's virtual machine when no compiler works; the
compiled library of a tree of C files."""

import ctypes
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from agvctl.plant.codegen import c_compiler, compiled_library
from agvctl.plant.full import PlantOptions, parameter_vector, state_from_motor_speeds
from agvctl.plant.integrator import CompiledPlant, compiled_plant


def _sliding_and_sticking(vehicle):
    """A state with one motor sliding forward and one backward, and a held input that stops one of them."""
    x0 = state_from_motor_speeds(vehicle, (60.0, -25.0), (0.3, -0.2, 0.4))
    u = np.array([4.0, 0.5])
    return x0, u, parameter_vector(vehicle)


def test_without_a_compiler_the_plant_runs_in_casadis_vm_and_says_so(vehicle, tmp_path, monkeypatch):
    native = compiled_plant()  # compiled (or loaded) before the compiler disappears
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    with pytest.warns(RuntimeWarning, match="virtual machine"):
        vm = CompiledPlant(PlantOptions())
    assert list(tmp_path.iterdir()) == []  # nothing half-written left in the cache
    x0, u, p = _sliding_and_sticking(vehicle)
    ts = vehicle.control.sample_period_s
    # the same equations, evaluated by CasADi instead of the C compiler: equal to rounding
    for a, b in zip(vm.step(x0, u, p, ts), native.step(x0, u, p, ts), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)
    us = np.tile(u, (30, 1))
    for a, b in zip(vm.run(x0, us, p, ts), native.run(x0, us, p, ts), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_compiled_library_is_cached_and_reused(vehicle, tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    first = CompiledPlant(PlantOptions(centrifugal=False))
    libraries = sorted(tmp_path.iterdir())
    assert [f.suffix for f in libraries] == [".so"] and libraries[0].name.startswith("agv_plant_")
    stamp = libraries[0].stat().st_mtime_ns
    second = CompiledPlant(PlantOptions(centrifugal=False))  # same generated code: loads, does not rebuild
    assert sorted(tmp_path.iterdir()) == libraries and libraries[0].stat().st_mtime_ns == stamp
    x0, u, p = _sliding_and_sticking(vehicle)
    ts = vehicle.control.sample_period_s
    for a, b in zip(first.step(x0, u, p, ts), second.step(x0, u, p, ts), strict=True):
        np.testing.assert_array_equal(a, b)


def test_threads_calling_the_compiled_plant_at_once_get_their_own_results(vehicle):
    # the compiled calls release the GIL and reuse argument buffers: one set per thread, so concurrent runs of
    # different inputs give exactly what they give alone
    plant = compiled_plant()
    x0, u, p = _sliding_and_sticking(vehicle)
    ts = vehicle.control.sample_period_s
    inputs = [np.tile(u * scale, (300, 1)) for scale in (1.0, -0.5, 0.25, 2.0)]

    def stepped(us):
        x, rows = x0, []
        for row in us:
            x, aux, stats = plant.step(x, row, p, ts)
            rows.append(np.concatenate([x, aux, stats]))
        return np.array(rows), *plant.run(x0, us, p, ts)

    alone = [stepped(us) for us in inputs]
    with ThreadPoolExecutor(max_workers=4) as pool:
        together = list(pool.map(stepped, inputs))
    for a, b in zip(alone, together, strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_array_equal(x, y)


@pytest.mark.skipif(c_compiler() is None, reason="no C compiler (cc/gcc) on this machine")
def test_a_tree_of_c_files_compiles_together_with_its_header_folders_on_the_include_path(tmp_path, monkeypatch):
    monkeypatch.setenv("AGVCTL_CACHE_DIR", str(tmp_path))
    tree = {
        "inc/twice.h": "double twice(double x);\n",
        "src/twice.c": '#include "twice.h"\ndouble twice(double x) { return 2.0 * x; }\n',
        "api.c": '#include "twice.h"\ndouble four_times(double x) { return twice(twice(x)); }\n',
    }
    lib = compiled_library(tree, "tree_example")
    lib.four_times.restype = ctypes.c_double
    lib.four_times.argtypes = [ctypes.c_double]
    assert lib.four_times(1.5) == 6.0
    with pytest.raises(ValueError, match="not a path inside the source tree"):
        compiled_library({"../outside.c": "int x;\n"}, "tree_example")
