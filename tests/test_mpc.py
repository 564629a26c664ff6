"""MPC pose controllers on a simple plant: the report's kinematics (eqs 39-43) driven through a first-order
lag of the wheel speeds (a stand-in for the closed PI loops), integrated exactly for the lag and with small
midpoint steps for the pose. Checks convergence from an offset, the hard wheel-speed and wheel-acceleration
limits in every command and every predicted sequence, the fallbacks, and the strict config loading."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import osqp
import pytest

from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.fallback import limit_command
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.ltv_qp import INF, QpReference, QpStep, StepBlock
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController
from agvctl.controllers.mpc.qp_blocks import Pattern, VariableLayout
from agvctl.errors import ConfigError
from agvctl.feasibility import feedback_accel_m_s2
from agvctl.params import VehicleParams
from agvctl.planning import PathLimits, PathSpec, plan, plan_file
from agvctl.planning.reference import Reference
from agvctl.planning.spec import LineSegment

ROOT = Path(__file__).resolve().parents[1]
PLANT_TIME_CONSTANT_S = 0.12
"""The simple plant's wheel lag: deliberately not the controller's default model value (0.1 s)."""


@pytest.fixture(scope="module")
def figure8(vehicle: VehicleParams) -> Reference:
    return plan_file(ROOT / "trajectories" / "figure8.toml", vehicle)


@pytest.fixture(scope="module")
def line(vehicle: VehicleParams) -> Reference:
    return plan_file(ROOT / "trajectories" / "line.toml", vehicle)


def closed_loop(controller, reference: Reference, vehicle: VehicleParams, *, start, duration_s: float):
    """Run ``controller`` on the simple plant; returns (times, position errors, commands, statuses)."""
    T, b = vehicle.control.sample_period_s, vehicle.wheels.separation_m
    controller.reset(reference)
    pose = np.array(start, dtype=float)
    wheel = np.zeros(2)
    n = round(duration_s / T)
    substeps = 8
    h = T / substeps
    decay = math.exp(-h / PLANT_TIME_CONSTANT_S)
    errors, commands, statuses = np.empty(n), np.empty((n, 2)), []
    for k in range(n):
        cmd = controller.update(k * T, pose, wheel)
        s = np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s])
        commands[k] = s
        statuses.append(cmd.status)
        for _ in range(substeps):
            w_next = s + (wheel - s) * decay
            v = 0.5 * (wheel + w_next)
            U, omega = 0.5 * (v[0] + v[1]), (v[1] - v[0]) / b  # eqs 39-40
            mid = pose[2] + 0.5 * omega * h
            pose = pose + h * np.array([U * math.cos(mid), U * math.sin(mid), omega])  # eqs 41-43
            wheel = w_next
        r = reference.sample([(k + 1) * T])
        errors[k] = math.hypot(pose[0] - r.x_m[0], pose[1] - r.y_m[0])
    return (np.arange(n) + 1) * T, errors, commands, statuses


def test_converges_from_lateral_offset_and_tracks_figure8(vehicle: VehicleParams, figure8: Reference) -> None:
    ctrl = LtvMpcController(vehicle)
    duration_s = figure8.duration_s
    t, err, _, statuses = closed_loop(ctrl, figure8, vehicle, start=(0.0, 0.1, 0.0), duration_s=duration_s)
    assert err[0] > 0.09  # it did start 0.1 m off the path
    assert np.max(err[t >= 3.0]) < 0.02  # the acceptance: within 2 cm after 3 s, and it stays there
    assert ctrl.failures == 0 and set(statuses) == {"solved"}


class _FullReload(LtvMpcController):
    """The LTV MPC giving OSQP all of P and A on every step."""

    def _load_matrices(self, step: QpStep) -> dict[str, Any]:
        super()._load_matrices(step)  # the step's entries into the data arrays
        return {"Px": self._qp.p_data.copy(), "Ax": self._qp.a_data.copy()}


class _FirstLoadOnly(LtvMpcController):
    """The LTV MPC keeping the first step's A: what a wrong change test would do."""

    def _load_matrices(self, step: QpStep) -> dict[str, Any]:
        update = super()._load_matrices(step)
        if hasattr(self, "_loaded_once"):
            return {}
        self._loaded_once = True
        return update


