"""The Python API validates like the files: the public dataclasses check their fields when constructed (finite,
within range, among their choices), the entry points their arguments, each with a one-line ConfigError naming the
class or function and the argument; CSV readers count lines in the file (comments included), accept a UTF-8
byte-order mark and give a package error for an empty file."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agvctl.calibration import read_umbmark_log
from agvctl.errors import ConfigError
from agvctl.estimation.offline import read_log
from agvctl.feasibility import (
    WheelReach,
    actuator_headroom,
    feasible_wheel_limits,
    feedback_accel_m_s2,
    no_default_limit_reasons,
    torque_accel_limit_m_s2,
    wheel_accel_reach_m_s2,
)
from agvctl.log import SimLog
from agvctl.params import ControlParams, FrictionModelParams, MotorParams, SensorParams, WheelSide
from agvctl.planning import ArcSegment, LineSegment, TurnSegment, WheelLimits, plan_segments
from agvctl.planning.spec import PathLimits, PathSpec, StartPose, Waypoint
from agvctl.sim.open_loop import load_input_profile, simulate_open_loop

LIMITS = WheelLimits(0.8, 0.5, 3.0)
MOTOR = {
    "inertia_kg_m2": 1e-5,
    "resistance_ohm": 1.0,
    "torque_constant_n_m_a": 0.05,
    "voltage_constant_v_s_rad": 0.05,
    "viscous_friction_n_m_s_rad": 1e-5,
    "coulomb_friction_n_m": 0.01,
    "stiction_n_m": 0.02,
    "gear_ratio": 10.0,
}


@pytest.mark.parametrize(
    ("make", "line"),
    [
        (lambda: LineSegment(length_m=math.nan), "LineSegment: length_m: must be finite (got nan)"),
        (lambda: LineSegment(length_m=1.0, speed_m_s=0.0), "LineSegment: speed_m_s: must be >= 0.001 (got 0)"),
        (lambda: ArcSegment(radius_m=0, angle_deg=90), "ArcSegment: radius_m: must be >= 0.001 (got 0)"),
        (lambda: TurnSegment(angle_deg=math.inf), "TurnSegment: angle_deg: must be finite (got inf)"),
        (lambda: LineSegment(length_m="1"), "LineSegment: length_m: expected a number (got '1')"),
        (lambda: StartPose(x_m=math.nan), "StartPose: x_m: must be finite"),
        (lambda: PathLimits(wheel_speed_m_s=-1.0), "PathLimits: wheel_speed_m_s: must be >= 0.001"),
        (lambda: Waypoint(x_m=1e9, y_m=0.0), "Waypoint: x_m: must be <= 1e+06"),
        (lambda: PathSpec(segments=(LineSegment(length_m=1.0),), join="smoth"), "PathSpec: join: must be one of"),
        (lambda: WheelLimits(0.8, math.nan, 3.0), "WheelLimits: wheel_accel_m_s2: must be finite and >= 0.001"),
        (lambda: ControlParams(sample_period_s=0.0), "ControlParams: sample_period_s: must be >= 0.0001"),
        (lambda: FrictionModelParams(p_factor=-1.0), "FrictionModelParams: p_factor: must be > 0"),
        (lambda: SensorParams(encoder_counts_per_rev=0), "SensorParams: encoder_counts_per_rev: must be > 0"),
        (lambda: SensorParams(encoder_counts_per_rev=2.5), "SensorParams: encoder_counts_per_rev: expected an int"),
        (lambda: WheelSide(radius_m=math.nan), "WheelSide: radius_m: must be finite"),
        (lambda: MotorParams(**{**MOTOR, "gear_ratio": 0.0}), "MotorParams: gear_ratio: must be > 0"),
    ],
)
def test_a_public_dataclass_refuses_a_bad_field_naming_it(make: Any, line: str) -> None:
    with pytest.raises(ConfigError) as info:
        make()
    assert str(info.value).startswith(line) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("arguments", "line"),
    [
        ({"join": "smoth"}, "plan_segments: join: must be one of 'smooth', 'stop' (got 'smoth')"),
        ({"sample_period_s": 0.0}, "plan_segments: sample_period_s: must be finite and > 0 (got 0.0)"),
        ({"sample_period_s": -0.04}, "plan_segments: sample_period_s: must be finite and > 0 (got -0.04)"),
        ({"separation_m": 0.0}, "plan_segments: separation_m: must be finite and > 0 (got 0.0)"),
        ({"segments": ()}, "plan_segments: segments: give 1 … 10000 segments (got 0)"),
        ({"segments": (LineSegment(length_m=0.0),)}, "plan_segments: segments[0].length_m: must not be zero"),
        ({"segments": ("line",)}, "plan_segments: segments[0]: expected a segment"),
    ],
)
def test_plan_segments_refuses_a_bad_argument_naming_it(arguments: dict[str, Any], line: str) -> None:
    call = {"segments": (LineSegment(length_m=1.0),), "limits": LIMITS, "separation_m": 0.5, "sample_period_s": 0.04}
    with pytest.raises(ConfigError) as info:
        plan_segments(**{**call, **arguments})
    assert str(info.value).startswith(line)


@pytest.mark.parametrize(
    ("state", "line"),
    [
        ([0, 0, math.nan, 0, 0], "simulate_open_loop: initial_state[x_m]: must be finite and within ±1e+06 (got nan)"),
        ([1e308, 0, 0, 0, 0], "simulate_open_loop: initial_state[omega_pre_left_rad_s]: must be finite and within"),
        ([0, 0, 0], "simulate_open_loop: initial_state: must have shape (5,) (got (3,))"),
    ],
)
def test_simulate_open_loop_refuses_a_bad_initial_state(vehicle: Any, state: list[float], line: str) -> None:
    with pytest.raises(ConfigError) as info:
        simulate_open_loop(vehicle, np.ones((3, 2)), initial_state=state)
    assert str(info.value).startswith(line)


def test_read_log_of_an_empty_file_is_a_package_error(tmp_path: Path) -> None:
    (tmp_path / "log.csv").write_text("")
    with pytest.raises(ConfigError, match="log.csv: empty file"):
        read_log(tmp_path / "log.csv")


def test_read_log_names_the_line_of_a_bad_cell(tmp_path: Path) -> None:
    (tmp_path / "log.csv").write_text("t_s,x_m\n0,1\n0.04,oops\n")
    with pytest.raises(ConfigError, match=r"log.csv: line 3: not a number: 'oops'"):
        read_log(tmp_path / "log.csv")


def test_read_log_accepts_a_byte_order_mark_and_reads_what_to_csv_wrote(tmp_path: Path) -> None:
    SimLog({"t_s": np.array([0.0, 0.04]), "x_m": np.array([1.0, math.nan])}).to_csv(tmp_path / "log.csv")
    data = (tmp_path / "log.csv").read_bytes()
    (tmp_path / "bom.csv").write_bytes(b"\xef\xbb\xbf" + data)
    log = read_log(tmp_path / "bom.csv")
    assert list(log) == ["t_s", "x_m"] and log["t_s"][1] == 0.04 and math.isnan(log["x_m"][1])


def test_a_profile_error_names_the_line_in_the_file_after_comment_lines(tmp_path: Path) -> None:
    path = tmp_path / "p.csv"
    path.write_text("# a profile\n# volts\nt_s,da_left_v,da_right_v\n0,1,1\n\n0.5,1,x\n")
    with pytest.raises(ConfigError, match=r"p.csv: line 6: expected three numbers"):
        load_input_profile(path, 0.04, 1.0)
    path.write_text("# a profile\nt_s,da_left_v,da_right_v\n0,1,1\n# a pause\n0,2,2\n")
    with pytest.raises(ConfigError, match=r"p.csv: line 5: t_s must increase strictly"):
        load_input_profile(path, 0.04, 1.0)


def test_csv_files_written_by_excel_with_a_byte_order_mark_are_read(tmp_path: Path) -> None:
    profile = tmp_path / "p.csv"
    profile.write_bytes(b"\xef\xbb\xbft_s,da_left_v,da_right_v\r\n0,1,2\r\n")
    assert load_input_profile(profile, 0.04, 0.08).tolist() == [[1.0, 2.0], [1.0, 2.0]]
    runs = tmp_path / "runs.csv"
    runs.write_bytes(b"\xef\xbb\xbfdirection,x_m,y_m\r\ncw,0.1,0.2\r\nccw,0.1,0.1\r\n")
    cw, ccw = read_umbmark_log(runs)
    assert cw.shape[-1] == 2 and ccw.shape[-1] == 2


def test_a_calibration_log_error_names_the_line_in_the_file_after_comment_lines(tmp_path: Path) -> None:
    runs = tmp_path / "runs.csv"
    runs.write_text("# hall B, 4 m square\ndirection,x_m,y_m\n# first cw\ncw,0.1,0.2\n\nccw,0.1,oops\n")
    with pytest.raises(ConfigError, match=r"runs.csv: line 6: y_m is not a finite number \(oops\)"):
        read_umbmark_log(runs)
    runs.write_text("# hall B\ndirection,x_m,y_m\ncw,0.1,0.2\nleft,0.1,0.1\n")
    with pytest.raises(ConfigError, match=r"runs.csv: line 4: direction must be cw or ccw \(got 'left'\)"):
        read_umbmark_log(runs)


@pytest.mark.parametrize(
    ("call", "line"),
    [
        (lambda v: feasible_wheel_limits("vehicle"), "feasible_wheel_limits: vehicle: expected a VehicleParams"),
        (lambda v: feasible_wheel_limits(v, current_headroom=1.0), "feasible_wheel_limits: current_headroom: must be"),
        (lambda v: feasible_wheel_limits(v, voltage_headroom="x"), "feasible_wheel_limits: voltage_headroom: expected"),
        (lambda v: feedback_accel_m_s2(None), "feedback_accel_m_s2: vehicle: expected a VehicleParams"),
        (lambda v: feedback_accel_m_s2(v, current_headroom=-0.1), "feedback_accel_m_s2: current_headroom: must be"),
        (lambda v: torque_accel_limit_m_s2(3), "torque_accel_limit_m_s2: vehicle: expected a VehicleParams"),
        (lambda v: actuator_headroom("v", [[0.0, 0.0]], [[0.0, 0.0]]), "actuator_headroom: vehicle: expected a"),
        (lambda v: WheelReach({}), "WheelReach: vehicle: expected a VehicleParams"),
        (lambda v: wheel_accel_reach_m_s2(1.0, [0.0, 0.0]), "wheel_accel_reach_m_s2: vehicle: expected a"),
        (lambda v: no_default_limit_reasons(v, None), "no_default_limit_reasons: limits: expected a FeasibleLimits"),
    ],
)
def test_the_feasibility_functions_refuse_a_bad_argument_naming_it(vehicle: Any, call: Any, line: str) -> None:
    with pytest.raises(ConfigError) as info:
        call(vehicle)
    assert line in str(info.value) and "\n" not in str(info.value)
