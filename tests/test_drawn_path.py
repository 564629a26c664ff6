"""The drawn path: how far the planned path leaves the geometry a path file writes, and the tolerance it keeps."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from agvctl.errors import ConfigError
from agvctl.evaluation.limits import LIMITS, default_limits
from agvctl.evaluation.path_metrics import path_error_columns
from agvctl.log import SimLog
from agvctl.params import load_vehicle
from agvctl.planning import (
    DRAWN_PATH_TOLERANCE_M,
    ArcSegment,
    DrawnPath,
    LineSegment,
    PathLimits,
    PathSpec,
    Pose,
    TurnSegment,
    Waypoint,
    load_path,
    plan,
    plan_segments,
)
from agvctl.planning import waypoints as waypoint_module
from agvctl.planning.drawn import CHORD_ERROR_M, piece_distance_m

VEHICLE = load_vehicle()

# a line into an arc (the getting-started path), a line, an arc and a turn in place, the figure-8's reversal of
# curvature, an S of arcs into a line driven in reverse, and four waypoints whose spline turns sharply
SEGMENT_PATHS = {
    "line-arc": (LineSegment(length_m=1.5), ArcSegment(radius_m=0.8, angle_deg=90)),
    "line-arc-turn": (LineSegment(length_m=2.0), ArcSegment(radius_m=1.0, angle_deg=90), TurnSegment(angle_deg=90)),
    "reversal": (ArcSegment(radius_m=1.0, angle_deg=360, speed_m_s=0.5), ArcSegment(radius_m=1.0, angle_deg=-360)),
    "s-reverse": (
        ArcSegment(radius_m=0.5, angle_deg=60),
        ArcSegment(radius_m=0.3, angle_deg=-120),
        LineSegment(length_m=0.7),
        LineSegment(length_m=-1.0),
    ),
}
SHARP_WAYPOINTS = tuple(
    Waypoint(x_m=x, y_m=y, theta_deg=t)
    for x, y, t in ((0.0, 0.0, 0.0), (1.73, 2.094, 35.2), (2.296, 1.463, None), (5.015, 2.632, 37.8))
)


def _spec(name: str, tolerance_m: float) -> PathSpec:
    limits = PathLimits(drawn_path_tolerance_m=tolerance_m)
    if name == "waypoints":
        return PathSpec(waypoints=SHARP_WAYPOINTS, limits=limits, name=name)
    return PathSpec(segments=SEGMENT_PATHS[name], limits=limits, name=name)


def test_the_distance_to_an_arc_is_the_distance_to_its_circle_beside_it_and_to_its_ends_beyond():
    pose = Pose(1.0, -2.0, 0.3)
    radius, swept = 0.5, math.radians(120)
    centre = (pose.x_m - radius * math.sin(pose.theta_rad), pose.y_m + radius * math.cos(pose.theta_rad))
    start_angle = pose.theta_rad - math.pi / 2  # of the start, seen from the centre (a left turn)
    angles = start_angle + np.linspace(0.0, swept, 7)
    for offset in (-0.2, 0.0, 0.3):
        r = radius + offset
        x, y = centre[0] + r * np.cos(angles), centre[1] + r * np.sin(angles)
        d = piece_distance_m(x, y, pose, radius * swept, 1.0 / radius)
        np.testing.assert_allclose(d, abs(offset), atol=1e-12)
    behind = start_angle - 0.5  # beyond the start: the nearest point is the start itself
    x, y = centre[0] + radius * math.cos(behind), centre[1] + radius * math.sin(behind)
    d = piece_distance_m(np.array([x]), np.array([y]), pose, radius * swept, 1.0 / radius)
    assert d[0] == pytest.approx(2.0 * radius * math.sin(0.25), rel=1e-12)  # the chord of 0.5 rad


@pytest.mark.parametrize("name", [*SEGMENT_PATHS, "waypoints"])
@pytest.mark.parametrize("tolerance_m", [0.001, DRAWN_PATH_TOLERANCE_M])
def test_the_planned_path_stays_within_the_tolerance_of_the_drawn_one(name, tolerance_m):
    ref = plan(_spec(name, tolerance_m), VEHICLE)
    assert ref.drawn_path_deviation_m <= tolerance_m
    assert ref.drawn_path_tolerance_m == tolerance_m
    # judged independently of the planner's own figure: the reference every 2 ms against the drawn geometry
    s = ref.sample(np.arange(0.0, ref.duration_s, 2e-3))
    assert ref.drawn_path is not None
    measured = np.max(ref.drawn_path.distance_m(s.x_m, s.y_m))
    assert measured <= tolerance_m + CHORD_ERROR_M
    assert measured == pytest.approx(ref.drawn_path_deviation_m, abs=0.05 * tolerance_m)  # the figure is the real one


def test_a_join_left_to_the_speed_alone_leaves_the_corner_by_centimetres():
    """Why the tolerance exists: the line into an arc, planned without one that binds, is tens of mm off."""
    free = plan(_spec("line-arc", 1.0), VEHICLE)
    assert free.drawn_path_deviation_m > 4 * DRAWN_PATH_TOLERANCE_M


def test_a_path_of_lines_and_turns_in_place_is_the_drawn_path():
    ref = plan(load_path("trajectories/square.toml"), VEHICLE)
    assert ref.drawn_path_deviation_m == 0.0
    s = ref.grid
    assert ref.drawn_path is not None
    assert np.max(ref.drawn_path.distance_m(s.x_m, s.y_m)) < 1e-9


def test_the_drawn_path_of_segments_is_their_lines_and_arcs():
    drawn = DrawnPath.of_segments(SEGMENT_PATHS["line-arc-turn"], Pose(0.0, 0.0, 0.0))
    # the corner the join cuts: (2, 0), then the arc's end (3, 1)
    d = drawn.distance_m([2.0, 3.0, 1.0, 3.0], [0.0, 1.0, 0.5, 0.0])
    np.testing.assert_allclose(d[:2], 0.0, atol=1e-12)
    assert d[2] == pytest.approx(0.5, abs=1e-9)  # beside the line
    assert d[3] == pytest.approx(math.sqrt(2.0) - 1.0, abs=CHORD_ERROR_M)  # outside the arc, off its centre (2, 1)


def test_the_tolerance_is_a_path_file_limit_and_is_checked(tmp_path):
    file = tmp_path / "p.toml"
    body = '[[segments]]\ntype = "line"\nlength_m = 1.5\n[[segments]]\ntype = "arc"\nradius_m = 0.8\nangle_deg = 90\n'
    file.write_text("[limits]\ndrawn_path_tolerance_m = 0.002\n" + body, encoding="utf-8")
    ref = plan(load_path(file), VEHICLE)
    assert ref.drawn_path_tolerance_m == 0.002 and ref.drawn_path_deviation_m <= 0.002
    file.write_text("[limits]\ndrawn_path_tolerance_m = 0\n" + body, encoding="utf-8")
    with pytest.raises(ConfigError, match=r"p\.toml: limits\.drawn_path_tolerance_m: must be >= 0\.0001"):
        load_path(file)
    with pytest.raises(ConfigError, match=r"plan_segments: drawn_path_tolerance_m: must be finite"):
        plan_segments(
            SEGMENT_PATHS["line-arc"],
            limits=plan(load_path("trajectories/line.toml")).limits,
            separation_m=0.5,
            sample_period_s=0.04,
            drawn_path_tolerance_m=math.nan,
        )


def test_a_plan_that_cannot_keep_within_the_tolerance_is_refused_naming_the_key(monkeypatch):
    monkeypatch.setattr(waypoint_module, "MAX_NODES_PER_SPAN", waypoint_module.NODES_PER_SPAN)  # no refining
    spec = dataclasses.replace(_spec("waypoints", 1e-4), source="paths/sharp.toml")
    with pytest.raises(ConfigError) as caught:
        plan(spec, VEHICLE)
    message = str(caught.value)
    assert message.startswith("paths/sharp.toml: limits.drawn_path_tolerance_m: the planned path leaves the drawn")
    assert "\n" not in message


def test_a_vehicle_exactly_on_the_reference_is_as_far_from_the_drawn_path_as_the_plan():
    ref = plan(_spec("line-arc", DRAWN_PATH_TOLERANCE_M), VEHICLE)
    s = ref.sample(np.arange(0.0, ref.duration_s, 1e-3))
    columns = path_error_columns(s.t_s, s.x_m, s.y_m, s.theta_rad, ref)
    assert np.max(columns["cross_track_error_m"]) < 2e-5  # on the planned path (its 1 cm chords)
    assert np.max(columns["drawn_cross_track_error_m"]) == pytest.approx(ref.drawn_path_deviation_m, abs=1e-5)


def test_cross_track_against_the_drawn_path_is_an_optional_limit_outside_the_default_gate():
    assert LIMITS["drawn_cross_track_error_max_m"].unit == " m"
    log = SimLog({"t_s": np.zeros(1), "cross_track_error_m": np.zeros(1)})
    assert "drawn_cross_track_error_max_m" not in default_limits(VEHICLE, log)


def test_the_plan_plot_draws_the_drawn_path_under_the_planned_one():
    from agvctl.plots.path import plot_reference

    ref = plan(_spec("line-arc", DRAWN_PATH_TOLERANCE_M), VEHICLE)
    ax = plot_reference(ref).axes[0]
    lines = {line.get_label(): line for line in ax.get_lines()}
    assert ref.drawn_path is not None
    np.testing.assert_array_equal(lines["drawn path"].get_xdata(), ref.drawn_path.x_m)
    assert lines["drawn path"].get_zorder() < lines["planned path"].get_zorder()


def test_plan_prints_how_far_it_leaves_the_drawn_path_and_the_key_that_bounds_it(capsys):
    from agvctl.cli import main

    assert main(["plan", "trajectories/slalom.toml"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "off the drawn path" in x)
    deviation_mm = plan(load_path("trajectories/slalom.toml"), VEHICLE).drawn_path_deviation_m * 1e3
    assert f"{deviation_mm:.2f} mm" in line and "limits.drawn_path_tolerance_m" in line
