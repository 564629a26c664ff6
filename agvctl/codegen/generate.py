"""``agvctl codegen``'s API: an experiment's PI wheel loops, its pose controller where it is generated, and its MPC's
QP solver as a folder of C99 for the vehicle.

:func:`generate_code` loads an experiment, builds its wheel loops as a run would (the gains designed or from its
gains file, its options, the controller's vehicle) and renders them as C
(:func:`~agvctl.controllers.pi.c_loops.render_wheel_loops_c`), with a README naming the experiment and the agvctl
version, an example caller and a Makefile. Where the pose controller is generated (the Ramsete law), the folder holds
the whole cascade (:func:`~agvctl.codegen.cascade.experiment_cascade`): the law, the reference as data, and one step
function from pose and motor speeds to DA voltages. Where the pose controller is the LTV MPC, the folder
:data:`~agvctl.codegen.qp.QP_FOLDER` holds the QP it solves each step, as OSQP's generated solver
(:func:`~agvctl.codegen.qp.experiment_qp`), and the Makefile builds it into a static library. It returns the files'
texts; the command line writes them.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl import __version__
from agvctl.actuator import Actuator
from agvctl.codegen.cascade import ExperimentCascade, experiment_cascade, pose_controller_of
from agvctl.codegen.qp import QP_FOLDER, ExperimentQp, experiment_qp
from agvctl.controllers.base import PoseController
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.c_loops import (
    STRICT_C_FLAGS,
    StaticMemory,
    WheelLoopsC,
    render_wheel_loops_c,
    static_memory,
)
from agvctl.controllers.pi.options import FEEDFORWARD_RAMP_RAD_S
from agvctl.errors import ConfigError
from agvctl.plant.codegen import c_compiler, c_templates
from agvctl.scenario.experiment import Experiment, load_experiment

__all__ = ["GENERATED_FILES", "GENERATED_WHEEL_LOOPS", "GeneratedCode", "generate_code"]

GENERATED_FILES = ("agv_wheel_loops.h", "agv_wheel_loops.c", "example_main.c", "Makefile", "README.md")
"""The files :func:`generate_code` writes for every experiment, in this order (then, where the pose controller is
generated, the cascade's files, :data:`~agvctl.codegen.cascade.CASCADE_FILES`, and for the LTV MPC its QP's files
under :data:`~agvctl.codegen.qp.QP_FOLDER`)."""

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
        Every file of the output folder by its path in the folder (the wheel loops, ``example_main.c``,
        ``Makefile``, ``README.md``, and the QP solver's under ``mpc_qp/``).
    memory : StaticMemory or None
        The loops' static memory as the compiler lays it out (None: not measured).
    qp : ExperimentQp
        The MPC's QP solver, or why there is none.
    cascade : ExperimentCascade
        The whole cascade's step (the pose controller, the reference and the loops), or why there is none.
    """

    experiment: Experiment
    wheel_loops: WheelLoopsC
    files: dict[str, str]
    memory: StaticMemory | None
    qp: ExperimentQp
    cascade: ExperimentCascade


def _describe_memory(memory: StaticMemory | None) -> str:
    if memory is None:
        return "not measured (generated without a C compiler)"
    return f"state {memory.state_bytes} bytes (caller-owned), constants {memory.constant_bytes} bytes"


def _qp_values(qp: ExperimentQp) -> dict[str, Any]:
    """What the README and the Makefile say about the QP solver (its sources, objects and include folders)."""
    code = qp.code
    if code is None:
        return {"qp": False, "qp_note": qp.note}
    sources = [f"{QP_FOLDER}/{path}" for path in code.sources]
    return {
        "qp": True,
        "qp_folder": QP_FOLDER,
        "qp_prefix": code.prefix,
        "qp_note": qp.note,
        "qp_memory": "not measured" if qp.static_bytes is None else f"{qp.static_bytes} bytes",
        "qp_table_bytes": "not measured" if qp.table_bytes is None else f"{qp.table_bytes} bytes",
        "qp_includes": " ".join(f"-I{QP_FOLDER}/{d}" if d != "." else f"-I{QP_FOLDER}" for d in code.include_dirs),
        "qp_pairs": [(src, src.replace("/", "_").removesuffix(".c") + ".o") for src in sources],
        "qp_tables": qp.n_tables,
    }


def _cascade_values(cascade: ExperimentCascade, pose: PoseController) -> dict[str, Any]:
    """What the README, the example and the Makefile say about the cascade (over the MPC's folder, or not)."""
    return {
        "cascade": cascade.generated,
        "cascade_note": cascade.note,
        "pose_prefix": cascade.pose_prefix,
        "mpc": cascade.generated and isinstance(pose, LtvMpcController),
    }


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
    single: bool = False,
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
        Compile the loops and the QP solver (once, into the cache of compiled code) to measure their static memory,
        which the README states. Without a C compiler it is not measured.
    single : bool
        Generate the MPC's QP solver in single precision (``float``), for a processor without a double-precision
        unit. The wheel loops stay in double: a few dozen operations per sample, which a software ``double`` does
        in microseconds.

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
    >>> [name for name in code.files if not name.startswith("mpc_qp/")][:5]
    ['agv_wheel_loops.h', 'agv_wheel_loops.c', 'example_main.c', 'Makefile', 'README.md']
    >>> code.cascade.generated  # the LTV MPC's: agv_cascade.{h,c} over mpc_qp/
    True
    >>> "malloc" in code.files["agv_wheel_loops.c"], "mpc_qp/agv_mpc_qp.h" in code.files
    (False, True)
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
    pose = pose_controller_of(loaded)
    qp = experiment_qp(loaded, pose, generator=generator, measure_memory=measure_memory, single=single)
    cascade = experiment_cascade(loaded, pose, generator=generator, qp=qp)
    values = {
        **_readme_values(loaded, code, memory, generator),
        **_qp_values(qp),
        **_cascade_values(cascade, pose),
    }
    env = c_templates("agvctl.codegen")
    files = dict(code.files)
    for name in GENERATED_FILES[len(files) :]:
        files[name] = env.get_template(f"{name}.j2").render(values)
    files.update(cascade.files)
    if qp.code is not None:
        files.update({f"{QP_FOLDER}/{path}": text for path, text in qp.code.files.items()})
    return GeneratedCode(loaded, code, files, memory, qp, cascade)