def test_loading_only_the_changed_matrix_entries_is_the_same_as_reloading_all(
    vehicle: VehicleParams, figure8: Reference
) -> None:
    """The step hands OSQP only the entries of P and A that changed since the last solve; on a path whose curvature
    varies, every command is the one from reloading both matrices whole each step, within the solver's tolerance
    (a reload refactorises, so the iterates differ in the last digits OSQP guarantees), while a solver that keeps
    stale matrices is far off."""
    runs = [
        closed_loop(c, figure8, vehicle, start=(0.0, 0.05, 0.1), duration_s=4.0)[2]
        for c in (LtvMpcController(vehicle), _FullReload(vehicle), _FirstLoadOnly(vehicle))
    ]
    assert np.max(np.abs(runs[0] - runs[1])) < 1e-3  # m/s
    assert np.max(np.abs(runs[2] - runs[1])) > 1e-2


def test_a_reset_controller_commands_as_a_new_one(vehicle: VehicleParams, figure8: Reference) -> None:
    """A controller used on one run and reset onto the next gives the commands a new controller gives: the solver's
    iterates and its adapted step size do not carry over (to rounding: the factorisation is redone in another
    order)."""
    used = LtvMpcController(vehicle)
    closed_loop(used, figure8, vehicle, start=(0.0, 0.05, 0.1), duration_s=4.0)
    again, new = (
        closed_loop(c, figure8, vehicle, start=(0.02, -0.03, -0.05), duration_s=4.0)[2]
        for c in (used, LtvMpcController(vehicle))
    )
    assert np.max(np.abs(again - new)) < 1e-9  # m/s


def test_frames_are_the_same_model(vehicle: VehicleParams, line: Reference) -> None:
    """Path-frame and world-frame errors are rotations of each other and the cost is rotation invariant (with the
    along-path error weighed as the cross-path one: a share below 1 exists in the path frame only)."""
    runs = [
        closed_loop(LtvMpcController(vehicle, MpcConfig(error_frame=f, tolerance=1e-6, along_track_share=1.0)),
                    line, vehicle,
                    start=(0.0, 0.05, 0.1), duration_s=3.0)[2]
        for f in ("path", "world")
    ]  # fmt: skip
    np.testing.assert_allclose(runs[0], runs[1], atol=1e-4)


def test_wheel_speed_and_acceleration_limits_hold(vehicle: VehicleParams, line: Reference) -> None:
    """A start far off the path (0.3 m, 0.6 rad) behind a reference cruising faster than the MPC's speed limit
    drives the controller into both limits. Every command respects |s| ≤ v_max and |Δs| ≤ a_lim·T_s exactly,
    every predicted sequence to the solver's tolerance."""
    config = MpcConfig(max_wheel_speed_m_s=0.5, tolerance=1e-4)
    ctrl = LtvMpcController(vehicle, config)
    a_step = vehicle.derived.accel_limit_m_s2 * vehicle.control.sample_period_s
    T, b = vehicle.control.sample_period_s, vehicle.wheels.separation_m
    ctrl.reset(line)
    pose, previous = np.array([0.0, -0.3, 0.6]), np.zeros(2)
    peak_rate = peak_speed = 0.0
    for k in range(75):
        cmd = ctrl.update(k * T, pose, previous)  # a perfect wheel loop: the wheels run at the last command
        assert cmd.status == "solved"
        s = np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s])
        assert np.all(np.abs(s) <= 0.5) and np.all(np.abs(s - previous) <= a_step * (1 + 1e-12))
        seq = np.vstack([previous, ctrl.predicted_setpoints_m_s])
        assert np.all(np.abs(seq) <= 0.5 + 0.01 * a_step)
        assert np.all(np.abs(np.diff(seq, axis=0)) <= 1.01 * a_step)
        peak_rate = max(peak_rate, float(np.max(np.abs(s - previous))))
        peak_speed = max(peak_speed, float(np.max(np.abs(s))))
        previous = s
        U, omega = 0.5 * (s[0] + s[1]), (s[1] - s[0]) / b
        mid = pose[2] + 0.5 * omega * T
        pose = pose + T * np.array([U * math.cos(mid), U * math.sin(mid), omega])
    assert peak_rate > 0.99 * a_step  # the acceleration limit was reached, so the check above meant something
    assert peak_speed > 0.499  # and so was the speed limit


