"""Which path limits bind on a planned reference, and the actuator headroom it leaves (``plan`` and ``run``)."""

from __future__ import annotations

import numpy as np

from agvctl.feasibility import actuator_headroom
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference, ReferenceSamples
from agvctl.planning.spec import BodyLimits, PathLimits

__all__ = ["limits_report"]


def limits_report(reference: Reference, limits: PathLimits, vehicle: VehicleParams) -> list[str]:
    """Which wheel limits bind on a planned reference, and the actuator headroom it leaves, as readable lines.

    Parameters
    ----------
    reference : Reference
        The planned reference.
    limits : PathLimits
        The limits the path file set (None: the vehicle's default).
    vehicle : VehicleParams
        The nominal vehicle the headroom is computed for.

    Returns
    -------
    list of str
        One line per wheel limit (its value, from the file or the default, and whether the plan reaches it), one
        per body limit the file sets (its peak sampled every 10 ms), and one with the smallest fractions of I_max
        and of the full-scale voltage left for feedback along the plan (straight-line model of eq 5 per wheel,
        sampled every 10 ms).
    """
    peaks = reference.peaks()
    rows = (
        ("wheel speed", "m/s", reference.limits.wheel_speed_m_s, limits.wheel_speed_m_s, "peak_wheel_speed_m_s"),
        ("wheel accel", "m/s²", reference.limits.wheel_accel_m_s2, limits.wheel_accel_m_s2, "peak_wheel_accel_m_s2"),
        ("wheel jerk", "m/s³", reference.limits.wheel_jerk_m_s3, limits.wheel_jerk_m_s3, "peak_wheel_jerk_m_s3"),
    )
    lines = []
    for what, unit, value, given, peak_key in rows:
        origin = "file" if given is not None else "default"
        binds = "binds" if peaks[peak_key] >= 0.99 * value else f"peak {peaks[peak_key]:.3g}"
        lines.append(f"  path limit  {what:12s} {value:8.4g} {unit:5s} ({origin}; {binds})")
    s = reference.sample(np.arange(0.0, reference.duration_s + 0.01, 0.01))
    lines += _body_rows(reference, s)
    speed = np.column_stack([s.wheel_speed_left_m_s, s.wheel_speed_right_m_s])
    accel = np.column_stack([s.wheel_accel_left_m_s2, s.wheel_accel_right_m_s2])
    current, voltage = actuator_headroom(vehicle, speed, accel)

    def share(fraction: float) -> str:
        return f"{fraction:.0%}" if fraction >= 0 else f"none ({-fraction:.0%} short)"

    lines.append(
        f"  headroom left for feedback: {share(current)} of the current limit, {share(voltage)} of the voltage"
    )
    return lines


def _body_rows(reference: Reference, s: ReferenceSamples) -> list[str]:
    """A line per body limit the path sets: its value, the share of it the plan uses and whether the plan, sampled
    at ``s``, reaches that share."""
    body, share = reference.limits.body, reference.limits.body_plan_share
    if body == BodyLimits():
        return []
    u, w = s.speed_m_s, s.yaw_rate_rad_s
    jerk = np.gradient(s.accel_m_s2, s.t_s) if len(s.t_s) > 1 else np.zeros_like(u)
    rows = (
        ("body speed", "m/s", body.linear_speed_m_s, u),
        ("body accel", "m/s²", body.linear_accel_m_s2, s.accel_m_s2),
        ("body jerk", "m/s³", body.linear_jerk_m_s3, jerk),
        ("yaw rate", "rad/s", body.angular_speed_rad_s, w),
        ("yaw accel", "rad/s²", body.angular_accel_rad_s2, s.yaw_accel_rad_s2),
        ("lateral acc", "m/s²", body.lateral_accel_m_s2, u * w),
    )
    lines = []
    for what, unit, value, samples in rows:
        if value is not None:
            peak = float(np.max(np.abs(samples))) if len(samples) else 0.0
            binds = "binds" if peak >= 0.99 * share * value else f"peak {peak:.3g}"
            lines.append(f"  path limit  {what:12s} {value:8.4g} {unit:5s} (file; plan at {share:.0%}: {binds})")
    return lines
