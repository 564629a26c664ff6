"""The full model and its simulator against physics, the report's figures and a tight reference integration."""

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from agvctl.actuator import Actuator
from agvctl.params import load_vehicle
from agvctl.plant.full import AUX_NAMES, FullModel, PlantOptions, parameter_vector, state_from_motor_speeds
from agvctl.sim import simulate_batch, simulate_open_loop
from agvctl.sim.stepper import PlantStepper

TS = 0.04
K_T, K_E, R, N, r = 0.027, 0.027, 0.38, 36.0, 0.10  # appendix A (k_t = k_e in SI units, ERRATA)
TAU_C = TAU_S = 0.065


def held(*segments):
    """Piecewise-constant DA commands: segments of (duration_s, left_v, right_v)."""
    rows = []
    for duration, left, right in segments:
        rows += [(left, right)] * int(round(duration / TS))
    return np.array(rows, dtype=float)


def profile_10s():
    """10 s: standstill below break-away, break-away, reversal, spin in place, arcs, saturation."""
    return held(
        (1.0, 0.40, 0.40),  # below break-away (0.457 V at the DA)
        (1.0, 0.50, 0.50),  # just above it
        (1.0, 3.0, 3.0),
        (1.0, -3.0, -3.0),  # reversal
        (1.5, 3.5, -3.5),  # spin in place
        (1.5, 4.0, 2.0),  # arc
        (1.0, 5.0, 5.0),  # full scale: current limit, DA clip at +5 V
        (1.0, -2.0, 1.0),  # reversal into an arc
        (1.0, 0.0, 0.0),  # coast to rest
    )


def reference_solution(vehicle, da):
    """scipy's DOP853 at rtol 1e-10, restarted at every sample so no step straddles an input jump."""
    model = FullModel()
    f = ca.Function("f", [model.x, model.u, model.p], [model.xdot])
    p = parameter_vector(vehicle)
    u = Actuator(vehicle).apply(da).motor_voltage_v
    x = np.zeros(5)
    states = [x]
    for k in range(len(u)):
        sol = solve_ivp(
            lambda t, xx, uk=u[k]: np.asarray(f(xx, uk, p)).ravel(), (0, TS), x, method="DOP853", rtol=1e-10, atol=1e-12
        )
        assert sol.success
        x = sol.y[:, -1]
        states.append(x)
    X = np.array(states)
    aux = ca.Function("a", [model.x, model.u, model.p], [model.aux])
    omega = np.array([np.asarray(aux(xk, u[0], p)).ravel()[:2] for xk in X])  # ω_mot depends on x only
    return X, omega


@pytest.mark.slow
def test_simulator_matches_tight_reference(vehicle):
    da = profile_10s()
    log = simulate_open_loop(vehicle, da).log
    X_ref, omega_ref = reference_solution(vehicle, da)
    top_motor_speed = vehicle.derived.left.max_motor_speed_rad_s
    speed_err = np.abs(np.column_stack([log["omega_motor_left_rad_s"], log["omega_motor_right_rad_s"]]) - omega_ref)
    pose_err = np.hypot(log["x_m"] - X_ref[:, 2], log["y_m"] - X_ref[:, 3])
    assert speed_err.max() <= 1e-3 * top_motor_speed
    assert pose_err.max() <= 1e-3
    # the profile did what it says: it spun, it moved, it reversed
    assert np.ptp(log["theta_rad"]) > 1.0 and np.ptp(log["x_m"]) > 0.3
    assert log["omega_motor_left_rad_s"].min() < -50 < 50 < log["omega_motor_left_rad_s"].max()


