"""The Python API never crashes: random arguments to its public constructors and entry points end in success or
the package's own one-line error.

The segments and the other path dataclasses, the vehicle parameter dataclasses, the experiment's plant and
robustness tables, :func:`plan_segments`, :func:`plan_waypoints`, :func:`simulate_open_loop` (a few samples each)
and :func:`read_log` (random bytes) get random arguments: NaN, ±inf, huge and tiny numbers, zero, negative, wrong
types, misspelled choices, mixed with sensible values so that success is reached too. The only accepted outcomes
are success, or an :class:`~agvctl.errors.AgvctlError` whose message is one line starting with the class or
function it names (the path's source for :func:`plan_waypoints`, the file for :func:`read_log`). Any other
exception fails.

Each gets :data:`EXAMPLES` examples, drawn deterministically.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from cli_runs import assert_clean
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.docking import DockingConfig
from agvctl.controllers.mpc.rest import RestConfig
from agvctl.errors import AgvctlError
from agvctl.estimation.ekf import EkfSettings
from agvctl.estimation.offline import read_log
from agvctl.params import (
    AmplifierParams,
    BatteryParams,
    BodyParams,
    ControlParams,
    DAParams,
    FrameParams,
    FrictionModelParams,
    MotorParams,
    SensorParams,
    WheelSide,
    load_vehicle,
)
from agvctl.planning import ArcSegment, LineSegment, TurnSegment, WheelLimits, plan_segments, plan_waypoints
from agvctl.planning.geometry import Pose
from agvctl.planning.spec import PathLimits, PathSpec, StartPose, Waypoint
from agvctl.scenario.spec import ControllerSpec, ExperimentSpec, PlantSpec, RobustnessSpec, Spread
from agvctl.sim.open_loop import simulate_batch, simulate_open_loop

EXAMPLES = 1000
API = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
)
WORK = Path(tempfile.mkdtemp(prefix="agvctl-api-"))

NASTY: list[Any] = [0, -1, 1, 0.0, -0.0, 1e-300, -1e-300, 1e-9, 1e9, 1e308, -1e308, math.nan, math.inf, -math.inf]
WRONG_TYPES: list[Any] = [None, True, False, "1", "", "smoth", [], {}, (1.0,), object()]
numbers = st.sampled_from(NASTY) | st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(10**9), 10**9)
sensible = st.floats(1e-3, 10.0) | st.floats(-10.0, -1e-3) | st.integers(1, 20)
values = sensible | sensible | numbers | st.sampled_from(WRONG_TYPES)


def arguments(cls: type) -> st.SearchStrategy[dict[str, Any]]:
    """Keyword arguments for every field of the dataclass ``cls``, random values for some of them."""
    names = [f.name for f in dataclasses.fields(cls) if f.init]
    return st.fixed_dictionaries({name: values for name in names})


# ----------------------------------------------------------------------------------------------------------------
# Constructors

SEGMENTS = [LineSegment, TurnSegment, ArcSegment]
PATH_DATACLASSES = [StartPose, PathLimits, Waypoint]
VEHICLE_DATACLASSES = [
    FrameParams,
    BatteryParams,
    BodyParams,
    AmplifierParams,
    DAParams,
    FrictionModelParams,
    SensorParams,
    ControlParams,
    WheelSide,
    MotorParams,
]


def _constructor_test(cls: type) -> Callable[..., None]:
    @API
    @given(kwargs=arguments(cls))
    def check(kwargs: dict[str, Any]) -> None:
        assert_clean(lambda: cls(**kwargs), cls.__name__)

    return check


test_line_segment = _constructor_test(LineSegment)
test_turn_segment = _constructor_test(TurnSegment)
test_arc_segment = _constructor_test(ArcSegment)
test_start_pose = _constructor_test(StartPose)
test_path_limits = _constructor_test(PathLimits)
test_waypoint = _constructor_test(Waypoint)
test_frame_params = _constructor_test(FrameParams)
test_battery_params = _constructor_test(BatteryParams)
test_body_params = _constructor_test(BodyParams)
test_amplifier_params = _constructor_test(AmplifierParams)
test_da_params = _constructor_test(DAParams)
test_friction_model_params = _constructor_test(FrictionModelParams)
test_sensor_params = _constructor_test(SensorParams)
test_control_params = _constructor_test(ControlParams)
test_wheel_side = _constructor_test(WheelSide)
test_motor_params = _constructor_test(MotorParams)
test_plant_spec = _constructor_test(PlantSpec)
test_spread = _constructor_test(Spread)
test_robustness_spec = _constructor_test(RobustnessSpec)
test_pose = _constructor_test(Pose)
test_mpc_config = _constructor_test(MpcConfig)
test_docking_config = _constructor_test(DockingConfig)
test_rest_config = _constructor_test(RestConfig)
test_ekf_settings = _constructor_test(EkfSettings)
test_path_spec = _constructor_test(PathSpec)
test_experiment_spec = _constructor_test(ExperimentSpec)
test_controller_spec = _constructor_test(ControllerSpec)


@API
@given(speed=values, accel=values, jerk=values)
def test_wheel_limits(speed: Any, accel: Any, jerk: Any) -> None:
    assert_clean(lambda: WheelLimits(speed, accel, jerk), "WheelLimits")


# ----------------------------------------------------------------------------------------------------------------
# Entry points

segment_args = {
    LineSegment: {"length_m": st.floats(-5.0, 5.0) | values, "speed_m_s": st.none() | values},
    TurnSegment: {"angle_deg": st.floats(-720.0, 720.0) | values, "speed_m_s": st.none() | values},
    ArcSegment: {"radius_m": st.floats(0.01, 5.0) | values, "angle_deg": st.floats(-360, 360) | values},
}


@st.composite
def segment(draw: st.DrawFn) -> Any:
    cls = draw(st.sampled_from(SEGMENTS))
    kwargs = draw(st.fixed_dictionaries(segment_args[cls]))
    try:
        return cls(**kwargs)
    except AgvctlError:
        return draw(st.sampled_from([LineSegment(length_m=1.0), TurnSegment(angle_deg=90.0), "line", None]))


limits = st.builds(WheelLimits, st.floats(0.05, 2.0), st.floats(0.05, 2.0), st.floats(0.5, 10.0)) | st.just(
    WheelLimits(0.8, 0.5, 3.0)
)


@API
@given(
    segments=st.lists(segment(), min_size=0, max_size=3),
    limits=limits,
    separation_m=st.floats(0.1, 1.0) | values,
    sample_period_s=st.sampled_from([0.04, 0.02, 0.1]) | values,
    join=st.sampled_from(["smooth", "stop", "smoth", "", None, 1]),
)
def test_plan_segments(
    segments: list[Any], limits: WheelLimits, separation_m: Any, sample_period_s: Any, join: Any
) -> None:
    assert_clean(
        lambda: plan_segments(
            segments, limits=limits, separation_m=separation_m, sample_period_s=sample_period_s, join=join
        ),
        "plan_segments",
        "segments[",  # a motion that cannot be planned: a PlanningError naming the segment
    )


@st.composite
def waypoint(draw: st.DrawFn) -> Any:
    coordinate = st.floats(-5.0, 5.0) | values
    kwargs = draw(st.fixed_dictionaries({"x_m": coordinate, "y_m": coordinate, "theta_deg": st.none() | values}))
    try:
        return Waypoint(**kwargs)
    except AgvctlError:
        return draw(st.sampled_from([Waypoint(x_m=1.0, y_m=0.0), Waypoint(x_m=0.0, y_m=0.0)]))


@API
@given(
    waypoints=st.lists(waypoint(), min_size=0, max_size=4),
    limits=limits,
    separation_m=st.floats(0.1, 1.0) | values,
    sample_period_s=st.sampled_from([0.04, 0.02, 0.1]) | values,
)
def test_plan_waypoints(waypoints: list[Any], limits: WheelLimits, separation_m: Any, sample_period_s: Any) -> None:
    assert_clean(
        lambda: plan_waypoints(
            waypoints, limits=limits, separation_m=separation_m, sample_period_s=sample_period_s, source="path.toml"
        ),
        "path.toml",
        "waypoints",  # a path that cannot be planned: a PlanningError naming the waypoints
    )


VEHICLE = load_vehicle()
commands = st.lists(st.tuples(st.floats(-12.0, 12.0) | numbers, st.floats(-12.0, 12.0) | numbers), max_size=4)
states = st.none() | st.lists(st.floats(-1.0, 1.0) | numbers, min_size=0, max_size=6) | st.sampled_from(WRONG_TYPES)


@API
@given(da=commands | st.sampled_from(WRONG_TYPES), initial_state=states)
def test_simulate_open_loop(da: Any, initial_state: Any) -> None:
    result = assert_clean(lambda: simulate_open_loop(VEHICLE, da, initial_state=initial_state), "simulate_open_loop")
    if result is not None:
        assert np.all(np.isfinite(result.log["x_m"]))  # type: ignore[attr-defined]


@API
@given(data=st.binary(max_size=200) | st.text(alphabet="t_s,x0.1e-\n\r# \ufeffnaNinf", max_size=80).map(str.encode))
def test_read_log(data: bytes) -> None:
    path = WORK / "log.csv"
    path.write_bytes(data)
    assert_clean(lambda: read_log(path), str(path))


@API
@given(
    da=commands | st.sampled_from(WRONG_TYPES),
    initial_states=st.none() | st.lists(states, min_size=0, max_size=3) | st.sampled_from(WRONG_TYPES),
    n_vehicles=st.integers(1, 2),
)
def test_simulate_batch(da: Any, initial_states: Any, n_vehicles: int) -> None:
    vehicles = [VEHICLE] * n_vehicles
    call = lambda: simulate_batch(vehicles, da, initial_states=initial_states)  # noqa: E731
    logs = assert_clean(call, "simulate_batch", "simulate_open_loop")
    if logs is not None:
        assert all(np.all(np.isfinite(log["x_m"])) for log in logs)  # type: ignore[attr-defined]


SHORT_LINE = plan_segments(
    [LineSegment(length_m=0.05)],
    limits=WheelLimits(wheel_speed_m_s=0.3, wheel_accel_m_s2=0.4, wheel_jerk_m_s3=2.0),
    separation_m=VEHICLE.wheels.separation_m,
    sample_period_s=VEHICLE.control.sample_period_s,
)


@API
@given(
    initial_pose=st.none() | st.lists(numbers | st.floats(-0.01, 0.01), max_size=4) | st.sampled_from(WRONG_TYPES),
    settle_s=st.sampled_from([0.0, 0.04, -1.0, 601.0, math.nan, math.inf, "1", None]),
    compute_delay=st.sampled_from(["none", "one_sample", "two", None]),
    sensor_seed=st.sampled_from([0, 1, -1, 1.5, True, None]),
)
def test_run_closed_loop(initial_pose: Any, settle_s: Any, compute_delay: Any, sensor_seed: Any) -> None:
    from agvctl.controllers.base import PoseCommand
    from agvctl.controllers.pi.tuning import default_pi_gains
    from agvctl.controllers.pi.wheel_loop import PIWheelController
    from agvctl.sim.loop import run_closed_loop

    class Still:
        def reset(self, reference: object) -> None:
            pass

        def update(self, t_s: float, pose: object, wheel_speed_m_s: object) -> PoseCommand:
            return PoseCommand(0.0, 0.0)

    def call() -> object:
        return run_closed_loop(
            plant_vehicle=VEHICLE,
            controller_vehicle=VEHICLE,
            reference=SHORT_LINE,
            pose_controller=Still(),
            wheel_controller=PIWheelController(VEHICLE, default_pi_gains(VEHICLE).gains),
            initial_pose=initial_pose,
            settle_s=settle_s,
            compute_delay=compute_delay,
            sensor_seed=sensor_seed,
        )

    assert_clean(call, "run_closed_loop", "simulate_open_loop")
