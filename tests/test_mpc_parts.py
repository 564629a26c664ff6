"""The MPC's parts, each against its contract: the reference governor, the reachable-setpoint window, the rules of
motion and the command shaper, the end-of-path supervisor with its docking planner, and the QP's layout."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp

from agvctl.controllers.mpc.config import MpcConfig, resolved_config
from agvctl.controllers.mpc.docking import Docking, DockingConfig, EndOfPath
from agvctl.controllers.mpc.governor import ReferenceGovernor
from agvctl.controllers.mpc.horizon import HorizonReference, heading_direction, turning_in_place
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.ltv_qp import window_versions
from agvctl.controllers.mpc.prediction import PREDICTION_MODELS
from agvctl.controllers.mpc.qp_blocks import BlockQp, Pattern, QpBlock, VariableBlock, VariableLayout
from agvctl.controllers.mpc.shaping import (
    CommandShaper,
    HorizonStep,
    NoBackingAtStart,
    ReachWindow,
    SetpointWindow,
    TowardTurningPoint,
)
from agvctl.feasibility import WheelReach
from agvctl.params import VehicleParams
from agvctl.planning import PathLimits, PathSpec, plan
from agvctl.planning.reference import Reference
from agvctl.planning.spec import LineSegment, TurnSegment

CONFIG = resolved_config(MpcConfig())


@pytest.fixture(scope="module")
def straight(vehicle: VehicleParams) -> Reference:
    """A 2 m line from the origin along x."""
    return plan(PathSpec(segments=(LineSegment(length_m=2.0),), name="straight"), vehicle)


@pytest.fixture(scope="module")
def turn(vehicle: VehicleParams) -> Reference:
    """A quarter turn in place at the origin."""
    return plan(PathSpec(segments=(TurnSegment(angle_deg=90.0),), name="turn"), vehicle)


def grid_of(reference: Reference, vehicle: VehicleParams) -> HorizonReference:
    T = vehicle.control.sample_period_s
    return HorizonReference(reference, CONFIG, T, PREDICTION_MODELS[CONFIG.prediction_model](CONFIG, T))


def on_reference(grid: HorizonReference, k: int) -> np.ndarray:
    return np.array([grid.x_m[k], grid.y_m[k], grid.theta_rad[k]])


# -- the reference governor ------------------------------------------------------------------------------------


def test_governed_clock_is_the_loops_clock_while_the_vehicle_keeps_up(
    straight: Reference, vehicle: VehicleParams
) -> None:
    T = vehicle.control.sample_period_s
    grid = grid_of(straight, vehicle)
    governor = ReferenceGovernor(CONFIG, vehicle.wheels.separation_m)
    for n in range(40):
        k = governor.advance(grid, n * T, on_reference(grid, n + 1))  # the vehicle a sample ahead: no lag
        assert k == n and governor.fraction == 0.0


def test_governed_clock_waits_for_a_vehicle_beyond_the_stop_lag(straight: Reference, vehicle: VehicleParams) -> None:
    T = vehicle.control.sample_period_s
    grid = grid_of(straight, vehicle)
    governor = ReferenceGovernor(CONFIG, vehicle.wheels.separation_m)
    start = np.zeros(3)  # the vehicle never leaves the start
    clocks = [governor.advance(grid, n * T, start) + governor.fraction for n in range(100)]
    assert clocks[-1] - clocks[-2] < 1e-6 and clocks[-1] < 50  # held, far behind t/T_s = 99
    lag_at_hold = governor.lag_m(grid, clocks[-1] + 1.0, start)
    assert lag_at_hold == pytest.approx(CONFIG.governor_lag_stop_m, abs=1e-3)  # where the lag reaches the stop


def test_governed_clock_catches_up_but_never_runs_ahead(straight: Reference, vehicle: VehicleParams) -> None:
    T = vehicle.control.sample_period_s
    grid = grid_of(straight, vehicle)
    governor = ReferenceGovernor(CONFIG, vehicle.wheels.separation_m)
    for n in range(30):  # held at the start
        governor.advance(grid, n * T, np.zeros(3))
    behind = governor.clock
    steps = []
    for n in range(30, 200):  # the vehicle teleported onto the reference point ahead of the clock: no lag
        before = governor.clock
        governor.advance(grid, n * T, on_reference(grid, min(int(before) + 2, grid.n_points - 1)))
        steps.append(governor.clock - before)
        assert governor.clock <= grid.window_start(n * T)
    assert behind < 30 and max(steps) == pytest.approx(CONFIG.governor_catch_up)
    assert governor.clock == grid.window_start(199 * T)  # caught up


def test_governor_off_is_the_loops_clock(straight: Reference, vehicle: VehicleParams) -> None:
    T = vehicle.control.sample_period_s
    grid = grid_of(straight, vehicle)
    governor = ReferenceGovernor(resolved_config(MpcConfig(reference_governor=False)), vehicle.wheels.separation_m)
    assert [governor.advance(grid, n * T, np.zeros(3)) for n in range(50)] == list(range(50))


def test_lag_in_a_turn_in_place_is_the_heading_lag_as_wheel_arc(turn: Reference, vehicle: VehicleParams) -> None:
    grid = grid_of(turn, vehicle)
    governor = ReferenceGovernor(CONFIG, vehicle.wheels.separation_m)
    k = int(np.argmax(np.abs(grid.yaw_rate_rad_s)))
    assert turning_in_place(float(grid.yaw_rate_rad_s[k]), float(grid.speed_m_s[k]), vehicle.wheels.separation_m)
    lagging = on_reference(grid, k) - np.array([0.0, 0.0, 0.1])  # 0.1 rad behind a turn to the left
    assert governor.lag_m(grid, float(k), lagging) == pytest.approx(0.1 * vehicle.wheels.separation_m / 2)
    off_point = on_reference(grid, k) + np.array([0.05, 0.0, 0.0])
    assert governor.lag_m(grid, float(k), off_point) == pytest.approx(0.05)


# -- the reachable-setpoint window and the command shaper -------------------------------------------------------


def reach_window(vehicle: VehicleParams) -> ReachWindow:
    T = vehicle.control.sample_period_s
    return ReachWindow(WheelReach(vehicle), PREDICTION_MODELS[CONFIG.prediction_model](CONFIG, T).lead_factor_s, 0.6)


def test_reach_window_holds_the_measured_speed_and_leads_by_what_the_wheel_can_reach(vehicle: VehicleParams) -> None:
    window = reach_window(vehicle)
    speeds = np.array([0.2, -0.1])
    w = window(speeds)
    assert w is not None
    assert np.all(w.lower_m_s < speeds) and np.all(speeds < w.upper_m_s)
    np.testing.assert_allclose(w.upper_m_s - speeds, w.lead_up_m_s)
    np.testing.assert_allclose(speeds - w.lower_m_s, w.lead_down_m_s)
    up_l, up_r, down_l, down_r = WheelReach(vehicle).accel_pair_m_s2(0.2, -0.1)
    factor = PREDICTION_MODELS[CONFIG.prediction_model](CONFIG, vehicle.control.sample_period_s).lead_factor_s
    np.testing.assert_allclose(w.lead_up_m_s, [up_l * factor, up_r * factor])
    np.testing.assert_allclose(w.lead_down_m_s, [down_l * factor, down_r * factor])


def test_reach_window_meets_the_speed_box_from_beyond_it_and_refuses_a_broken_measurement(
    vehicle: VehicleParams,
) -> None:
    window = reach_window(vehicle)
    w = window(np.array([3.0, -3.0]))  # far beyond the 0.6 m/s box
    assert w is not None and w.lower_m_s[0] <= 0.6 and w.upper_m_s[1] >= -0.6
    assert window(np.array([math.nan, 0.0])) is None
    assert window(np.array([0.0, math.inf])) is None


def step_on(grid: HorizonReference, k: int, pose: np.ndarray, window: SetpointWindow | None = None) -> HorizonStep:
    return HorizonStep(grid, k, 0.0, pose, np.zeros(2), window, np.zeros(2), on_main_path=True)


def test_no_backing_at_start_drops_a_backward_mean_and_only_at_the_start(
    straight: Reference, vehicle: VehicleParams
) -> None:
    grid = grid_of(straight, vehicle)
    rule = NoBackingAtStart(CONFIG.horizon)
    rule.reset(grid)
    left, right = rule(step_on(grid, 0, np.zeros(3)), -0.2, 0.1)  # backing while turning left
    assert right - left == pytest.approx(0.3)  # the turn kept
    assert 0.5 * (left + right) == pytest.approx(0.0)  # the backward mean dropped
    assert rule(step_on(grid, 0, np.zeros(3)), 0.3, 0.4) == (0.3, 0.4)  # forward already: untouched
    far = int(np.argmax(grid.travel_m > 0.5))
    assert rule(step_on(grid, far, on_reference(grid, far)), -0.2, 0.1) == (-0.2, 0.1)  # past the start
    docking = HorizonStep(grid, 0, 0.0, np.zeros(3), np.zeros(2), None, np.zeros(2), on_main_path=False)
    assert rule(docking, -0.2, 0.1) == (-0.2, 0.1)  # a docking manoeuvre may back up


def test_toward_turning_point_drops_only_a_mean_speed_away_from_it(turn: Reference, vehicle: VehicleParams) -> None:
    grid = grid_of(turn, vehicle)
    rule = TowardTurningPoint(vehicle.wheels.separation_m)
    k = int(np.argmax(np.abs(grid.yaw_rate_rad_s)))
    point = on_reference(grid, k)
    heading = np.array([math.cos(point[2]), math.sin(point[2]), 0.0])
    beyond = point + 0.05 * heading  # past the point along the heading: forward carries it further away
    assert rule(step_on(grid, k, beyond), -0.1, 0.3) == pytest.approx((-0.2, 0.2))
    assert rule(step_on(grid, k, beyond), -0.3, 0.1) == (-0.3, 0.1)  # backward brings it back: kept
    short = point - 0.05 * heading
    assert rule(step_on(grid, k, short), -0.1, 0.3) == (-0.1, 0.3)


def test_command_shaper_applies_window_and_rate_limit_and_remembers_the_command(
    straight: Reference, vehicle: VehicleParams
) -> None:
    grid = grid_of(straight, vehicle)
    shaper = CommandShaper((), max_wheel_speed_m_s=0.6, max_step_m_s=0.02)
    shaper.reset(grid)
    window = SetpointWindow(np.array([-0.05, -0.05]), np.array([0.05, 0.01]), np.full(2, 0.05), np.full(2, 0.05))
    previous = shaper.previous(np.zeros(2), window)
    step = HorizonStep(grid, 0, 0.0, np.zeros(3), np.zeros(2), window, previous, on_main_path=True)
    left, right = shaper(step, 0.5, 0.5)
    assert left == pytest.approx(0.02)  # the rate limit binds first
    assert right == pytest.approx(0.01)  # the window binds first
    np.testing.assert_allclose(shaper.previous(np.zeros(2), window), [0.02, 0.01])
    far_window = SetpointWindow(np.array([0.3, 0.3]), np.array([0.4, 0.4]), np.full(2, 0.05), np.full(2, 0.05))
    np.testing.assert_allclose(shaper.previous(np.full(2, 0.35), far_window), [0.28, 0.28])  # pulled to reach


# -- the end of the path and docking ---------------------------------------------------------------------------


def test_end_of_path_is_done_on_the_end_and_docks_from_beside_it(straight: Reference, vehicle: VehicleParams) -> None:
    T = vehicle.control.sample_period_s
    end = EndOfPath(Docking(vehicle, DockingConfig()), T)
    end.reset(straight)
    final = straight.final_pose
    on_end = np.array([final.x_m, final.y_m, final.theta_rad])
    assert end.after_step(1.0, 1.0, on_end, np.zeros(2)) is None and not end.done  # the path goes on
    assert end.after_step(9.0, straight.duration_s, on_end, np.zeros(2)) is None and end.done
    end.reset(straight)
    beside = on_end + np.array([0.0, 0.02, 0.0])  # 2 cm to the left of the end, at rest
    assert end.after_step(9.0, straight.duration_s, beside, np.array([0.05, 0.05])) is None  # moving: wait
    manoeuvre = end.after_step(9.0, straight.duration_s, beside, np.zeros(2))
    assert manoeuvre is not None and not end.done and not end.on_path
    assert end.time_offset_s == pytest.approx(9.0 + T)
    last = manoeuvre.final_pose
    assert math.hypot(last.x_m - final.x_m, last.y_m - final.y_m) < 1e-9  # it ends at the path's end
    lengths = manoeuvre.sample([manoeuvre.duration_s]).path_length_m
    assert 0.3 <= lengths[0] <= 1.0  # back 20·e ≥ 0.15 m and in again


def test_docking_is_off_when_disabled_and_stops_after_its_attempts(straight: Reference, vehicle: VehicleParams) -> None:
    final = straight.final_pose
    beside = np.array([final.x_m, final.y_m + 0.02, final.theta_rad])
    off = EndOfPath(Docking(vehicle, DockingConfig(enabled=False)), 0.04)
    off.reset(straight)
    assert off.after_step(9.0, straight.duration_s, beside, np.zeros(2)) is None and off.done
    docking = Docking(vehicle, DockingConfig(attempts=1))
    docking.reset(straight)
    assert docking.plan(beside) is not None
    assert docking.plan(beside) is None and not docking.needed(beside)


def test_docking_counts_the_estimates_uncertainty_across_the_path_against_its_tolerance(
    straight: Reference, vehicle: VehicleParams
) -> None:
    """5 mm beside the end of a line (tolerance 8 mm): known exactly, the vehicle stays; estimated with σ = 2 mm
    across the path it may be 9 mm off (5 + 2σ) and docks; the same σ along the path changes nothing."""
    final = straight.final_pose
    beside = np.array([final.x_m, final.y_m + 0.005, final.theta_rad])
    docking = Docking(vehicle, DockingConfig())
    docking.reset(straight)
    assert not docking.needed(beside)
    docking.observe(np.diag([0.002**2, 1e-12, 0.0]))  # σ along the line (x) only
    assert not docking.needed(beside)
    docking.observe(np.diag([1e-12, 0.002**2, 0.0]))  # σ across it (y)
    assert docking.needed(beside)
    docking.reset(straight)  # a new run starts from a known pose
    assert not docking.needed(beside)


def test_docking_backs_up_no_further_than_a_curved_end_allows(vehicle: VehicleParams) -> None:
    from agvctl.planning.spec import ArcSegment

    arc = plan(
        PathSpec(
            segments=(LineSegment(length_m=0.5), ArcSegment(radius_m=0.5, angle_deg=90.0)),
            name="bend",
            limits=PathLimits(wheel_speed_m_s=0.3, wheel_accel_m_s2=0.5),
        ),
        vehicle,
    )
    config = DockingConfig(max_deviation_m=0.01)
    docking = Docking(vehicle, config)
    docking.reset(arc)
    final = arc.final_pose
    normal = np.array([-math.sin(final.theta_rad), math.cos(final.theta_rad), 0.0])
    manoeuvre = docking.plan(np.array([final.x_m, final.y_m, final.theta_rad]) + 0.02 * normal)
    assert manoeuvre is not None
    back_m = 0.5 * float(manoeuvre.sample([manoeuvre.duration_s]).path_length_m[0])
    assert back_m <= math.sqrt(2.0 * config.max_deviation_m * 2.0) + 1e-9  # L ≤ √(2δ/|κ|), κ = 2 1/m


def test_docking_undoes_the_final_turns_in_place_the_short_way_round(vehicle: VehicleParams) -> None:
    turns = plan(
        PathSpec(
            segments=(LineSegment(length_m=1.0), TurnSegment(angle_deg=-200.0), TurnSegment(angle_deg=-200.0)),
            name="line then 400 degrees in place",
        ),
        vehicle,
    )
    docking = Docking(vehicle, DockingConfig())
    docking.reset(turns)
    final = turns.final_pose
    along = np.array([final.x_m + 0.02, final.y_m, final.theta_rad])  # 2 cm beyond the end of the drive
    manoeuvre = docking.plan(along)
    assert manoeuvre is not None
    theta = manoeuvre.sample(np.linspace(0.0, manoeuvre.duration_s, 400)).theta_rad
    assert np.max(np.abs(theta - final.theta_rad)) <= math.radians(40.0) + 1e-6  # -400° leaves -40°: undo +40°
    assert manoeuvre.final_pose.theta_rad == pytest.approx(final.theta_rad, abs=1e-9)
    full = plan(PathSpec(segments=(LineSegment(length_m=1.0), TurnSegment(angle_deg=360.0)), name="full"), vehicle)
    docking.reset(full)
    end = full.final_pose
    assert not docking.needed(np.array([end.x_m + 0.02, end.y_m, end.theta_rad]))  # facing along the drive again


# -- the QP ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("reversal", [0.0, 0.01])
@pytest.mark.parametrize("model", ["kinematic", "kinematic+wheel_loop"])
def test_qp_rows_follow_the_blocks_and_the_matrices_fit_them(
    vehicle: VehicleParams, model: str, reversal: float
) -> None:
    N = 6
    ctrl = LtvMpcController(vehicle, MpcConfig(horizon=N, prediction_model=model, weight_reversal=reversal))
    qp, nx = ctrl._qp, ctrl.nx
    wheel_loop, M = model == "kinematic+wheel_loop", 5 if reversal else 0
    assert nx == (5 if wheel_loop else 3)
    assert qp.layout.n_variables == N * nx + 2 * N + 2 * M
    expected = {"dynamics": N * nx, "speed box": 2 * N, "rate": 2 * (N - 1), "first move": 2}
    expected |= {"reach": 2 * (N - 1)} if wheel_loop else {}
    expected |= {"reversal": 6 * M} if M else {}
    expected |= {"state cost": 0, "input cost": 0}
    assert {name: rows.stop - rows.start for name, rows in qp.rows.items()} == expected  # in this order, contiguous
    assert list(qp.rows) == list(expected) and qp.n_rows == sum(expected.values())
    A, P = qp.A, qp.P
    assert A.shape == (qp.n_rows, qp.layout.n_variables)
    pos_A, pos_B = qp.a_slots["dynamics"]["A"], qp.a_slots["dynamics"]["B"]
    assert pos_A.size == (N - 1) * nx * nx and pos_B.size == N * nx * 2
    assert np.all(A.data[pos_B] == 1.0) and np.all(A.data[pos_A] == 0.0)  # placeholders of −B_k and −A_k
    assert len(set(pos_A) | set(pos_B)) == pos_A.size + pos_B.size
    assert P.shape == (qp.layout.n_variables,) * 2
    assert sp.tril(P, k=-1).nnz == 0  # upper triangle, as OSQP takes it
    full = (P + sp.triu(P, k=1).T).toarray()
    assert np.all(np.linalg.eigvalsh(full) > -1e-12)  # convex
    if M:  # each slack r_i of the first M samples: r_i + δs_i, r_i − δs_i and r_i alone
        i_slacks, i_setpoints = qp.layout.start("reversal slacks"), qp.layout.start("setpoints")
        rows = A.toarray()[qp.rows["reversal"]]
        slacks, setpoints = rows[:, i_slacks:], rows[:, i_setpoints:i_slacks]
        eye, first = np.eye(2 * M), np.eye(2 * M, 2 * N)
        assert np.array_equal(slacks, np.vstack([eye, eye, eye]))
        assert np.array_equal(setpoints, np.vstack([first, -first, 0 * first]))
        assert not rows[:, :i_setpoints].any()
        assert not full[i_slacks:].any()  # their cost is linear
        assert np.all(qp.q[i_slacks:] == reversal)


class _Diagonal(QpBlock[None, float]):
    """One entry of A on each variable, its slot written each step with the step's value."""

    name = "diagonal"

    def __init__(self, n: int) -> None:
        self.n_rows = n

    def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
        for i in range(self.n_rows):
            pattern.add(i, layout.start("z") + self.n_rows - 1 - i, 1.0, "anti-diagonal")

    def bind(self, qp: BlockQp[None, float], rows: slice) -> None:
        self._data, self._positions = qp.a_data, qp.a_slots[self.name]["anti-diagonal"]

    def write_matrices(self, step: float) -> tuple[bool, bool]:
        self._data[self._positions] = step * np.arange(1, self.n_rows + 1)
        return True, False