def test_no_motion_below_breakaway(vehicle):
    # break-away: k_t i = τ_s with i = k_pow v_DA / R  →  v_DA = τ_s R / (k_pow k_t) = 0.457 V
    v_break = TAU_S * R / (2.0 * K_T)
    below = simulate_open_loop(vehicle, held((3.0, 0.97 * v_break, -0.97 * v_break))).log
    assert np.all(below["omega_motor_left_rad_s"] == 0) and np.all(below["omega_motor_right_rad_s"] == 0)
    assert np.all(below["x_m"] == 0) and np.all(below["theta_rad"] == 0)
    above = simulate_open_loop(vehicle, held((3.0, 1.05 * v_break, 1.05 * v_break))).log
    assert above["x_m"][-1] > 1e-3


@pytest.mark.parametrize("v_da", [1.0, 2.5, -4.0])
def test_steady_state_speed_matches_eq_33(vehicle, v_da):
    # steady straight line, eq 33 with ω̇ = 0 and no centrifugal load: k_t/R (u − k_e ω) = f_m ω + τ_c sign(ω)
    log = simulate_open_loop(vehicle, held((4.0, v_da, v_da))).log
    code = round(v_da / (10 / 4096))
    u = 2.0 * code * 10 / 4096
    omega = np.sign(u) * (K_T * abs(u) / R - TAU_C) / (K_E * K_T / R)
    assert log["omega_motor_left_rad_s"][-1] == pytest.approx(omega, rel=1e-6)
    assert log["speed_m_s"][-1] == pytest.approx(omega * r / N, rel=1e-6)
    assert abs(log["yaw_rate_rad_s"][-1]) < 1e-9


def test_straight_acceleration_is_bounded_by_current_limit(vehicle):
    log = simulate_open_loop(vehicle, held((1.0, 5.0, 5.0))).log
    a_lim = vehicle.derived.accel_limit_m_s2
    assert a_lim == pytest.approx(0.657, rel=5e-3)
    assert log["current_left_a"][0] == pytest.approx(5.5)  # the amplifier current-limits at start
    # once it has broken away, with the current at its limit, the vehicle accelerates at a_lim (eq 5)...
    assert log["current_left_a"][1] == pytest.approx(5.5)
    assert log["wheel_accel_left_m_s2"][1] == pytest.approx(a_lim, rel=1e-6)
    # ...never faster, also measured by finite differences of the speed
    assert log["wheel_accel_peak_left_m_s2"].max() <= a_lim * (1 + 1e-9)
    assert np.max(np.diff(log["speed_m_s"]) / TS) <= a_lim * (1 + 1e-6)
    # and the current limit binds: full voltage at rest would drive (2 · 4.998 V)/0.38 Ω = 26 A
    assert log["current_limited_left"][0] == 1.0


def test_mirrored_inputs_give_mirrored_path(vehicle):
    da = held((2.0, 3.0, 1.0), (2.0, -1.0, 4.0), (1.0, 2.0, 2.0))
    a = simulate_open_loop(vehicle, da).log
    b = simulate_open_loop(vehicle, da[:, ::-1]).log
    np.testing.assert_allclose(b["x_m"], a["x_m"], atol=1e-12)
    np.testing.assert_allclose(b["y_m"], -a["y_m"], atol=1e-12)
    np.testing.assert_allclose(b["theta_rad"], -a["theta_rad"], atol=1e-12)
    np.testing.assert_allclose(b["omega_motor_left_rad_s"], a["omega_motor_right_rad_s"], atol=1e-9)


def test_zero_input_from_motion_comes_to_rest(vehicle):
    x0 = state_from_motor_speeds(vehicle, (200.0, 150.0))
    log = simulate_open_loop(vehicle, held((6.0, 0.0, 0.0)), initial_state=x0).log
    assert log["omega_motor_left_rad_s"][0] == pytest.approx(200.0)
    assert log["omega_motor_left_rad_s"][-1] == 0 and log["omega_motor_right_rad_s"][-1] == 0
    # stopped for good: stiction holds it (the last second has no motion at all)
    assert np.all(log["speed_m_s"][-25:] == 0)