@pytest.mark.parametrize("controller", [LtvMpcController, NonlinearMpcController])
def test_setpoints_change_no_faster_than_the_paths_own_limit_plus_the_feedbacks_share(
    vehicle: VehicleParams, controller: Any
) -> None:
    """A path planned at 0.2 m/s² for its load, started 3 cm and 2° off: the setpoints change by at most 0.2 m/s²
    plus what the planner's 20 % current headroom gives (eq 5) per sample, the start's correction included; a path
    at the default limits keeps eq 5's a_lim, which the default limits and that share add up to."""
    T = vehicle.control.sample_period_s
    share = feedback_accel_m_s2(vehicle)
    gentle = plan(
        PathSpec(segments=(LineSegment(length_m=1.0),), name="gentle", limits=PathLimits(wheel_accel_m_s2=0.2)),
        vehicle,
    )
    ctrl = controller(vehicle)
    ctrl.reset(plan(PathSpec(segments=(LineSegment(length_m=1.0),)), vehicle))
    assert ctrl.max_wheel_accel_m_s2 == vehicle.derived.accel_limit_m_s2
    ctrl.reset(gentle)
    assert ctrl.max_wheel_accel_m_s2 == pytest.approx(0.2 + share)
    assert controller(vehicle, MpcConfig(max_wheel_accel_m_s2=0.6)).max_wheel_accel_m_s2 == 0.6  # set: kept
    if controller is NonlinearMpcController:
        return
    _, _, commands, statuses = closed_loop(ctrl, gentle, vehicle, start=(0.0, 0.03, math.radians(2.0)), duration_s=3)
    rates = np.abs(np.diff(np.vstack([np.zeros(2), commands]), axis=0)) / T
    assert set(statuses) == {"solved"}
    assert np.max(rates) <= (0.2 + share) * (1 + 1e-9)
    assert np.max(rates) > 0.99 * (0.2 + share)  # the correction used the bound, so the check above meant something


def test_a_small_start_error_blends_into_driving_off_and_a_large_one_still_turns_a_wheel_backwards(
    vehicle: VehicleParams, line: Reference
) -> None:
    """The reversal weight: from 3 cm and 2° off, the correction drives both wheels forward (without the weight one
    runs backwards at several cm/s) and removes the offset no slower; from 20° off a wheel still turns backwards, as
    turning on the spot is what such an error needs."""

    def run(weight: float, heading_deg: float, lateral_m: float) -> tuple[float, float]:
        ctrl = LtvMpcController(vehicle, MpcConfig(weight_reversal=weight))
        start = (0.0, lateral_m, math.radians(heading_deg))
        _, errors, commands, statuses = closed_loop(ctrl, line, vehicle, start=start, duration_s=3)
        assert set(statuses) == {"solved"}
        return float(np.min(commands)), float(np.max(errors[25:]))  # the slowest wheel; the error after 1 s

    slowest, error = run(MpcConfig().weight_reversal, 2.0, 0.03)
    slowest_without, error_without = run(0.0, 2.0, 0.03)
    assert slowest > -0.005
    assert slowest_without < -0.03
    assert error <= error_without + 1e-3
    assert run(MpcConfig().weight_reversal, 20.0, 0.0)[0] < -0.05


def test_first_move_from_speed_above_limit_is_feasible(vehicle: VehicleParams, line: Reference) -> None:
    """Measured wheel speeds beyond v_max + a_lim·T_s at reset would make a hard first move infeasible."""
    ctrl = LtvMpcController(vehicle)
    ctrl.reset(line)
    cmd = ctrl.update(0.0, np.zeros(3), np.array([1.5, 1.5]))
    assert cmd.status == "solved"
    v_max = vehicle.derived.max_speed_m_s
    assert v_max - 0.03 < cmd.wheel_speed_left_m_s <= v_max + 1e-6


