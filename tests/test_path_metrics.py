"""Path errors on exact geometry: a straight line, a circle, a turn in place, a path that retraces itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvctl.planning import ArcSegment, LineSegment, TurnSegment, WheelLimits, plan_segments
from agvctl.planning.reference import Reference
from agvctl.sim.path_metrics import ReferencePath, path_errors

LIMITS = WheelLimits(wheel_speed_m_s=0.6, wheel_accel_m_s2=0.4, wheel_jerk_m_s3=2.0)
SPACING_M = 0.005


def _plan(*segments: LineSegment | ArcSegment | TurnSegment) -> Reference:
    return plan_segments(list(segments), limits=LIMITS, separation_m=0.5, sample_period_s=0.04)


def test_straight_line() -> None:
    ref = _plan(LineSegment(length_m=2.0))
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(0.0, ref.duration_s, 200))
    x = rng.uniform(0.0, 2.0, 200)  # anywhere along the line, either side of it
    y = rng.uniform(-0.3, 0.3, 200)
    theta = rng.uniform(-1.0, 1.0, 200)
    e = path_errors(t, x, y, theta, ref, spacing_m=SPACING_M)
    s_ref = ref.sample(t).x_m  # the line runs along +x from the origin
    np.testing.assert_allclose(e.cross_track_m, np.abs(y), atol=1e-12)
    np.testing.assert_allclose(e.along_track_lag_m, s_ref - x, atol=1e-12)
    np.testing.assert_allclose(e.heading_error_rad, theta, atol=1e-12)


def test_beyond_the_ends_the_distance_is_to_the_end_point() -> None:
    ref = _plan(LineSegment(length_m=1.0))
    e = path_errors([0.0, 0.0], [-0.3, 1.4], [0.4, -0.3], [0.0, 0.0], ref)
    np.testing.assert_allclose(e.cross_track_m, [0.5, 0.5], atol=1e-12)  # 3-4-5 triangles


def test_circle() -> None:
    radius = 1.0
    ref = _plan(ArcSegment(radius_m=radius, angle_deg=300))  # a left arc from the origin around (0, 1)
    rng = np.random.default_rng(2)
    phi = rng.uniform(0.05, math.radians(295), 300)  # angle travelled along the arc
    rho = radius + rng.uniform(-0.3, 0.3, 300)  # distance from the centre
    x, y = rho * np.sin(phi), 1.0 - rho * np.cos(phi)
    theta = phi + rng.uniform(-0.5, 0.5, 300)
    t = rng.uniform(0.0, ref.duration_s, 300)
    e = path_errors(t, x, y, theta, ref, spacing_m=SPACING_M)
    sagitta = SPACING_M**2 / (8 * radius)  # the polyline's chords lie inside the arc by at most this
    np.testing.assert_allclose(e.cross_track_m, np.abs(rho - radius), atol=sagitta * 1.01)
    # off the arc, the foot on a chord is not the radial projection: the chord's normal turns by up to
    # spacing/(2R) across it, which shifts the foot along it by up to |ρ − R| spacing/(2R)
    along = 0.3 * SPACING_M / (2 * radius)
    np.testing.assert_allclose(e.path_length_m, radius * phi, atol=along)
    np.testing.assert_allclose(e.along_track_lag_m, ref.sample(t).path_length_m - radius * phi, atol=along)
    np.testing.assert_allclose(e.heading_error_rad, theta - phi, atol=along / radius)


def test_turn_in_place_has_a_range_of_headings() -> None:
    ref = _plan(LineSegment(length_m=1.0), TurnSegment(angle_deg=90), LineSegment(length_m=1.0))
    t = np.full(4, 0.5 * ref.duration_s)
    theta = np.radians([0.0, 45.0, 90.0, 120.0])
    e = path_errors(t, np.ones(4), np.zeros(4), theta, ref)  # at the corner, where the path turns
    np.testing.assert_allclose(e.cross_track_m, 0.0, atol=1e-12)
    # the heading range is what the dense samples see of the turn: within 1 µrad of its ends
    np.testing.assert_allclose(e.heading_error_rad, np.radians([0.0, 0.0, 0.0, 30.0]), atol=1e-6)


def test_a_path_that_retraces_itself_keeps_the_clocks_lap() -> None:
    ref = _plan(*[ArcSegment(radius_m=1.0, angle_deg=a) for a in (360, -360, 360)])  # a figure-8 and a lap
    t = np.linspace(0.0, ref.duration_s, 700)
    s = ref.sample(t)
    e = path_errors(t, s.x_m, s.y_m, s.theta_rad, ref)  # exactly on the reference
    np.testing.assert_allclose(e.cross_track_m, 0.0, atol=1e-5)
    np.testing.assert_allclose(e.along_track_lag_m, 0.0, atol=1e-5)
    np.testing.assert_allclose(e.heading_error_rad, 0.0, atol=1e-4)


def test_a_path_at_rest_and_bad_input() -> None:
    ref = _plan(TurnSegment(angle_deg=90))
    path = ReferencePath(ref)
    assert len(path) == 1
    e = path.errors([0.0], [0.3], [0.4], [math.pi])
    assert e.cross_track_m[0] == pytest.approx(0.5)
    assert e.heading_error_rad[0] == pytest.approx(math.pi / 2)  # 90° beyond the range 0…90°
    with pytest.raises(ValueError, match="same length"):
        path.errors([0.0, 1.0], [0.0], [0.0], [0.0])
    with pytest.raises(ValueError, match="spacing_m"):
        ReferencePath(ref, spacing_m=0.0)
