"""What the default gate measures at the end of a path, on synthetic logs: when the vehicle arrives (lateness), how
far beside the path's final line it stands once there (the dock) and the current it holds at rest."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agvctl.evaluation.metrics import METRICS, arrival_index, reference_end_index
from agvctl.log import SimLog

TS = 0.04
"""The synthetic logs' sample period, s."""
TRACK_M = 0.5
"""The synthetic vehicle's wheel separation, m (only the reference's wheel speeds use it)."""


def synthetic_log(
    x_m: np.ndarray,
    ref_x_m: np.ndarray,
    *,
    y_m: np.ndarray | None = None,
    ref_y_m: np.ndarray | None = None,
    ref_theta_rad: np.ndarray | None = None,
    current_a: float | np.ndarray = 0.0,
) -> SimLog:
    """A drive sampled at :data:`TS`: the vehicle at ``(x_m, y_m)``, its reference at ``(ref_x_m, ref_y_m)``
    heading ``ref_theta_rad`` (0: along x), the reference's wheel speeds from its motion, the vehicle's wheels at
    its speed along x with setpoints 0 wherever it stands, and ``current_a`` in each motor."""
    n = len(x_m)
    zeros = np.zeros(n)
    y_m = zeros if y_m is None else y_m
    ref_y_m = zeros if ref_y_m is None else ref_y_m
    ref_theta_rad = zeros if ref_theta_rad is None else ref_theta_rad
    speed = np.concatenate((np.diff(x_m) / TS, [0.0]))  # over the sample that starts at each row
    ref_speed = np.concatenate((np.hypot(np.diff(ref_x_m), np.diff(ref_y_m)) / TS, [0.0]))
    ref_turn = np.concatenate((np.diff(ref_theta_rad) / TS, [0.0])) * 0.5 * TRACK_M
    return SimLog(
        {
            "t_s": TS * np.arange(n),
            "x_m": np.asarray(x_m, dtype=float),
            "y_m": np.asarray(y_m, dtype=float),
            "ref_x_m": np.asarray(ref_x_m, dtype=float),
            "ref_y_m": np.asarray(ref_y_m, dtype=float),
            "ref_theta_rad": np.asarray(ref_theta_rad, dtype=float),
            "ref_wheel_speed_left_m_s": ref_speed - ref_turn,
            "ref_wheel_speed_right_m_s": ref_speed + ref_turn,
            "wheel_speed_left_m_s": speed,
            "wheel_speed_right_m_s": speed,
            "setpoint_wheel_speed_left_m_s": speed,
            "setpoint_wheel_speed_right_m_s": speed,
            "current_left_a": np.full(n, current_a),
            "current_right_a": np.full(n, -current_a),
        }
    )


REF = np.minimum(0.01 * np.arange(200), 1.0)
"""1 m along x at 0.25 m/s: the reference reaches its end at sample 100 (t = 4 s) and rests there to sample 199."""


def lateness(log: SimLog) -> float:
    return METRICS["lateness_s"].value(log, TS)


def dock(log: SimLog) -> float:
    return METRICS["dock_cross_track_error_max_m"].value(log, TS)


def test_a_vehicle_with_its_reference_is_not_late() -> None:
    on_time = synthetic_log(REF, REF)
    assert reference_end_index(on_time) == 100
    assert lateness(on_time) == 0.0


def test_lateness_is_the_time_from_the_references_end_to_the_vehicles_arrival_within_2_cm_of_the_end() -> None:
    late = synthetic_log(np.minimum(0.008 * np.arange(200), 1.0), REF)  # 0.2 m/s: 5 s to arrive
    # within 2 cm of the end from 0.98 m on, first reached at sample 123 (0.984 m): 0.92 s after the reference's end
    assert arrival_index(late) == 123
    assert lateness(late) == pytest.approx(TS * (123 - 100))


def test_a_vehicle_that_never_arrives_is_late_by_the_rest_of_the_run() -> None:
    stops_short = synthetic_log(np.minimum(0.01 * np.arange(200), 0.9), REF)
    assert lateness(stops_short) == pytest.approx(TS * (199 - 100))


def test_running_past_the_end_with_the_reference_and_coming_back_is_not_late() -> None:
    # at the end with the reference at 4 s, 5 cm past it by 4.4 s, back at 5 s: within 2 cm again only at 4.84 s
    past = np.concatenate((REF[:101], 1.0 + 0.05 * np.sin(np.linspace(0.0, np.pi, 25))[1:], np.full(75, 1.0)))
    log = synthetic_log(past, REF)
    assert arrival_index(log) <= 100 and lateness(log) == 0.0


