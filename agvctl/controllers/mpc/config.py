"""The MPC pose controllers' settings (:class:`MpcConfig`, an experiment file's ``[controller]`` keys) and the
figures derived from them: the wheel-loop time constant, the setpoints' reachable lead and the speed and acceleration
limits (see :mod:`agvctl.controllers.mpc.common` for the problem they set)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

from agvctl.config import check_fields, document_fields, number
from agvctl.controllers.mpc.docking import DockingConfig
from agvctl.controllers.mpc.rest import RestConfig
from agvctl.controllers.ranges import (
    MAX_ACCEL_M_S2,
    MAX_DISTANCE_M,
    MAX_SCALE,
    MAX_SOLVE_TIME_S,
    MAX_WEIGHT,
    MAX_WHEEL_SPEED_M_S,
    MIN_ACCEL_M_S2,
    MIN_SOLVE_TIME_S,
    MIN_WHEEL_SPEED_M_S,
)
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams

__all__ = [
    "DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S",
    "ErrorFrame",
    "MpcConfig",
    "PredictionModel",
    "QpSolver",
    "check_ltv_settings",
    "check_nmpc_settings",
    "resolved_config",
    "resolved_limits",
    "wheel_loop_time_constant_s",
]

PredictionModel = Literal["kinematic", "kinematic+wheel_loop"]
ErrorFrame = Literal["path", "world"]
QpSolver = Literal["osqp", "osqp_c", "osqp_c_float"]


@document_fields
@dataclass(frozen=True)
class MpcConfig:
    """Settings of the MPC pose controllers, as in an experiment file's ``[controller]`` table (SI units).

    Weights are per squared unit of their quantity: position 1/m², heading 1/rad², input and input rate
    1/(m/s)²; the reversal weight, a linear cost, per m/s. Only their ratios matter. Every number has a range
    (:mod:`agvctl.controllers.ranges` gives each one's reason): weights at most 10⁶, limits from 1 mm/s (mm/s²)
    to 10 m/s (100 m/s²), time budgets and τ from 0.1 ms to 10 s, at most 10⁶ iterations (a tracking step needs
    tens, the hardest over a thousand).
    """

    horizon: int = number(
        ge=1, le=500, default=20, doc="N, the prediction and control horizon in samples (at most 500: 20 s at 40 ms)."
    )
    weight_position: float = number(
        ge=0, le=MAX_WEIGHT, default=1.0e3, doc="The weight on each predicted position error, 1/m²."
    )
    along_track_share: float = number(ge=0, le=1, default=0.4)
    """The along-path share of ``weight_position``: in the path frame, the along-path error is weighted
    ``along_track_share`` × ``weight_position`` and the cross-path error ``weight_position``; below 1, being on the
    path counts more than keeping time (the reference governor bounds the lag). The world frame weighs both axes
    alike."""
    turn_in_place_position_scale: float = number(ge=0, le=MAX_SCALE, default=3.0)
    """The scale of the position weight where the reference turns in place. There the path is the turning point,
    and any translation is off it: the LTV MPC weighs the position error this much more there, alike in every
    direction, so that a wheel at its current limit cannot slide the vehicle off the point
    (``docs/decisions/0004-path-frame-weights.md``)."""
    weight_heading: float = number(
        ge=0, le=MAX_WEIGHT, default=30.0, doc="The weight on each predicted heading error, 1/rad²."
    )
    weight_terminal_scale: float = number(
        ge=0,
        le=MAX_SCALE,
        default=1.0,
        doc="The factor on the position and heading weights at k = N (the terminal cost).",
    )
    weight_input: float = number(
        ge=0, le=MAX_WEIGHT, default=0.1, doc="w_u, the weight on each setpoint minus its feed-forward, 1/(m/s)²."
    )
    weight_input_rate: float = number(
        ge=0,
        le=MAX_WEIGHT,
        default=10.0,
        doc="w_Δ, the weight on each setpoint's change from the sample before, 1/(m/s)².",
    )
    weight_reversal: float = number(ge=0, le=MAX_WEIGHT, default=3.0)
    """w_r, the LTV MPC's weight on each setpoint's speed against its wheel's direction along the reference (the
    feed-forward's), 1/(m/s): a linear cost, zero on the reference, so that a small start-up correction blends into
    driving off instead of turning a wheel backwards while a large one still turns it. 0: none (the QP then has no
    reversal slacks). The NMPC has no such cost."""
    prediction_model: PredictionModel = "kinematic+wheel_loop"
    """The prediction model: the kinematics of eqs 39-43 driven by the setpoints directly (``"kinematic"``), or
    through the first-order lag v̇ = (s − v)/τ that stands for the closed wheel loops (``"kinematic+wheel_loop"``)."""
    wheel_loop_time_constant_s: float | None = number(ge=MIN_SOLVE_TIME_S, le=MAX_SOLVE_TIME_S, default=None)
    """τ of the closed wheel loop's lag in the ``"kinematic+wheel_loop"`` model, s. None (default): in an experiment,
    the best first-order fit to its own PI wheel loops; for a controller built directly,
    :data:`DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S`."""
    error_frame: ErrorFrame = "path"
    """The LTV MPC's error coordinates: along/across the reference heading (``path``) or x/y (``world``)."""
    max_wheel_speed_m_s: float | None = number(
        ge=MIN_WHEEL_SPEED_M_S,
        le=MAX_WHEEL_SPEED_M_S,
        default=None,
        doc="v_max, the largest setpoint of either wheel (None: the vehicle's max speed), m/s.",
    )
    max_wheel_accel_m_s2: float | None = number(
        ge=MIN_ACCEL_M_S2,
        le=MAX_ACCEL_M_S2,
        default=None,
        doc=(
            "a_lim, the largest change of a setpoint per sample over T_s (None: the reference's own acceleration limit"
            " plus what the planner leaves to the feedback, at most the vehicle's eq-5 limit), m/s²."
        ),
    )
    max_solve_time_s: float | None = number(ge=MIN_SOLVE_TIME_S, le=MAX_SOLVE_TIME_S, default=None)
    """The solver's wall-time limit per step, s. None (default): no wall-clock limit, so a simulation gives the
    same result on any machine and under any load; the solve time is still measured and checked
    (``solve_time_p99_ms``, ``deadline_misses``). Set it to emulate a real-time budget: then a solve that runs out
    of time falls back, as it would on the vehicle."""
    reach_lead: float = number(gt=0, le=5, default=2.5)
    """How far a setpoint may lead its wheel, in multiples of what the wheel can follow in one sample (the
    prediction model's ``lead_factor_s``, :mod:`~agvctl.controllers.mpc.prediction`). Bounded, so the setpoints
    never run away from a saturated wheel; above 1, so that the PI loop's proportional action can still push a wheel
    that is heavier or stiffer than the controller's model (``docs/decisions/0002-saturation-aware-cascade.md``)."""
    body_command_share: float = number(gt=0, le=1, default=0.8)
    """The share of each of the path's limits on the body's acceleration (its ``[limits]`` ``linear_accel_m_s2``,
    ``angular_accel_rad_s2``, ``lateral_accel_m_s2``) that the LTV MPC's commands may use (the NMPC plans without
    these bounds, and its commands are not bounded by them): the mean of the setpoints changes by
    at most that share of the linear limit per sample, their difference over b by that share of the angular one, and
    a command's U·ω stays within that share of the lateral one (:mod:`~agvctl.controllers.mpc.body_bounds`). Above
    the plan's share (``limits.body_plan_share``), so that the feedback has room; below 1, so that what the wheels
    add (a break-away, a loop's overshoot) stays within the limit the gate judges."""
    body_breakaway_share: float = number(gt=0, le=1, default=0.5)
    """The share of the body's per-sample bounds that a command may use while a wheel is at or near rest (below 1 cm/s,
    :data:`~agvctl.controllers.mpc.body_bounds.NEAR_REST_SPEED_M_S`): a wheel breaking away, stopping or reversing
    meets its friction's jump within a sample, so a smaller step keeps the jump and the step within the limit."""
    docking: DockingConfig = DockingConfig()
    """When and how to dock, stopped beside the end of the path (:mod:`~agvctl.controllers.mpc.docking`): the
    ``[controller.docking]`` table."""
    rest: RestConfig = RestConfig()
    """When to hold the wheels at the end of the path, the error within the estimate's uncertainty
    (:mod:`~agvctl.controllers.mpc.rest`): the ``[controller.rest]`` table."""
    reference_governor: bool = True
    """Slow the reference's clock down while the vehicle lags behind it (graceful lag:
    :mod:`~agvctl.controllers.mpc.governor`)."""
    governor_lag_start_m: float = number(
        gt=0,
        le=MAX_DISTANCE_M,
        default=0.04,
        doc="The lag behind the reference at which the governor starts to slow its clock, m.",
    )
    governor_lag_stop_m: float = number(
        gt=0,
        le=MAX_DISTANCE_M,
        default=0.10,
        doc="The lag behind the reference at which the governor holds its clock, m.",
    )
    governor_catch_up: float = number(ge=1, le=2, default=1.5)
    """The largest rate of the governed clock while it catches up: behind the loop's clock and within
    ``governor_lag_start_m`` of the reference, the governed clock runs up to this much faster than time (the
    reference's speed along the path scaled alike), so a delay is made up."""
    qp_solver: QpSolver = "osqp"
    """The LTV MPC's QP solver: OSQP through its Python package (``"osqp"``), or the controller's step in generated C,
    compiled with the system compiler and called in the loop (``"osqp_c"``: the governor, the window, the rest, the
    fallback and the shaper, :mod:`~agvctl.controllers.mpc.c_update`, around the QP's step,
    :mod:`~agvctl.controllers.mpc.c_step`, and the solver ``agvctl codegen`` writes for the vehicle; docking decided
    and planned in Python; software-in-the-loop, the same commands bit for bit), or that solver in single precision
    (``"osqp_c_float"``, for a processor without a double-precision unit). The generated solver keeps no time, so it
    takes no ``max_solve_time_s``. The NMPC solves with IPOPT."""
    max_iterations: int = number(ge=1, le=1_000_000, default=4000)
    """The solver's iteration limit per step (OSQP's own default): a tracking step needs tens, the first steps from
    a far-off start several hundred, and a step with both wheels at their limits on a path planned with little
    headroom over a thousand; a step that reaches the limit falls back and counts as a solver failure."""
    tolerance: float = number(
        ge=1e-10,
        le=1.0,
        default=1.0e-3,
        doc="The solver's tolerance (OSQP's eps_abs and eps_rel, IPOPT's tol): at least 10⁻¹⁰, near the rounding of "
        "the residuals, at most 1, which accepts any answer.",
    )

    def __post_init__(self) -> None:
        check_fields(self)


def check_ltv_settings(config: MpcConfig) -> None:
    """What the LTV MPC asks of its settings beyond each field's range: a generated C solver keeps no time, so it
    takes no solve-time limit.

    Parameters
    ----------
    config : MpcConfig
        The settings.

    Raises
    ------
    ConfigError
        Naming ``max_solve_time_s`` (source ``LtvMpcController``).
    """
    if config.qp_solver != "osqp" and config.max_solve_time_s is not None:
        problem = f"the generated C solver keeps no time: leave it unset with qp_solver = {config.qp_solver!r}"
        raise ConfigError("LtvMpcController", "max_solve_time_s", problem)


def check_nmpc_settings(config: MpcConfig) -> None:
    """What the NMPC asks of its settings beyond each field's range: it solves with IPOPT, so it takes no QP solver.

    Parameters
    ----------
    config : MpcConfig
        The settings.

    Raises
    ------
    ConfigError
        Naming ``qp_solver`` (source ``NonlinearMpcController``).
    """
    if config.qp_solver != "osqp":
        problem = f"{config.qp_solver!r} is the LTV MPC's QP solver; the NMPC solves with IPOPT (remove it)"
        raise ConfigError("NonlinearMpcController", "qp_solver", problem)


DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S = 0.1
"""τ (s) a directly built MPC assumes for the wheel loops when its config leaves it unset."""


def resolved_config(config: MpcConfig) -> MpcConfig:
    """The settings ``config`` with the wheel-loop time constant set.

    Parameters
    ----------
    config : MpcConfig
        The settings; an unset ``wheel_loop_time_constant_s`` becomes :data:`DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S`.

    Returns
    -------
    MpcConfig
        ``config`` itself when its time constant is set, else a copy with the default.
    """
    if config.wheel_loop_time_constant_s is not None:
        return config
    return dataclasses.replace(config, wheel_loop_time_constant_s=DEFAULT_WHEEL_LOOP_TIME_CONSTANT_S)


def wheel_loop_time_constant_s(config: MpcConfig) -> float:
    """τ of the wheel loops' lag that resolved settings assume.

    Parameters
    ----------
    config : MpcConfig
        Settings from :func:`resolved_config`.

    Returns
    -------
    float
        ``config.wheel_loop_time_constant_s``, s.

    Raises
    ------
    ValueError
        The settings are not resolved (their time constant is None).
    """
    if config.wheel_loop_time_constant_s is None:
        raise ValueError("MpcConfig.wheel_loop_time_constant_s: resolve the config first (resolved_config)")
    return config.wheel_loop_time_constant_s


def resolved_limits(config: MpcConfig, vehicle: VehicleParams) -> tuple[float, float]:
    """The hard limits on the setpoints, v_max and a_lim: the settings', or the vehicle's.

    Parameters
    ----------
    config : MpcConfig
        The settings; their ``max_wheel_speed_m_s`` and ``max_wheel_accel_m_s2`` replace the vehicle's.
    vehicle : VehicleParams
        The controller's vehicle: its derived max speed and the acceleration limit of eq 5.

    Returns
    -------
    max_wheel_speed_m_s : float
        v_max, the largest setpoint of either wheel, m/s.
    max_wheel_accel_m_s2 : float
        a_lim, the largest change of a setpoint per sample over T_s (unless set, the ceiling the reference's own
        limit narrows: :meth:`~agvctl.controllers.mpc.common.MpcStepper.reset`), m/s².
    """
    d = vehicle.derived
    v_max = config.max_wheel_speed_m_s if config.max_wheel_speed_m_s is not None else d.max_speed_m_s
    a_lim = config.max_wheel_accel_m_s2 if config.max_wheel_accel_m_s2 is not None else d.accel_limit_m_s2
    return float(v_max), float(a_lim)
