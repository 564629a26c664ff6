"""Planning within a payload's limits on the body's motion: a path file's [limits] bound the axle midpoint's speed,
acceleration and jerk, the yaw rate and acceleration and the centripetal acceleration at every instant of the plan
(eqs 39-43), at the share of each that the path leaves the plan (the rest is the feedback's), and leave a plan
whose body never reaches them as it was."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from cli_runs import one_line, run

from agvctl.params import load_vehicle
from agvctl.planning import (
    BODY_PLAN_SHARE,
    ArcSegment,
    BodyLimits,
    LineSegment,
    PathLimits,
    PathSpec,
    TurnSegment,
    load_path,
    plan,
)

VEHICLE = load_vehicle(None)
TRAJECTORIES = Path(__file__).resolve().parent.parent / "trajectories"
GENTLE = dict(
    linear_speed_m_s=0.5,
    linear_accel_m_s2=0.3,
    linear_jerk_m_s3=1.0,
    angular_speed_rad_s=0.8,
    angular_accel_rad_s2=1.0,
    lateral_accel_m_s2=0.2,
)
DT = 0.0005


def body_peaks(reference) -> dict[str, float]:
    """The body's largest speed, accelerations and jerk over the plan, sampled every half millisecond."""
    s = reference.sample(np.arange(0.0, reference.duration_s, DT))
    u, w = s.speed_m_s, s.yaw_rate_rad_s
    return {
        "linear_speed_m_s": float(np.max(np.abs(u))),
        "linear_accel_m_s2": float(np.max(np.abs(s.accel_m_s2))),
        "linear_jerk_m_s3": float(np.max(np.abs(np.diff(s.accel_m_s2)) / DT)),
        "angular_speed_rad_s": float(np.max(np.abs(w))),
        "angular_accel_rad_s2": float(np.max(np.abs(s.yaw_accel_rad_s2))),
        "lateral_accel_m_s2": float(np.max(np.abs(u * w))),
    }


def path(join: str, **limits: float) -> PathSpec:
    segments = (
        LineSegment(length_m=1.5),
        ArcSegment(radius_m=0.8, angle_deg=90.0),
        TurnSegment(angle_deg=90.0),
        ArcSegment(radius_m=0.5, angle_deg=-120.0),
        LineSegment(length_m=1.0),
    )
    return PathSpec(segments=segments, name="gentle", limits=PathLimits(**limits), join=join)


@pytest.mark.parametrize("share", [BODY_PLAN_SHARE, 1.0])
@pytest.mark.parametrize("join", ["stop", "smooth"])
def test_the_plan_keeps_its_share_of_every_body_limit_at_every_instant_and_reaches_the_linear_ones(join, share):
    reference = plan(path(join, **GENTLE, body_plan_share=share), VEHICLE)
    assert reference.limits.body == BodyLimits(**GENTLE)  # the whole limits, which the gate judges
    peaks = body_peaks(reference)
    for key, bound in GENTLE.items():
        assert peaks[key] <= share * bound * 1.005, (key, peaks[key], bound)
    assert peaks["linear_accel_m_s2"] >= 0.99 * share * GENTLE["linear_accel_m_s2"]  # a line's start binds it
    assert peaks["angular_speed_rad_s"] >= 0.99 * share * GENTLE["angular_speed_rad_s"]  # the turn in place
    free = body_peaks(plan(path(join), VEHICLE))
    assert all(free[key] > GENTLE[key] for key in GENTLE), free  # each limit changes this plan


def test_waypoints_are_planned_within_the_body_limits():
    spec = load_path(TRAJECTORIES / "waypoints.toml")
    gentle = dict(linear_accel_m_s2=0.25, angular_accel_rad_s2=0.3, lateral_accel_m_s2=0.25)
    limits = dataclasses.replace(spec.limits, **gentle)
    peaks = body_peaks(plan(dataclasses.replace(spec, limits=limits), VEHICLE))
    for key, bound in gentle.items():
        assert peaks[key] <= BODY_PLAN_SHARE * bound * 1.005, (key, peaks[key], bound)


@pytest.mark.parametrize("name", ["figure8.toml", "slalom.toml", "dock.toml", "waypoints.toml"])
def test_body_limits_the_plan_never_reaches_leave_it_as_it_was(name):
    spec = load_path(TRAJECTORIES / name)
    loose = dataclasses.replace(spec.limits, **{key: 1e3 for key in GENTLE})
    before, after = plan(spec, VEHICLE), plan(dataclasses.replace(spec, limits=loose), VEHICLE)
    assert after.duration_s == before.duration_s
    t = np.linspace(0.0, before.duration_s, 501)
    np.testing.assert_array_equal(after.sample(t).x_m, before.sample(t).x_m)
    assert after.limits.body == BodyLimits(**{key: 1e3 for key in GENTLE})


def test_a_path_file_sets_body_limits_and_plan_says_which_bind(tmp_path, capsys):
    file = tmp_path / "gentle.toml"
    file.write_text(
        'name = "gentle"\n[limits]\nlinear_accel_m_s2 = 0.3\nlateral_accel_m_s2 = 5.0\n'
        '[[segments]]\ntype = "line"\nlength_m = 1.0\n[[segments]]\ntype = "arc"\nradius_m = 1.0\nangle_deg = 90\n',
        encoding="utf-8",
    )
    code, out, _ = run(capsys, "plan", file)
    assert code == 0
    assert f"body accel        0.3 m/s²  (file; plan at {BODY_PLAN_SHARE:.0%}: binds)" in out
    assert f"lateral acc         5 m/s²  (file; plan at {BODY_PLAN_SHARE:.0%}: peak" in out
    file.write_text(file.read_text(encoding="utf-8").replace("= 0.3", "= 0"), encoding="utf-8")
    code, _, err = run(capsys, "plan", file)
    assert code == 2
    one_line(err, str(file), "limits.linear_accel_m_s2")


def test_a_plan_share_outside_zero_to_one_is_refused_naming_the_key(tmp_path, capsys):
    file = tmp_path / "share.toml"
    file.write_text(
        'name = "share"\n[limits]\nlinear_accel_m_s2 = 0.3\nbody_plan_share = 1.2\n'
        '[[segments]]\ntype = "line"\nlength_m = 1.0\n',
        encoding="utf-8",
    )
    code, _, err = run(capsys, "plan", file)
    assert code == 2
    one_line(err, str(file), "limits.body_plan_share")