def test_the_builder_puts_each_slot_value_at_its_entry() -> None:
    """A block's slot values, written in the order it added the entries, land at those entries whatever order the
    CSC data array keeps them in (here the reverse: column order runs against the block's row order)."""
    qp: BlockQp[None, float] = BlockQp([VariableBlock("z", 4)], [_Diagonal(4)])
    update = qp.matrix_update(0.5)
    assert set(update) == {"Ax", "Ax_idx"}
    A = qp.A.copy()
    A.data[update["Ax_idx"]] = update["Ax"]
    assert np.array_equal(A.toarray(), np.fliplr(np.diag([0.5, 1.0, 1.5, 2.0])))


def test_the_builder_refuses_entries_outside_a_blocks_rows_and_twice_the_same_entry() -> None:
    class Outside(_Diagonal):
        def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
            pattern.add(self.n_rows, 0, 1.0)

    class Twice(_Diagonal):
        def constraints(self, layout: VariableLayout, pattern: Pattern) -> None:
            pattern.add(0, 0, 1.0)
            pattern.add(0, 0, 2.0)

    with pytest.raises(ValueError, match="outside its 2 rows"):
        BlockQp([VariableBlock("z", 2)], [Outside(2)])
    with pytest.raises(ValueError, match="same entry"):
        BlockQp([VariableBlock("z", 2)], [Twice(2)])