class _LeftWheelCap(StepBlock):
    """A constraint block: the left wheel's setpoints at most :attr:`CAP_M_S` over the horizon, one row per sample
    (δs_left,k ≤ cap − s_ff,left,k, written for each window from the reference's feed-forward)."""

    name = "left wheel cap"
    CAP_M_S = 0.2

    def __init__(self, horizon: int) -> None:
        self.n_rows = horizon

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        for k in range(self.n_rows):
            pattern.add(k, layout.start("setpoints") + 2 * k, 1.0)

    def bind(self, qp: Any, rows: slice) -> None:
        self._upper = qp.upper[rows]
        qp.lower[rows] = -INF

    def retarget(self, reference: QpReference) -> None:
        self._upper_by_point = self.CAP_M_S - reference.grid.feedforward_m_s[:, 0]

    def write(self, step: QpStep) -> None:
        self._upper[:] = self._upper_by_point[step.k : step.k + self.n_rows]


class _CappedLeftWheel(LtvMpcController):
    def _blocks(self) -> list[StepBlock]:
        return [*super()._blocks(), _LeftWheelCap(self.config.horizon)]


def test_a_constraint_block_added_to_the_qp_bounds_its_solution(vehicle: VehicleParams, line: Reference) -> None:
    """A new constraint is one block class and one entry in the controller's list of blocks: on a line cruising at
    0.5 m/s, the left wheel's every planned setpoint stays within the block's cap, which the plain controller's
    exceed, and the right wheel is left to go faster."""
    capped, plain = _CappedLeftWheel(vehicle), LtvMpcController(vehicle)
    T = vehicle.control.sample_period_s
    highest = {}
    for ctrl in (capped, plain):
        ctrl.reset(line)
        pose, wheel, plans = np.zeros(3), np.zeros(2), []
        for k in range(75):  # 3 s: up to cruise
            cmd = ctrl.update(k * T, pose, wheel)
            assert cmd.status == "solved"
            plans.append(ctrl.predicted_setpoints_m_s)
            wheel = np.array([cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s])
            U, omega = 0.5 * (wheel[0] + wheel[1]), (wheel[1] - wheel[0]) / vehicle.wheels.separation_m  # eqs 39-40
            pose = pose + T * np.array([U * math.cos(pose[2]), U * math.sin(pose[2]), omega])  # eqs 41-43
        highest[ctrl] = np.max(np.array(plans), axis=(0, 1))
    assert highest[capped][0] <= _LeftWheelCap.CAP_M_S + 1e-3  # within the solver's tolerance
    assert highest[plain][0] > 0.4
    assert highest[capped][1] > _LeftWheelCap.CAP_M_S + 0.05


class _FaultyBlock(StepBlock):
    """A block with an indexing bug: it writes past its one row."""

    name = "faulty"
    n_rows = 1

    def bind(self, qp: Any, rows: slice) -> None:
        self._upper = qp.upper[rows]

    def write(self, step: QpStep) -> None:
        self._upper[1] = 0.0


class _Faulty(LtvMpcController):
    def _blocks(self) -> list[StepBlock]:
        return [*super()._blocks(), _FaultyBlock()]


def test_a_fault_in_the_step_raises_and_is_no_solver_failure(vehicle: VehicleParams, line: Reference) -> None:
    """An exception that is not the solver's own (here an index out of range) leaves the step, for the run to report
    as its error; it is not counted as a solver failure and hidden behind a fallback."""
    ctrl = _Faulty(vehicle)
    ctrl.reset(line)
    with pytest.raises(IndexError):
        ctrl.update(0.0, np.zeros(3), np.zeros(2))
    assert ctrl.failures == 0


def test_the_solvers_own_exception_falls_back_and_is_counted(
    vehicle: VehicleParams, line: Reference, monkeypatch: pytest.MonkeyPatch
) -> None:
    ctrl = LtvMpcController(vehicle)
    ctrl.reset(line)

    def refuse(**_: Any) -> None:
        raise osqp.OSQPException(osqp.SolverError.OSQP_DATA_VALIDATION_ERROR)

    monkeypatch.setattr(ctrl._solver, "solve", refuse)
    cmd = ctrl.update(0.0, np.zeros(3), np.zeros(2))
    assert cmd.status == "fallback_feedforward" and ctrl.failures == 1


