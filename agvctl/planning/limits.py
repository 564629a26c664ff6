"""The wheel limits a path resolves to on a vehicle: the file's limits, the vehicle's defaults where it sets none,
each checked against what the vehicle can do and against the headroom feedback needs."""

from __future__ import annotations

import warnings

from agvctl.errors import ConfigError
from agvctl.feasibility import (
    CURRENT_HEADROOM,
    MIN_HEADROOM,
    VOLTAGE_HEADROOM,
    HeadroomWarning,
    actuator_headroom,
    feasible_wheel_limits,
    no_default_limit_reasons,
)
from agvctl.params import VehicleParams
from agvctl.planning.spec import BODY_LIMIT_KEYS, BodyLimits, PathSpec, WheelLimits

__all__ = ["JERK_RAMP_SAMPLES", "PhysicalLimitWarning", "default_jerk_limit_m_s3", "resolve_limits"]

JERK_RAMP_SAMPLES = 5
"""The default jerk limit lets the acceleration ramp from 0 to a_lim over this many control periods."""


class PhysicalLimitWarning(UserWarning):
    """A limit above what the vehicle can physically do was accepted because ``force=True``."""


def default_jerk_limit_m_s3(vehicle: VehicleParams) -> float:
    """The default wheel jerk limit: a_lim reached in :data:`JERK_RAMP_SAMPLES` control periods.

    A planning convention, not a physical limit: it keeps the acceleration's ramps a few samples long, which the
    wheel loops follow.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle: its acceleration limit a_lim (eq 5) and sample period.

    Returns
    -------
    float
        The jerk limit, m/s³: 0.657 / (5 · 0.04 s) = 3.29 m/s³ for the default vehicle.
    """
    return vehicle.derived.accel_limit_m_s2 / (JERK_RAMP_SAMPLES * vehicle.control.sample_period_s)


def resolve_limits(spec: PathSpec, vehicle: VehicleParams, *, force: bool = False) -> WheelLimits:
    """A path's wheel limits with the vehicle's defaults filled in, checked against the vehicle.

    Defaults leave headroom for feedback (:func:`~agvctl.feasibility.feasible_wheel_limits`: the plan uses at most
    80 % of I_max and of the full-scale voltage) and :func:`default_jerk_limit_m_s3`. Explicit limits the actuator
    can deliver but with less than :data:`~agvctl.feasibility.MIN_HEADROOM` of current or voltage left get a
    :class:`~agvctl.feasibility.HeadroomWarning`.

    Parameters
    ----------
    spec : PathSpec
        The path: its ``[limits]`` and each segment's ``speed_m_s``.
    vehicle : VehicleParams
        The vehicle the path is planned for.
    force : bool
        Accept a limit above what the vehicle can do, with a :class:`PhysicalLimitWarning`, instead of refusing it.

    Returns
    -------
    WheelLimits
        The limits the planner keeps to.

    Raises
    ------
    ConfigError
        A wheel speed limit (or a segment's ``speed_m_s``) above the no-load top speed, or an acceleration limit
        above a_lim (eq 5), naming both values, unless ``force``; a limit left to its default when the vehicle has
        none (it cannot move, or not with the headroom), naming the vehicle keys why, ``force`` or not.

    Warns
    -----
    PhysicalLimitWarning
        A limit above what the vehicle can do, accepted because of ``force``.
    HeadroomWarning
        An explicit limit that leaves less than :data:`~agvctl.feasibility.MIN_HEADROOM` for feedback.
    """
    top, a_lim = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2
    lim = spec.limits
    checks: list[tuple[str, float | None, float, str, str]] = [
        ("limits.wheel_speed_m_s", lim.wheel_speed_m_s, top, "m/s", "no-load top speed"),
        ("limits.wheel_accel_m_s2", lim.wheel_accel_m_s2, a_lim, "m/s²", "acceleration limit a_lim (eq 5)"),
    ]
    checks += [
        (f"segments[{i}].speed_m_s", seg.speed_m_s, top, "m/s", "no-load top speed")
        for i, seg in enumerate(spec.segments)
    ]
    over = set()
    for key, value, physical, unit, what in checks:
        if value is not None and value > physical:
            over.add(key)
            problem = f"{value:g} {unit} is above the vehicle's {what} of {physical:.4g} {unit}"
            if not force:
                raise ConfigError(spec.source, key, problem + " (use --force to plan anyway)")
            warnings.warn(
                f"{spec.source}: {key}: {problem}; planning anyway (--force)", PhysicalLimitWarning, stacklevel=2
            )
    _warn_headroom(spec, vehicle, skip=over)
    default = feasible_wheel_limits(vehicle)
    for key, why in no_default_limit_reasons(vehicle, default).items():
        if getattr(lim, key) is None:
            raise ConfigError(spec.source, f"limits.{key}", f"no default for this vehicle: {why}")
    jerk = lim.wheel_jerk_m_s3 if lim.wheel_jerk_m_s3 is not None else default_jerk_limit_m_s3(vehicle)
    return WheelLimits(
        wheel_speed_m_s=lim.wheel_speed_m_s if lim.wheel_speed_m_s is not None else default.wheel_speed_m_s,
        wheel_accel_m_s2=lim.wheel_accel_m_s2 if lim.wheel_accel_m_s2 is not None else default.wheel_accel_m_s2,
        wheel_jerk_m_s3=jerk,
        body=BodyLimits(**{key: getattr(lim, key) for key in BODY_LIMIT_KEYS}),
        body_plan_share=lim.body_plan_share,
    )


def _warn_headroom(spec: PathSpec, vehicle: VehicleParams, skip: set[str]) -> None:
    """A :class:`HeadroomWarning` for each explicit limit that leaves less than MIN_HEADROOM for feedback (but
    those in ``skip``, already above the physical limit)."""
    lim = spec.limits
    if lim.wheel_accel_m_s2 is not None and "limits.wheel_accel_m_s2" not in skip:
        a = lim.wheel_accel_m_s2
        current, _ = actuator_headroom(vehicle, [[1e-9, 1e-9]], [[a, a]])
        if current < MIN_HEADROOM:
            warnings.warn(
                f"{spec.source}: limits.wheel_accel_m_s2: {a:g} m/s² leaves {max(current, 0):.0%} of the current "
                f"limit for feedback (at least {MIN_HEADROOM:.0%} advised; the default "
                f"{feasible_wheel_limits(vehicle).wheel_accel_m_s2:.3g} m/s² leaves {CURRENT_HEADROOM:.0%})",
                HeadroomWarning,
                stacklevel=3,
            )
    speeds = [("limits.wheel_speed_m_s", lim.wheel_speed_m_s)]
    speeds += [(f"segments[{i}].speed_m_s", seg.speed_m_s) for i, seg in enumerate(spec.segments)]
    for key, v in speeds:
        if v is None or key in skip:
            continue
        _, voltage = actuator_headroom(vehicle, [[v, v]], [[0.0, 0.0]])
        if voltage < MIN_HEADROOM:
            warnings.warn(
                f"{spec.source}: {key}: {v:g} m/s leaves {max(voltage, 0):.0%} of the full-scale voltage for "
                f"feedback at cruise (at least {MIN_HEADROOM:.0%} advised; the default "
                f"{feasible_wheel_limits(vehicle).wheel_speed_m_s:.3g} m/s leaves {VOLTAGE_HEADROOM:.0%})",
                HeadroomWarning,
                stacklevel=3,
            )
