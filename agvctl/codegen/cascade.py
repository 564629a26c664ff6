"""An experiment's whole controller cascade as C99, where its pose controller is generated: the pose controller,
the reference it tracks as data, and one step function over it and the wheel loops.

:func:`experiment_cascade` builds the experiment's pose controller as a run builds it; where it is a unicycle law
(``pose = "ramsete"``, ``"ltv_lqr"`` or their ``_c`` twins) it renders the law's C
(:func:`~agvctl.controllers.baselines.c_unicycle.render_unicycle_c`), the reference's rows on the control grid
(``agv_reference.c``) and ``agv_cascade.{h,c}``: time (as the sample k), pose and measured motor speeds in, DA
voltages out, through the generated wheel loops. Other pose controllers have no generated step yet, and it says so.
"""

from __future__ import annotations

from dataclasses import dataclass

from agvctl.codegen.qp import QP_FOLDER, ExperimentQp
from agvctl.controllers.base import PoseController
from agvctl.controllers.baselines.c_unicycle import generated_prefix, render_unicycle_c
from agvctl.controllers.baselines.unicycle import UnicycleTracker
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.c_loops import PREFIX as LOOPS_PREFIX
from agvctl.controllers.registry import pose_controllers
from agvctl.params import SIDES
from agvctl.plant.codegen import c_templates
from agvctl.scenario.experiment import Experiment

__all__ = ["CASCADE_FILES", "ExperimentCascade", "experiment_cascade", "pose_controller_of"]

CASCADE_FILES = ("agv_cascade.h", "agv_cascade.c", "agv_reference.h", "agv_reference.c")
"""The files of the cascade's step and the reference, besides the pose controller's own."""


@dataclass(frozen=True)
class ExperimentCascade:
    """An experiment's controller cascade as C, or why there is none.

    Parameters
    ----------
    files : dict of str to str
        The pose controller's, the reference's and the cascade's files by name (empty: not generated).
    pose_prefix : str
        The pose controller's files' stem ("" when not generated).
    note : str
        What the cascade is, or why it was not generated.
    """

    files: dict[str, str]
    pose_prefix: str
    note: str

    @property
    def generated(self) -> bool:
        """Whether the cascade's step is generated."""
        return bool(self.files)


def pose_controller_of(experiment: Experiment) -> PoseController:
    """``experiment``'s pose controller, built as a run builds it (its registry entry, its settings, the controller's
    vehicle), for the generators to read.

    Parameters
    ----------
    experiment : Experiment
        The loaded experiment.

    Returns
    -------
    PoseController
        The controller, not yet reset.
    """
    spec = experiment.spec
    c = spec.controller
    kind = pose_controllers.resolve(c.pose, key="controller.pose", source=spec.source, base_dir=spec.base_dir)
    return kind.make(experiment.controller_vehicle, c.pose_settings)


def experiment_cascade(
    experiment: Experiment, controller: PoseController, *, generator: str, qp: ExperimentQp | None = None
) -> ExperimentCascade:
    """The controller cascade of ``experiment`` as C99, where its pose controller is generated.

    Parameters
    ----------
    experiment : Experiment
        The loaded experiment.
    controller : PoseController
        Its pose controller (:func:`pose_controller_of`).
    generator : str
        What writes the files (``"agvctl 0.2.0"``).
    qp : ExperimentQp or None
        The LTV MPC's QP folder (:func:`~agvctl.codegen.qp.experiment_qp`), whose pose controller the cascade calls.

    Returns
    -------
    ExperimentCascade
        The files, or why there are none.
    """
    spec, vehicle = experiment.spec, experiment.controller_vehicle
    if isinstance(controller, LtvMpcController):
        return _mpc_cascade(experiment, qp, generator)
    if generated_prefix(controller) is None or not isinstance(controller, UnicycleTracker):
        note = f"the pose controller {spec.controller.pose!r} has no generated step yet: it runs in agvctl"
        return ExperimentCascade({}, "", note)
    controller.reset(experiment.reference)
    origin = f"The pose controller of experiment {spec.name!r}."
    pose = render_unicycle_c(controller, origin=origin, generator=generator)
    values = {
        "experiment": spec.name,
        "generator": generator,
        "sample_period_s": f"{controller.sample_period_s:g}",
        "pose_prefix": pose.prefix,
        "loops_prefix": LOOPS_PREFIX,
        "rim_per_motor": [vehicle.rim_per_motor_rad(side) for side in SIDES],
        "rows": controller.reference_rows.tolist(),
        "mpc": False,
    }
    env = c_templates("agvctl.codegen")
    files = dict(pose.files)
    files.update({name: env.get_template(f"{name}.j2").render(values) for name in CASCADE_FILES})
    rows = len(controller.reference_rows)
    law = "the Ramsete law" if pose.prefix == "agv_ramsete" else "the LTV unicycle LQR and its gain schedule"
    note = f"{law}; the reference: {rows} samples, {8 * 7 * rows} bytes of constant data"
    return ExperimentCascade(files, pose.prefix, note)


MPC_POSE_PREFIX = "agv_mpc_pose"
"""The LTV MPC pose controller's files' stem in the QP folder."""


def _mpc_cascade(experiment: Experiment, qp: ExperimentQp | None, generator: str) -> ExperimentCascade:
    """The cascade over the LTV MPC whose QP folder ``qp`` holds (its pose controller on the path)."""
    spec, vehicle = experiment.spec, experiment.controller_vehicle
    if qp is None or qp.code is None:
        why = qp.note if qp is not None else "its QP is not generated"
        return ExperimentCascade({}, "", f"the LTV MPC's cascade needs its QP in C: {why}")
    values = {
        "experiment": spec.name,
        "generator": generator,
        "sample_period_s": f"{vehicle.control.sample_period_s:g}",
        "pose_prefix": MPC_POSE_PREFIX,
        "loops_prefix": LOOPS_PREFIX,
        "rim_per_motor": [vehicle.rim_per_motor_rad(side) for side in SIDES],
        "mpc": True,
    }
    env = c_templates("agvctl.codegen")
    files = {name: env.get_template(f"{name}.j2").render(values) for name in ("agv_cascade.h", "agv_cascade.c")}
    note = f"the LTV MPC on the path's tables and its docking manoeuvres', its QP, step and settings in {QP_FOLDER}/"
    return ExperimentCascade(files, MPC_POSE_PREFIX, note)
