"""``agvctl codegen``'s API: an experiment's PI wheel loops as a folder of C99 for the vehicle.

:func:`generate_code` loads an experiment, builds its wheel loops as a run would (the gains designed or from its
gains file, its options, the controller's vehicle) and renders them as C
(:func:`~agvctl.controllers.pi.c_loops.render_wheel_loops_c`), with a README naming the experiment and the agvctl
version, an example caller and a Makefile. It returns the files' texts; the command line writes them.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl import __version__
from agvctl.actuator import Actuator
from agvctl.controllers.pi.c_loops import (
    STRICT_C_FLAGS,
    StaticMemory,
    WheelLoopsC,
    render_wheel_loops_c,
    static_memory,
)
from agvctl.controllers.pi.options import FEEDFORWARD_RAMP_RAD_S
from agvctl.errors import ConfigError
from agvctl.plant.codegen import c_compiler
from agvctl.scenario.experiment import Experiment, load_experiment

__all__ = ["GENERATED_FILES", "GENERATED_WHEEL_LOOPS", "GeneratedCode", "generate_code"]

GENERATED_FILES = ("agv_wheel_loops.h", "agv_wheel_loops.c", "example_main.c", "Makefile", "README.md")
"""The files :func:`generate_code` writes, in this order."""

GENERATED_WHEEL_LOOPS = ("pi", "pi_c")
"""The wheel loops an experiment may name for ``agvctl codegen``: the built-in PI loops (in Python or as C)."""


@dataclass(frozen=True)
class GeneratedCode:
    """The C generated for one experiment.

    Parameters
    ----------
    experiment : Experiment
        The experiment it was generated from.
    wheel_loops : WheelLoopsC
        The wheel loops' header and source.
    files : dict of str to str
        Every file of the output folder by name (the wheel loops, ``example_main.c``, ``Makefile``,
        ``README.md``).
    memory : StaticMemory or None
        The loops' static memory as the compiler lays it out (None: not measured).
    """

    experiment: Experiment
    wheel_loops: WheelLoopsC
    files: dict[str, str]
    memory: StaticMemory | None


@functools.cache
def _environment() -> Any:
    import jinja2

    return jinja2.Environment(
        loader=jinja2.PackageLoader("agvctl.codegen", "templates"),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )


def _describe_memory(memory: StaticMemory | None) -> str:
    if memory is None:
        return "not measured (generated without a C compiler)"
    return f"state {memory.state_bytes} bytes (caller-owned), constants {memory.constant_bytes} bytes"


def _readme_values(
    loaded: Experiment, code: WheelLoopsC, memory: StaticMemory | None, generator: str
) -> dict[str, str]:
    """What the README, the example and the Makefile say about the experiment and its loops."""
    spec, c, controller_vehicle = loaded.spec, loaded.spec.controller, loaded.controller_vehicle
    gains, options = loaded.wheel_loops.design.gains, loaded.wheel_loops.options
    act = Actuator(controller_vehicle)
    return {
        "experiment": spec.name,
        "source": os.path.basename(spec.source),
        "generator": generator,
        "prefix": code.prefix,
        "cflags": " ".join(STRICT_C_FLAGS),
        "sample_period_s": f"{gains.dt_s:g}",
        "quantum_v": f"{act.gain * act.volts_per_code:.4g}",
        "feedforward_ramp_rad_s": f"{FEEDFORWARD_RAMP_RAD_S:g}",
        "vehicle": controller_vehicle.name,
        "kp": f"{gains.kp:.6g}",
        "ki": f"{gains.ki:.6g}",
        "options": (
            f"coulomb_feedforward = {str(options.coulomb_feedforward).lower()}, braking = "
            f'"{options.braking.value}", steering_priority = {str(options.steering_priority).lower()}'
        ),
        "memory": _describe_memory(memory),
        "wheel_speed": c.wheel_speed,
        "pose": c.pose,
    }


def generate_code(
    experiment: str | Path,
    *,
    vehicle: str | Path | None = None,
    vehicle_overrides: Sequence[str] = (),
    measure_memory: bool = True,
) -> GeneratedCode:
    """The C99 of an experiment's PI wheel loops, with its gains and vehicle constants baked in.

    Parameters
    ----------
    experiment : str or Path
        The experiment file (TOML).
    vehicle : str, Path or None
        A vehicle file instead of the experiment's (as :func:`~agvctl.scenario.experiment.load_experiment`).
    vehicle_overrides : sequence of str
        Dotted-key changes of the vehicle, ``"KEY=VALUE"``.
    measure_memory : bool
        Compile the loops (once, into the cache of compiled code) to measure their static memory, which the README
        states. Without a C compiler it is not measured.

    Returns
    -------
    GeneratedCode
        The files of the output folder, by name, and the static memory.

    Raises
    ------
    ConfigError
        The experiment is invalid, or its ``controller.wheel_loops`` names loops other than the built-in PI loops.
    AgvctlError
        The generated code does not compile (with ``measure_memory``).

    Examples
    --------
    >>> code = generate_code("experiments/line.toml")
    >>> sorted(code.files)
    ['Makefile', 'README.md', 'agv_wheel_loops.c', 'agv_wheel_loops.h', 'example_main.c']
    >>> "malloc" in code.files["agv_wheel_loops.c"]
    False
    """
    loaded = load_experiment(experiment, vehicle=vehicle, vehicle_overrides=vehicle_overrides)
    spec = loaded.spec
    c = spec.controller
    if c.wheel_loops not in GENERATED_WHEEL_LOOPS:
        raise ConfigError(
            spec.source,
            "controller.wheel_loops",
            f"codegen generates the built-in PI loops ({' or '.join(map(repr, GENERATED_WHEEL_LOOPS))}), "
            f"not {c.wheel_loops!r}",
        )
    controller_vehicle = loaded.controller_vehicle
    python_loops = loaded.wheel_loops.controller(controller_vehicle)
    generator = f"agvctl {__version__}"
    origin = f"The PI wheel loops of experiment {spec.name!r} ({os.path.basename(spec.source)})."
    code = render_wheel_loops_c(python_loops, origin=origin, generator=generator)
    memory = static_memory(code) if measure_memory and c_compiler() is not None else None
    values = _readme_values(loaded, code, memory, generator)
    env = _environment()
    files = dict(code.files)
    for name in GENERATED_FILES[len(files) :]:
        files[name] = env.get_template(f"{name}.j2").render(values)
    return GeneratedCode(loaded, code, files, memory)
