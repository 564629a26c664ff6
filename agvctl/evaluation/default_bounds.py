"""The bounds of the default gate: those that do not depend on the vehicle, the record of a default bound, and
the bounds of a run (:func:`default_bounds`; :func:`~agvctl.evaluation.limits.default_limits` gives them in the
order of the limits' table; its module notes and record 0040 the reasons)."""

from __future__ import annotations

from dataclasses import dataclass

from agvctl.config import document_fields
from agvctl.feasibility import torque_accel_limit_m_s2
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.planning.spec import BODY_LIMIT_KEYS, BodyLimits

__all__ = ["DefaultLimit", "default_bounds"]


@document_fields
@dataclass(frozen=True)
class DefaultLimit:
    """A bound of the default gate and why it is what it is."""

    bound: float
    """The bound, in the unit of the limit's name."""
    reason: str
    """Why, in one line (``"ends within 1 cm of the path's end"``)."""


CORRIDOR_M = 0.10
"""The default corridor about the path: a healthy run stays within 10 cm of it."""
CORRIDOR_BEYOND_START_M = 0.05
"""A run that starts further off than the corridor may stray this much beyond its start's own offset."""


FINAL_HEADING_DEG = 0.5
"""The default final heading error: a healthy run ends within 0.25° of the path's final heading; 0.5° turns a
point a metre ahead of the axle 9 mm, as far as the final position's 1 cm."""
DOCK_CORRIDOR_M = 0.03
"""The default distance across the path's final line once the vehicle is there (the dock): a vehicle arrives within
2 cm of the end, so a healthy one is at most that far beside the line when the count starts, and a dock backing up
along it and coming in again only brings it closer; a further centimetre, the final position's, leaves room for
what remains of the approach."""
LATENESS_S = 0.5
"""The default lateness: a healthy run arrives within 2 cm of the path's end by the time the path ends (the
reference governor's catch-up makes up a start's lag), so half a second late is a delay of its own."""
REST_CURRENT_A = 0.1
"""The default current held at rest, the median over a second of both wheels resting: healthy wheel loops release
their wheels at rest (0 A)."""


def default_bounds(vehicle: VehicleParams, log: SimLog, body: BodyLimits | None = None) -> dict[str, DefaultLimit]:
    """The default gate's bounds of a run, each with its reason (the module notes of
    :mod:`~agvctl.evaluation.limits`).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model: its motors' torque sets the acceleration bound.
    log : SimLog
        The run's log: its start's offset from the path sets the corridor.
    body : BodyLimits or None
        The path's limits on the body's motion: each one set bounds what the payload feels (``peak_body_<key>``).

    Returns
    -------
    dict of str to DefaultLimit
        The bound and reason of each default limit, by limit name.
    """
    start_offset_m = abs(float(log["cross_track_error_m"][0])) if len(log) else 0.0
    if start_offset_m + CORRIDOR_BEYOND_START_M > CORRIDOR_M:
        corridor = DefaultLimit(
            start_offset_m + CORRIDOR_BEYOND_START_M, f"the start's offset {start_offset_m:.3g} m from the path + 5 cm"
        )
    else:
        corridor = DefaultLimit(CORRIDOR_M, "stays within 10 cm of the path")
    torque = torque_accel_limit_m_s2(vehicle)
    defaults = {
        "peak_wheel_accel_m_s2": DefaultLimit(
            torque, "what the motors' torque at the current limit gives a wheel, eqs 58-59"
        ),
        "wheel_speed_error_max_m_s": DefaultLimit(
            torque * vehicle.control.sample_period_s,
            "where its loop is not clamped, a wheel reaches its setpoint within a sample",
        ),
        "final_position_error_m": DefaultLimit(0.01, "ends within 1 cm of the path's end"),
        "final_heading_error_deg": DefaultLimit(FINAL_HEADING_DEG, "ends facing the path's final heading"),
        "cross_track_error_max_m": corridor,
        "dock_cross_track_error_max_m": DefaultLimit(
            DOCK_CORRIDOR_M, "once there, stays within 3 cm of the path's final line"
        ),
        "lateness_s": DefaultLimit(LATENESS_S, "arrives within 2 cm of the path's end by 0.5 s after it ends"),
        "rest_current_max_a": DefaultLimit(
            REST_CURRENT_A, "a wheel at rest holds no current: stiction holds it for free"
        ),
        "path_heading_error_max_deg": DefaultLimit(90.0, "never faces against the path"),
        "solver_failures": DefaultLimit(0, "every controller step succeeds"),
        "non_finite_commands": DefaultLimit(0, "every pose command is a finite number"),
    }
    for key in BODY_LIMIT_KEYS if body is not None else ():
        bound = getattr(body, key)
        if bound is not None:
            defaults[f"peak_body_{key}"] = DefaultLimit(bound, f"the payload feels the path's limits.{key}")
    return defaults