def test_heading_direction_is_the_setpoints_sign_and_at_rest_that_of_the_next_motion() -> None:
    feedforward = np.array([[0.0, 0.0], [0.1, -0.1], [0.2, 0.0], [0.0, 0.0], [-0.1, 0.1], [0.0, 0.0]])
    expected = np.array([[1, -1], [1, -1], [1, 1], [-1, 1], [-1, 1], [0, 0]], dtype=float)
    assert np.array_equal(heading_direction(feedforward), expected)


def test_window_versions_change_exactly_where_a_windows_data_does() -> None:
    """Random piecewise-constant data by interval and by point: two consecutive windows get the same version exactly
    when every entry they take is equal, whatever the offsets."""
    rng = np.random.default_rng(7)
    n, N = 60, 5
    by_interval = np.repeat(rng.normal(size=(12, 2, 2)), 5, axis=0)[:n]  # constant over runs of 5
    by_point = np.repeat(rng.normal(size=(20, 2)), 3, axis=0)[: n + 1]
    sources = [(by_interval, 1, N - 1), (by_point, 1, N)]
    windows = n - N - 1
    versions = window_versions(sources, windows)
    for k in range(1, windows):
        same = np.array_equal(by_interval[k + 1 : k + N], by_interval[k : k + N - 1]) and np.array_equal(
            by_point[k + 1 : k + N + 1], by_point[k : k + N]
        )
        assert (versions[k] == versions[k - 1]) == same, k
    assert versions[0] == 0 and np.all(np.diff(versions) >= 0)


def test_docking_accelerates_no_harder_than_the_path_it_completes(vehicle: VehicleParams) -> None:
    """A path planned at 0.2 m/s² for its load is docked at 0.2, not at the manoeuvre's own 0.3."""
    gentle = plan(
        PathSpec(segments=(LineSegment(length_m=1.0),), name="gentle", limits=PathLimits(wheel_accel_m_s2=0.2)),
        vehicle,
    )
    docking = Docking(vehicle, DockingConfig())
    for reference, accel in ((gentle, 0.2), (plan(PathSpec(segments=(LineSegment(length_m=1.0),)), vehicle), 0.3)):
        docking.reset(reference)
        final = reference.final_pose
        manoeuvre = docking.plan(np.array([final.x_m, final.y_m + 0.02, final.theta_rad]))
        assert manoeuvre is not None
        assert manoeuvre.limits.wheel_accel_m_s2 == pytest.approx(accel)
