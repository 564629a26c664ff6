"""The LTV MPC pose controller's step as generated C99, around its QP's step (:mod:`~agvctl.controllers.mpc.c_step`).

What :meth:`MpcStepper.update <agvctl.controllers.mpc.common.MpcStepper.update>` computes around the solve, from one
template (``templates/mpc_update.{h,c}.j2``): the reference governor (:mod:`~agvctl.controllers.mpc.governor`), the
reachable-setpoint window (:class:`~agvctl.controllers.mpc.shaping.ReachWindow`), the previous command kept reachable,
the rest at the end of the path (:mod:`~agvctl.controllers.mpc.rest`), the QP's step or a fallback
(:class:`~agvctl.controllers.mpc.fallback.SetpointFallback`), and the command shaper: the rules of motion
(:class:`~agvctl.controllers.mpc.shaping.NoBackingAtStart`,
:class:`~agvctl.controllers.mpc.shaping.TowardTurningPoint`), the window, the body's bounds
(:meth:`~agvctl.controllers.mpc.body_bounds.BodyBounds.command`) and the hard limits
(:func:`~agvctl.controllers.mpc.fallback.limit_command`). Deciding on and planning a docking manoeuvre
(:class:`~agvctl.controllers.mpc.docking.EndOfPath`) stays with the caller, which starts the manoeuvre's tables.

What the controller is and what a path sets are numbers in one array, :data:`UPDATE_SETTINGS` by name, filled by the
controller; the template's indices come from the same names.
"""

from __future__ import annotations

import math

from agvctl.controllers.mpc.body_bounds import NEAR_REST_SPEED_M_S
from agvctl.controllers.mpc.c_step import MpcPartC, StepParts
from agvctl.controllers.mpc.docking import BACKING_STEP_M
from agvctl.plant.codegen import c_templates

__all__ = ["UPDATE_SETTINGS", "WHEEL_CONSTANTS", "generate_pose_c", "generate_update_c"]

PREFIX = "agv_mpc"
"""The controller step's stem and the prefix of the names it defines."""

WHEEL_CONSTANTS = ("r_n", "k_e", "resistance", "k_t", "f_m", "tau_c", "tau_s", "j_tot")
"""Each wheel's reach constants by name, in the order of :attr:`WheelReach.constants
<agvctl.feasibility.WheelReach.constants>`: r/n, k_e, R, k_t, f_m, τ_c, τ_s, J_tot."""

UPDATE_SETTINGS = (
    "sample_period_s",
    "separation_m",
    "max_speed_m_s",
    "governor",
    "lag_start_m",
    "lag_stop_m",
    "catch_up",
    "lead_factor_s",
    "u_fs_v",
    "i_max_a",
    *(f"reach_left_{name}" for name in WHEEL_CONSTANTS),
    *(f"reach_right_{name}" for name in WHEEL_CONSTANTS),
    "rest_enabled",
    "rest_max_error_m",
    "rest_stopped_m_s",
    "rest_enter",
    "rest_release",
    "rest_tolerance_x",
    "rest_tolerance_y",
    "rest_tolerance_theta",
    "body_shaped",
    "max_step_m_s",
    "body_active",
    "body_mean_step",
    "body_difference_step",
    "body_lateral",
    "body_breakaway_share",
    "rest_end_x",
    "rest_end_y",
    "rest_end_theta",
)
"""The controller's numbers by name, in the order of the C array: its vehicle and settings (the governor, the wheels'
reach, the rest), then what each path sets (a_lim·T_s, the body's bounds, the end pose to rest at)."""


