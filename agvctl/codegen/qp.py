"""An experiment's MPC QP solver as C, for ``agvctl codegen``: the LTV MPC built as a run builds it, set up on the
experiment's reference, and its QP generated (:func:`~agvctl.controllers.mpc.c_qp.generate_qp_c`) into the
folder :data:`QP_FOLDER` of the output with the QP's step (:func:`~agvctl.controllers.mpc.c_step.generate_step_c`),
the experiment's reference as its tables (:func:`~agvctl.controllers.mpc.c_step.generate_step_tables_c`) and the
controller's step on it (:func:`~agvctl.controllers.mpc.c_update.generate_update_c`,
:func:`~agvctl.controllers.mpc.c_update.generate_pose_c`), with their static memory as the compiler lays it out."""

from __future__ import annotations

import dataclasses
import shutil
import subprocess
from dataclasses import dataclass

import osqp

from agvctl.controllers.base import PoseController
from agvctl.controllers.mpc.c_qp import QpC, compile_qp_c, generate_qp_c
from agvctl.controllers.mpc.c_step import generate_step_c, generate_step_tables_c
from agvctl.controllers.mpc.c_update import generate_pose_c, generate_update_c
from agvctl.controllers.mpc.docking import BACKING_STEPS
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.osqp_fixes import OSQP_VERSION
from agvctl.plant.codegen import c_compiler
from agvctl.scenario.experiment import Experiment

__all__ = ["QP_FOLDER", "ExperimentQp", "experiment_qp"]

QP_FOLDER = "mpc_qp"
"""The output's folder of the QP solver's files."""

_STATIC_SYMBOLS = frozenset("bBdDrR")
"""``nm``'s types of static storage: zeroed (bss), initialised (data) and read-only (rodata) objects."""


@dataclass(frozen=True)
class ExperimentQp:
    """The QP solver of an experiment's pose controller as C, or why there is none.

    Parameters
    ----------
    code : QpC or None
        The generated files (None: not generated, ``note`` says why).
    note : str
        What the solver is of, or why it was not generated.
    static_bytes : int or None
        The bytes of static storage of the compiled solver, its workspace, its step and the reference's tables included
        (None: not measured).
    n_tables : int
        The reference's tables the step reads (0: none generated).
    table_bytes : int or None
        The bytes of ``static_bytes`` that are the reference's tables and the QP's vectors as set up for it (None: not
        measured).
    """

    code: QpC | None
    note: str
    static_bytes: int | None
    n_tables: int = 0
    table_bytes: int | None = None


def _static_bytes(code: QpC, step_prefix: str) -> tuple[int, int] | tuple[None, None]:
    """The compiled folder's static storage, summed over its symbols, and the part of it that is the reference's
    tables (``<step_prefix>_reference_*`` and ``<step_prefix>_tables``); None without a compiler or ``nm``."""
    nm = shutil.which("nm")
    if nm is None or c_compiler() is None:
        return None, None
    library = compile_qp_c(code)._name
    listed = subprocess.run([nm, "-S", "--defined-only", library], capture_output=True, text=True, check=True).stdout
    total = tables = 0
    for line in listed.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[2] in _STATIC_SYMBOLS:
            size, name = int(parts[1], 16), parts[3]
            total += size
            if name.startswith(f"{step_prefix}_reference_") or name == f"{step_prefix}_tables":
                tables += size
    return total, tables


def experiment_qp(
    experiment: Experiment,
    controller: PoseController,
    *,
    generator: str,
    measure_memory: bool = True,
    single: bool = False,
) -> ExperimentQp:
    """The QP solver of ``experiment``'s LTV MPC as C99.

    Parameters
    ----------
    experiment : Experiment
        The loaded experiment.
    controller : PoseController
        Its pose controller, built as a run builds it (:func:`~agvctl.codegen.cascade.pose_controller_of`).
    generator : str
        What writes the files (``"agvctl 0.2.0"``).
    measure_memory : bool
        Compile the solver (once, into the cache of compiled code) to measure its static storage.
    single : bool
        Generate the solver in single precision (``float``).

    Returns
    -------
    ExperimentQp
        The files, or why there are none: a pose controller other than the LTV MPC, or an OSQP release other than
        the one the generator's fixes are written for.
    """
    c, spec = experiment.spec.controller, experiment.spec
    if not isinstance(controller, LtvMpcController):
        return ExperimentQp(None, f"the pose controller {c.pose!r} solves no QP of its own to generate", None)
    if osqp.__version__ != OSQP_VERSION:
        return ExperimentQp(
            None, f"the QP's C is generated with osqp {OSQP_VERSION}; osqp {osqp.__version__} is installed", None
        )
    controller.reset(experiment.reference)  # the QP of this path: its body-rate rows where the path limits the body
    origin = f"The QP of the LTV MPC of experiment {spec.name!r}."
    code = generate_qp_c(controller.qp, controller.osqp_settings, origin=origin, generator=generator, single=single)
    step = generate_step_c(controller.step_parts, origin=origin, generator=generator)
    update = generate_update_c(controller.step_parts, origin=origin, generator=generator)
    path_tables, path_last_start, settings = controller.step_tables(), controller.last_start, controller.c_settings()
    docking, manoeuvres = controller.c_docking()  # last: it tracks each manoeuvre
    tables = generate_step_tables_c(
        step,
        controller.qp,
        path_tables,
        path_last_start,
        rho=float(controller.osqp_settings["rho"]),
        origin=f"the reference of experiment {spec.name!r}.",
        generator=generator,
        manoeuvres=manoeuvres,
        first_steps=BACKING_STEPS[0],
    )
    pose = generate_pose_c(
        update,
        settings,
        sample_period_s=controller.sample_period_s,
        duration_s=experiment.reference.duration_s,
        docking=docking,
        experiment=spec.name,
        generator=generator,
    )
    code = dataclasses.replace(code, files={**code.files, **step.files, **tables, **update.files, **pose})
    horizon = controller.config.horizon
    precision = "single precision (float)" if single else "double precision"
    note = f"n = {code.n_variables} variables, m = {code.n_constraints} constraints, horizon N = {horizon}, {precision}"
    total, tables_bytes = _static_bytes(code, step.prefix) if measure_memory else (None, None)
    return ExperimentQp(code, note, total, len(step.table_names), tables_bytes)