def test_forced_solver_failure_falls_back_and_is_counted(vehicle: VehicleParams, figure8: Reference) -> None:
    """One OSQP iteration per step: every step whose optimum is not the warm start itself falls back."""
    ctrl = LtvMpcController(vehicle, MpcConfig(max_iterations=1))
    t, err, commands, statuses = closed_loop(ctrl, figure8, vehicle, start=(0.0, 0.05, 0.0), duration_s=4.0)
    assert len(t) == 100  # the run completed
    assert ctrl.failures == sum(s != "solved" for s in statuses) >= 95
    assert set(statuses) - {"solved"} == {"fallback_feedforward"}  # no sequence was ever solved to shift
    assert np.max(err) < 0.06  # the feed-forward alone keeps the offset (0.05 m), roughly


def test_shifted_fallback_after_a_failure(vehicle: VehicleParams, figure8: Reference) -> None:
    ctrl = LtvMpcController(vehicle)
    ctrl.reset(figure8)
    T = vehicle.control.sample_period_s
    g = figure8.sample(np.arange(11) * T)
    pose = lambda k: np.array([g.x_m[k], g.y_m[k], g.theta_rad[k]])  # noqa: E731 - on the reference
    wheel = lambda k: np.array([g.wheel_speed_left_m_s[k], g.wheel_speed_right_m_s[k]])  # noqa: E731
    for k in range(10):
        last = ctrl.update(k * T, pose(k), wheel(k))
        assert last.status == "solved"
    plan = ctrl.predicted_setpoints_m_s
    cmd = ctrl.update(10 * T, np.array([np.nan, 0.0, 0.0]), wheel(10))  # a broken pose estimate
    assert cmd.status == "fallback_shifted" and ctrl.failures == 1
    # the previous plan's next setpoint, within the hard limits (which the plan meets to the solver tolerance)
    a_step = vehicle.derived.accel_limit_m_s2 * T
    assert abs(plan[1, 0] - last.wheel_speed_left_m_s) <= 1.01 * a_step
    assert abs(plan[1, 1] - last.wheel_speed_right_m_s) <= 1.01 * a_step
    expected = [
        limit_command(plan[1, i], prev, ctrl.max_wheel_speed_m_s, a_step)
        for i, prev in enumerate((last.wheel_speed_left_m_s, last.wheel_speed_right_m_s))
    ]
    assert [cmd.wheel_speed_left_m_s, cmd.wheel_speed_right_m_s] == expected
    assert ctrl.update(11 * T, pose(10), wheel(10)).status == "solved"


def test_nmpc_converges_from_lateral_offset(vehicle: VehicleParams, figure8: Reference) -> None:
    ctrl = NonlinearMpcController(vehicle)
    t, err, _, statuses = closed_loop(ctrl, figure8, vehicle, start=(0.0, 0.1, 0.0), duration_s=4.0)
    assert np.max(err[t >= 3.0]) < 0.02
    assert ctrl.failures == 0


def test_nmpc_forced_failure_falls_back(vehicle: VehicleParams, line: Reference) -> None:
    ctrl = NonlinearMpcController(vehicle, MpcConfig(max_iterations=1))
    _, _, _, statuses = closed_loop(ctrl, line, vehicle, start=(0.0, 0.1, 0.0), duration_s=0.4)
    assert ctrl.failures == 10 and set(statuses) == {"fallback_feedforward"}


def test_config_from_controller_table() -> None:
    from agvctl.scenario.spec import ControllerSpec

    def from_table(table: dict[str, object]) -> ControllerSpec:
        return ControllerSpec.from_file(table, source="exp.toml", prefix="controller")

    table = {"pose": "mpc", "compute_delay": "none", "horizon": 15, "weight_position": 2000.0,
             "prediction_model": "kinematic"}  # fmt: skip
    config = from_table(table).pose_settings
    assert isinstance(config, MpcConfig)
    assert (config.horizon, config.weight_position, config.prediction_model) == (15, 2000.0, "kinematic")
    message = r"^exp.toml: controller.horizn: unknown key \(did you mean controller.horizon\?\)$"
    with pytest.raises(ConfigError, match=message):
        from_table({"horizn": 10})
    with pytest.raises(ConfigError, match=r"controller.horizon: must be >= 1"):
        from_table({"horizon": 0})
    with pytest.raises(ConfigError, match=r"controller.prediction_model: must be one of"):
        from_table({"prediction_model": "dynamic"})
    with pytest.raises(ConfigError, match=r"^exp.toml: controller.pose: must be one of 'mpc', 'nmpc', 'ramsete'"):
        from_table({"pose": "lqr"})