def test_current_limit_acts_continuously(vehicle):
    log = simulate_open_loop(vehicle, held((0.5, 5.0, -5.0), (0.5, -5.0, 5.0))).log
    assert log["current_peak_left_a"].max() <= 5.5 + 1e-12
    assert np.all(np.abs(log["current_left_a"]) <= 5.5 + 1e-12)


def test_spin_in_place_drifts_back_under_centrifugal_load(vehicle):
    # Opposite voltages spin the vehicle, but the centre of mass h behind the axle needs a centripetal force
    # M h ω² toward the point of rotation (eq 10). The motors supply it only by running slower than the voltage
    # asks, by Δ = M h ω² r / (2 N D) each, D = k_e k_t / R: the vehicle drifts backwards at U = −Δ r/N.
    log = simulate_open_loop(vehicle, held((4.0, 3.0, -3.0))).log
    omega = log["yaw_rate_rad_s"][-1]
    assert omega < -0.5
    delta = 85.0 * 0.12 * omega**2 * r / (2 * N * K_E * K_T / R)
    assert log["speed_m_s"][-1] == pytest.approx(-delta * r / N, rel=1e-3)
    # without the centrifugal terms the spin is pure
    no_cf = simulate_open_loop(vehicle, held((4.0, 3.0, -3.0)), options=PlantOptions(centrifugal=False)).log
    assert abs(no_cf["speed_m_s"][-1]) < 1e-9


def test_batch_equals_single_runs():
    base = load_vehicle()
    variants = [base, base.with_overrides(["wheels.right.radius_m=0.101"]), base.with_overrides(["body.mass_kg=120"])]
    da = held((2.0, 3.0, 2.0), (1.0, -1.0, 1.0))
    logs = simulate_batch(variants, da)
    for v, log in zip(variants, logs, strict=True):
        single = simulate_open_loop(v, da).log
        for name in ("x_m", "y_m", "theta_rad", "omega_motor_left_rad_s", "current_right_a"):
            np.testing.assert_allclose(log[name], single[name], rtol=0, atol=1e-12)
    assert not np.allclose(logs[0]["y_m"], logs[1]["y_m"])  # the variants differ


def test_unequal_radii_curve_toward_smaller_wheel(vehicle):
    v = vehicle.with_overrides(["wheels.right.radius_m=0.105"])
    log = simulate_open_loop(v, held((4.0, 3.0, 3.0))).log
    assert log["theta_rad"][-1] > 0.01  # a bigger right wheel turns the vehicle left (eq 40)


def test_aux_names_cover_log():
    assert "current_left_a" in AUX_NAMES and "wheel_accel_right_m_s2" in AUX_NAMES


def test_plant_options_remove_effects(vehicle):
    # without friction the motor starts at any voltage
    model = FullModel(PlantOptions(friction=False))
    xdot, _aux = model.rhs(np.zeros(5), [0.1, 0.1], parameter_vector(vehicle))
    assert float(xdot[0]) > 0


def test_stepping_sample_by_sample_records_what_the_compiled_chunks_record(vehicle):
    # PlantStepper.step records one row at a time in plain numbers, PlantStepper.run whole chunks in arrays: the
    # same commands (sticking, break-away, reversals, saturation) give the same log, bit for bit
    commands = np.concatenate(
        [held((0.8, 2.0, 1.0)), np.random.default_rng(0).uniform(-7.0, 7.0, (40, 2)), held((1.0, 0.0, 0.0))]
    )
    stepped, chunked = (PlantStepper(vehicle, initial_state=[0.0, 0.0, 0.1, 0.2, 0.3]) for _ in range(2))
    for command in commands:
        stepped.step(command)
    stepped.finish()
    chunked.run(commands)
    chunked.finish()
    a, b = stepped.log(), chunked.log()
    assert list(a) == list(b) and len(a) == len(commands) + 1
    for name in a:
        assert a[name].tobytes() == b[name].tobytes(), name