def test_a_dock_that_backs_away_after_arriving_is_not_late() -> None:
    backs_away = synthetic_log(np.concatenate((REF[:150], np.full(50, 0.95))), REF)  # arrived, then 5 cm away
    assert lateness(backs_away) == 0.0


def test_passing_the_end_before_the_path_comes_back_to_it_is_no_arrival() -> None:
    # a shuttle: out 1 m and back to the start; the vehicle 1 s (25 samples) behind, at the end only at its start
    out_and_back = np.concatenate((np.minimum(0.01 * np.arange(100), 1.0), 1.0 - 0.01 * np.arange(101), np.zeros(60)))
    behind = np.concatenate((np.zeros(25), out_and_back[:-25]))
    log = synthetic_log(behind, out_and_back)
    assert reference_end_index(log) == 200
    # the reference is within 2 cm of the end for good from sample 199 on; the vehicle 25 samples later
    assert arrival_index(log) == 224
    assert lateness(log) == pytest.approx(TS * 24)


def test_the_dock_measures_the_distance_across_the_final_line_not_along_it() -> None:
    past = np.concatenate((REF[:101], 1.0 + 0.05 * np.sin(np.linspace(0.0, np.pi, 25))[1:], np.full(75, 1.0)))
    assert dock(synthetic_log(past, REF)) == 0.0  # 5 cm past the end along its line
    beside = synthetic_log(REF, REF, y_m=np.full(200, 0.015))
    assert dock(beside) == pytest.approx(0.015)


def test_the_dock_counts_from_the_references_end_not_while_the_path_still_bends_towards_its_line() -> None:
    # a quarter circle of radius 1 m onto a final heading of +y, ending at (1, 1); the vehicle on the arc, late
    angle = np.minimum(0.5 * math.pi * np.arange(200) / 100, 0.5 * math.pi)
    late_angle = np.minimum(0.5 * math.pi * np.arange(200) / 150, 0.5 * math.pi)
    ref_x, ref_y = 1.0 - np.cos(angle), np.sin(angle)
    log = synthetic_log(1.0 - np.cos(late_angle), ref_x, y_m=np.sin(late_angle), ref_y_m=ref_y, ref_theta_rad=angle)
    assert lateness(log) > 1.5  # still on the arc, up to 1 m across the final line, when the reference ends
    assert dock(log) < 0.02  # once it has arrived, it is on that line


def test_after_a_turn_in_place_the_final_line_is_the_last_drives() -> None:
    # 1 m along x, then a quarter turn in place (5 samples): the final heading is +y, the last drive along x
    turn = np.concatenate((np.zeros(101), np.minimum(0.5 * math.pi * np.arange(1, 100) / 5, 0.5 * math.pi)))
    past = np.concatenate((REF[:101], 1.0 + 0.05 * np.sin(np.linspace(0.0, np.pi, 25))[1:], np.full(75, 1.0)))
    log = synthetic_log(past, REF, ref_theta_rad=turn)
    assert reference_end_index(log) == 105  # while the vehicle is still up to 5 cm past the end, along x
    assert dock(log) == 0.0  # along the last drive's line, not across it
    assert dock(synthetic_log(REF, REF, y_m=np.full(200, 0.015), ref_theta_rad=turn)) == pytest.approx(0.015)


def test_current_at_rest_counts_only_a_whole_second_of_both_wheels_resting() -> None:
    held = synthetic_log(REF, REF, current_a=0.4)  # at rest from sample 100 on: 100 samples, 4 s
    assert METRICS["rest_current_max_a"].value(held, TS) == pytest.approx(0.4)
    short = synthetic_log(REF[:120], REF[:120], current_a=0.4)  # 20 samples at rest: under a second
    assert METRICS["rest_current_max_a"].value(short, TS) == 0.0


def test_current_at_rest_is_what_is_held_for_most_of_a_second_not_what_stops_the_wheels() -> None:
    # 1.2 A for the first 0.24 s of the rest (the loops braking while their speed estimate settles), then released
    settling = np.where((np.arange(200) >= 100) & (np.arange(200) < 106), 1.2, 0.0)
    assert METRICS["rest_current_max_a"].value(synthetic_log(REF, REF, current_a=settling), TS) == 0.0
    # the same current held for 0.8 s of every second at rest is held
    held = np.where(np.arange(200) >= 100, 1.2, 0.0) * (np.arange(200) % 25 < 20)
    assert METRICS["rest_current_max_a"].value(synthetic_log(REF, REF, current_a=held), TS) == pytest.approx(1.2)
