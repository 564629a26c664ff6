"""The Python API never crashes: random arguments to its public constructors and entry points end in success or
the package's own one-line error.

The segments and the other path dataclasses, the vehicle parameter dataclasses, the experiment's plant and
robustness tables, the fuzz configuration and the limits, :func:`plan_segments`, :func:`plan_waypoints`,
:func:`simulate_open_loop` (a few samples each), :func:`read_log` (random bytes), :func:`run_closed_loop`,
:func:`fuzz` and :func:`check_experiments` (on paths of a few centimetres) get random arguments: NaN, ±inf, huge
and tiny numbers, zero, negative, wrong types, misspelled choices, mixed with sensible values so that success is
reached too. The only accepted outcomes
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
import pytest
from cli_runs import assert_clean
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agvctl.checks.runner import check_experiments
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig
from agvctl.controllers.baselines.ramsete import RamseteConfig
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.docking import DockingConfig
from agvctl.controllers.mpc.rest import RestConfig
from agvctl.controllers.pi.options import PIGains
from agvctl.controllers.pi.tuning import TuningSpec
from agvctl.controllers.registry import POSE_CONTROLLERS
from agvctl.errors import AgvctlError
from agvctl.estimation.ekf import EkfSettings
from agvctl.estimation.offline import read_log
from agvctl.evaluation.limits import LIMITS, LimitsSpec
from agvctl.fuzz.run import fuzz, fuzz_tasks
from agvctl.fuzz.spec import DEFAULT_ENVELOPE, EstimatorsSpec, FuzzSpec, PathGenSpec, StartSpec
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
# A string is a valid path: the wrong-type string points into the scratch folder, so a writer given it writes there.
STRAY = str(WORK / "x")

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
test_start_spec = _constructor_test(StartSpec)


@API
@given(
    localization=st.lists(st.sampled_from(["ekf", "odometry", "truth", "ekff", ""]) | values, max_size=2) | values,
    wheel_speed=st.lists(st.sampled_from(["kalman", "exact", "count_difference", "kalmn"]) | values, max_size=2)
    | values,
)
def test_estimators_spec(localization: Any, wheel_speed: Any) -> None:
    assert_clean(lambda: EstimatorsSpec(localization=localization, wheel_speed=wheel_speed), "EstimatorsSpec")


test_ramsete_config = _constructor_test(RamseteConfig)
test_ltv_lqr_config = _constructor_test(LtvLqrConfig)
test_pi_gains = _constructor_test(PIGains)


@API
@given(kwargs=arguments(TuningSpec))
def test_tuning_spec(kwargs: dict[str, Any]) -> None:
    assert_clean(lambda: TuningSpec(**kwargs), "TuningSpec", "tuning specification")


@st.composite
def mostly(draw: st.DrawFn, good: st.SearchStrategy[Any], bad: st.SearchStrategy[Any], in_four: int = 3) -> Any:
    """``good`` ``in_four`` times in four (a drawn selector: ``one_of`` would flatten ``bad``'s branches beside
    ``good``), so that arguments of several fields reach success often enough to test it too."""
    return draw(good) if draw(st.integers(0, 3)) < in_four else draw(bad)


ranges = st.tuples(values, values) | st.lists(values, max_size=3)
fractions = st.lists(st.floats(0.01, 1.0), min_size=2, max_size=2).map(sorted).map(tuple)
words = st.lists(st.sampled_from(["line", "arc", "turn", "smooth", "stop", "lin", ""]) | values, max_size=3)
path_gen_args = {
    "segments": mostly(st.lists(st.integers(1, 4), min_size=2, max_size=2).map(sorted).map(tuple), ranges),
    "segment_types": mostly(st.lists(st.sampled_from(["line", "arc", "turn"]), min_size=1, max_size=3), words),
    "join": mostly(st.lists(st.sampled_from(["smooth", "stop"]), min_size=1, max_size=2), words),
    "explicit_limits_fraction": mostly(st.floats(0.0, 1.0), values),
    **{name: mostly(fractions, ranges) for name in ("line_length_m", "arc_radius_m", "wheel_speed_fraction")},
    **{name: mostly(fractions.map(lambda r: (100 * r[0], 100 * r[1])), ranges) for name in ("arc_angle_deg",)},
}


@API
@given(kwargs=st.fixed_dictionaries({}, optional=path_gen_args))
def test_path_gen_spec(kwargs: dict[str, Any]) -> None:
    assert_clean(lambda: PathGenSpec(**kwargs), "PathGenSpec")


@API
@given(bounds=st.dictionaries(st.sampled_from([*LIMITS, "tracking_eror_max_m", "", 1, 1.5, None]), values, max_size=4))
def test_limits_spec(bounds: Any) -> None:
    assert_clean(lambda: LimitsSpec(bounds), "LimitsSpec")


required_fuzz_args = {
    "seed": mostly(st.integers(0, 10**6), values),
    "scenarios": mostly(st.integers(1, 3), values),
}
envelope = st.dictionaries(
    st.sampled_from(list(DEFAULT_ENVELOPE)), st.floats(-0.05, 0.0).map(lambda lo: (lo, -lo)), max_size=3
)
fuzz_args = {
    "controllers": mostly(
        st.lists(st.sampled_from(list(POSE_CONTROLLERS)), min_size=1, max_size=2, unique=True),
        st.lists(st.sampled_from([*POSE_CONTROLLERS, "Mpc", ""]) | values, max_size=3) | values,
    ),
    "settle_s": mostly(st.floats(0.0, 2.0), values),
    "start": mostly(st.builds(StartSpec), values),
    "plant": mostly(
        envelope,
        st.dictionaries(st.sampled_from([*DEFAULT_ENVELOPE, "body.mass", "wheels", 1, None]), ranges, max_size=3)
        | values,
    ),
    "controller": mostly(
        st.fixed_dictionaries({}, optional={"horizon": st.integers(5, 30), "coulomb_feedforward": st.booleans()}),
        st.dictionaries(st.sampled_from(["horizon", "reach_lead", "coulomb_feedforward", "pose"]), values) | values,
    ),
    "limits": mostly(st.builds(LimitsSpec), values),
    "estimators": mostly(st.builds(EstimatorsSpec), values),
    "name": mostly(st.sampled_from(["ok", ""]), st.sampled_from(["../x", "a/b", "\x00"]) | values),
}


@API
@given(kwargs=st.fixed_dictionaries(required_fuzz_args, optional=fuzz_args))
def test_fuzz_spec(kwargs: dict[str, Any]) -> None:
    """A fuzz configuration made in Python, then its scenarios drawn (:func:`fuzz_tasks` checks it against the
    vehicle before anything runs)."""

    def call() -> object:
        return fuzz_tasks(FuzzSpec(**kwargs), scenarios=[0])

    assert_clean(call, "FuzzSpec", "LimitsSpec", "StartSpec", "PathGenSpec")


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


# The runs' options, on runs of a few centimetres. Only the local executor in this process is drawn (one job):
# worker processes take seconds to start, and a Dask scheduler's address is a network connection; the fuzz and
# check tests run both.
options = {
    "jobs": mostly(st.just(1), st.sampled_from([0, -1, 1.5, 10**6, True, "2"]), in_four=2),
    "executor": mostly(st.just("local"), st.sampled_from(["Local", "", None, 1]), in_four=2),
    "scheduler": mostly(st.none(), st.sampled_from([3, b"tcp://x"]), in_four=2),
    "progress": mostly(st.sampled_from([None, lambda done, total: None]), st.sampled_from([3, "print"]), in_four=2),
}
TINY_FUZZ = FuzzSpec(
    seed=1,
    scenarios=1,
    settle_s=0.1,
    paths=PathGenSpec(segments=(1, 1), segment_types=("line",), line_length_m=(0.03, 0.05)),
)
indices = mostly(
    st.sampled_from([None, [0], (1,)]),
    st.lists(st.sampled_from([0, -1, 1.5, 10**10, None, "0"]), max_size=2) | values,
)


@API
@given(spec=mostly(st.just(TINY_FUZZ), values), scenarios=indices, **options)
def test_fuzz(spec: Any, scenarios: Any, jobs: Any, executor: Any, scheduler: Any, progress: Any) -> None:
    assert_clean(
        lambda: fuzz(spec, scenarios=scenarios, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress),
        "fuzz",
        "--jobs",
        "--executor",
        "--scheduler",
        "progress",
    )


def _experiment_files() -> list[Any]:
    (WORK / "tiny.toml").write_text('[[segments]]\ntype = "line"\nlength_m = 0.04\n')
    (WORK / "tiny_exp.toml").write_text('name = "tiny"\ntrajectory = "tiny.toml"\nsettle_s = 0.1\n')
    (WORK / "broken.toml").write_text('name = "broken"\ntrajectory = "missing.toml"\n')
    return [str(WORK / "tiny_exp.toml"), WORK / "tiny_exp.toml"]


BAD_EXPERIMENTS = [str(WORK / "broken.toml"), str(WORK), str(WORK / "none.toml"), 3, None]
experiment_lists = st.lists(st.sampled_from(_experiment_files()), min_size=1, max_size=2)


@API
@given(
    paths=mostly(experiment_lists, st.lists(st.sampled_from(BAD_EXPERIMENTS), max_size=2) | values),
    **options,
)
def test_check_experiments(paths: Any, jobs: Any, executor: Any, scheduler: Any, progress: Any) -> None:
    assert_clean(
        lambda: check_experiments(paths, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress),
        "check_experiments",
        str(WORK),
        "--jobs",
        "--executor",
        "--scheduler",
        "progress",
    )


# Every other entry point of the API reference, each argument its type or something else: a wrong type is the
# package's one-line error naming the function (or class) and the argument, never an AttributeError from inside.
@st.composite
def one_in(draw: st.DrawFn, good: st.SearchStrategy[Any], n: int) -> Any:
    """``good`` once in ``n`` draws, else a value of the wrong type."""
    return draw(good) if draw(st.integers(0, n - 1)) == 0 else draw(values | st.sampled_from([VEHICLE, STRAY, b""]))


def _tiny_run() -> tuple[Any, Any]:
    from agvctl.scenario.experiment import load_experiment, run_experiment

    _experiment_files()
    experiment = load_experiment(WORK / "tiny_exp.toml")
    return experiment, run_experiment(experiment)


TINY_EXPERIMENT, TINY_RUN = _tiny_run()


def _entry_points() -> dict[str, tuple[Callable[..., object], list[st.SearchStrategy[Any]]]]:
    from agvctl.controllers.baselines.ltv_lqr import LtvLqrController
    from agvctl.controllers.baselines.ramsete import RamseteController
    from agvctl.controllers.mpc.ltv import LtvMpcController
    from agvctl.controllers.pi.tuning import design_pi
    from agvctl.controllers.pi.wheel_loop import PIWheelController
    from agvctl.estimation.ekf import PoseEkf
    from agvctl.estimation.odometry import OdometryEstimator
    from agvctl.estimation.offline import filter_log, smooth_log
    from agvctl.evaluation.metrics import closed_loop_metrics
    from agvctl.planning import plan
    from agvctl.plant import decoupled_wheel_models, linear_model
    from agvctl.scenario.experiment import run_experiment

    vehicle = one_in(st.just(VEHICLE), 4)
    log = one_in(st.just(TINY_RUN.log), 4)
    gains = PIGains(kp=0.02, ki=0.3, dt_s=0.04)
    from agvctl.htmlreport import check_html, check_run_figures, fuzz_html, write_check_html, write_fuzz_html

    checked = one_in(st.just(check_experiments([WORK / "tiny_exp.toml"], jobs=1)), 16)
    fuzzed = one_in(st.just(fuzz(TINY_FUZZ, jobs=1)), 16)
    page = one_in(st.just(WORK / "page.html"), 4)
    return {
        "check_html": (lambda r, t: check_html(r, title=t), [checked, one_in(st.text(max_size=4), 4)]),
        "write_check_html": (write_check_html, [checked, page]),
        "fuzz_html": (
            lambda r, d, w: fuzz_html(r, failures_dir=d, worst=w),
            [fuzzed, one_in(st.just("failures"), 2), one_in(st.integers(0, 1), 4)],
        ),
        "write_fuzz_html": (write_fuzz_html, [fuzzed, page]),
        "check_run_figures": (
            check_run_figures,
            [one_in(st.just(TINY_EXPERIMENT), 4), one_in(st.just(TINY_RUN), 4), one_in(st.just([]), 4)],
        ),
        "linear_model": (linear_model, [vehicle]),
        "decoupled_wheel_models": (decoupled_wheel_models, [vehicle]),
        "plan": (plan, [one_in(st.just(PathSpec(segments=(LineSegment(length_m=0.04),))), 4), vehicle]),
        "run_experiment": (run_experiment, [one_in(st.just(TINY_EXPERIMENT), 8)]),
        "closed_loop_metrics": (closed_loop_metrics, [one_in(st.just(TINY_RUN), 4)]),
        "LtvMpcController": (LtvMpcController, [vehicle, one_in(st.none() | st.builds(MpcConfig), 4)]),
        "PIWheelController": (PIWheelController, [vehicle, one_in(st.just(gains), 4)]),
        "design_pi": (design_pi, [one_in(st.just(VEHICLE), 16), one_in(st.none(), 16)]),
        "RamseteController": (RamseteController, [vehicle, one_in(st.none() | st.builds(RamseteConfig), 4)]),
        "LtvLqrController": (LtvLqrController, [vehicle, one_in(st.none() | st.builds(LtvLqrConfig), 4)]),
        "PoseEkf": (PoseEkf, [vehicle, one_in(st.none() | st.builds(EkfSettings), 4)]),
        "OdometryEstimator": (OdometryEstimator, [vehicle]),
        "filter_log": (filter_log, [log, vehicle, one_in(st.none(), 4)]),
        "smooth_log": (smooth_log, [log, vehicle, one_in(st.none(), 4)]),
    }


ENTRY_POINTS = _entry_points()


@pytest.mark.parametrize("name", list(ENTRY_POINTS))
def test_entry_point_arguments(name: str) -> None:
    function, arguments = ENTRY_POINTS[name]

    @API
    @given(args=st.tuples(*arguments))
    def check(args: tuple[Any, ...]) -> None:
        assert_clean(lambda: function(*args), name)

    check()