def generate_update_c(
    parts: StepParts,
    *,
    origin: str,
    generator: str,
    prefix: str = PREFIX,
    step_prefix: str = "agv_mpc_step",
    qp_prefix: str = "agv_mpc_qp",
) -> MpcPartC:
    """The C99 of the controller's step around the QP's step (see the module's description).

    Parameters
    ----------
    parts : StepParts
        The QP and the controller's constants (its horizon).
    origin : str
        What the controller is of, written into the files.
    generator : str
        What wrote them.
    prefix : str
        The stem and the names' prefix.
    step_prefix : str
        The QP step's prefix (:func:`~agvctl.controllers.mpc.c_step.generate_step_c`).
    qp_prefix : str
        The QP solver's prefix.

    Returns
    -------
    MpcPartC
        The files.
    """
    macro = prefix.upper()
    values = {
        "prefix": prefix,
        "macro": macro,
        "guard": f"{macro}_H",
        "step_prefix": step_prefix,
        "step_macro": step_prefix.upper(),
        "qp_prefix": qp_prefix,
        "origin": origin,
        "generator": generator,
        "settings": UPDATE_SETTINGS,
        "horizon": parts.horizon,
        "pi": math.pi,
        "near_rest": NEAR_REST_SPEED_M_S,
    }
    env = c_templates("agvctl.controllers.mpc")
    files = {
        f"{prefix}.h": env.get_template("mpc_update.h.j2").render(values),
        f"{prefix}.c": env.get_template("mpc_update.c.j2").render(values),
    }
    return MpcPartC(files, prefix, parts.horizon)


def generate_pose_c(
    update: MpcPartC,
    settings: dict[str, float],
    *,
    sample_period_s: float,
    duration_s: float,
    docking: dict[str, float] | None,
    experiment: str,
    generator: str,
    prefix: str = "agv_mpc_pose",
    step_prefix: str = "agv_mpc_step",
    qp_prefix: str = "agv_mpc_qp",
) -> dict[str, str]:
    """The pose controller of one path as C99 (``<prefix>.{h,c}``): the controller's step with its settings as
    ``static const`` data, on the path's tables, one call per sample from the sample k, the pose and the wheel speeds,
    and at the path's end what :class:`~agvctl.controllers.mpc.docking.EndOfPath` decides: done, or a docking
    manoeuvre among those planned ahead (the step's docking tables, :func:`~agvctl.controllers.mpc.c_step.
    generate_step_tables_c`).

    Parameters
    ----------
    update : MpcPartC
        The controller's step.
    settings : dict of str to float
        Its numbers (:meth:`LtvMpcController.c_settings <agvctl.controllers.mpc.ltv.LtvMpcController.c_settings>`,
        after the reset on the path).
    sample_period_s : float
        T_s, s.
    duration_s : float
        The path's duration, s.
    docking : dict of str to float or None
        What deciding on a manoeuvre takes (:attr:`Docking.constants
        <agvctl.controllers.mpc.docking.Docking.constants>`); None: no docking.
    experiment : str
        The experiment's name, written into the files.
    generator : str
        What wrote them.
    prefix : str
        The files' stem and the names' prefix.
    step_prefix : str
        The QP step's prefix (its tables' too).
    qp_prefix : str
        The QP solver's prefix.

    Returns
    -------
    dict of str to str
        ``{file name: text}``.
    """
    values = {
        "prefix": prefix,
        "guard": f"{prefix.upper()}_H",
        "update_prefix": update.prefix,
        "update_macro": update.prefix.upper(),
        "step_prefix": step_prefix,
        "qp_prefix": qp_prefix,
        "experiment": experiment,
        "generator": generator,
        "settings": [(name, settings[name]) for name in UPDATE_SETTINGS],
        "sample_period": sample_period_s,
        "sample_period_s": f"{sample_period_s:g}",
        "duration": duration_s,
        "docking": docking,
        "attempts": int(docking["docking_attempts"]) if docking is not None else 0,
        "step_m": BACKING_STEP_M,
        "pi": math.pi,
    }
    env = c_templates("agvctl.controllers.mpc")
    return {
        f"{prefix}.h": env.get_template("mpc_pose.h.j2").render(values),
        f"{prefix}.c": env.get_template("mpc_pose.c.j2").render(values),
    }
