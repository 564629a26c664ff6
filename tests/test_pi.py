"""The PI wheel-speed loops: C(z) form, anti-windup, current prediction, friction feed-forward, steady state.

Expected values come from the report's physics (eq 1 with the Coulomb friction of eqs 2-4 in steady state) and
from scipy's own filtering of C(z), not from the controller's output.
"""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import lfilter

from agvctl.actuator import Actuator
from agvctl.controllers.pi.options import PIGains, WheelLoopOptions
from agvctl.controllers.pi.wheel_loop import PISpeedLoop, PIWheelController
from agvctl.params import load_vehicle
from agvctl.sim.wheel_step import step_metrics, wheel_step_response

# report, appendix A (and ERRATA for k_t)
K_E, K_T, R, TAU_C, I_MAX, K_POW = 0.027, 0.027, 0.38, 0.065, 5.5, 2.0
T_S = 0.04
OMEGA_STEP = 0.3 * 36.0 / 0.10  # 0.3 m/s wheel speed, N = 36, r = 0.1 m
GAINS = PIGains(kp=0.06, ki=0.7, dt_s=T_S)  # close to the tuned gains; fixed here so these tests stand alone
PLAIN_PI = WheelLoopOptions(coulomb_feedforward=False)  # the PI law alone, no friction feed-forward


def test_num_den_is_the_documented_backward_euler_pi():
    g = PIGains(kp=0.05, ki=1.5, dt_s=0.04)
    assert g.num == pytest.approx((0.05 + 1.5 * 0.04, -0.05))
    assert g.den == (1.0, -1.0)
    # C(z) = kp + ki T z/(z-1) evaluated at a point
    z = 0.3 + 0.8j
    c = np.polyval(g.num, z) / np.polyval(g.den, z)
    assert c == pytest.approx(0.05 + 1.5 * 0.04 * z / (z - 1))


def test_unsaturated_loop_is_the_filter_num_den(vehicle):
    """Without active limits the loop's voltage sequence is C(z) applied to the error sequence."""
    loop = PISpeedLoop(
        GAINS,
        vehicle.motor.left,
        current_limit_a=1e9,
        voltage_min_v=-1e9,
        voltage_max_v=1e9,
        coulomb_feedforward=False,
        anti_windup=True,
    )
    rng = np.random.default_rng(4)
    errors = rng.normal(0.0, 5.0, 50)
    u = [loop.update(float(e), 0.0) for e in errors]
    expected = lfilter(GAINS.num, GAINS.den, errors)
    np.testing.assert_allclose(u, expected, rtol=1e-12, atol=1e-12)
    assert not loop.limited


def test_wheel_controller_outputs_da_volts(vehicle):
    ctrl = PIWheelController(vehicle, GAINS, PLAIN_PI)
    da = ctrl.update(np.array([10.0, -10.0]), np.array([9.0, -9.0]))
    # one sample: u = (kp + ki T) e, e = ±1 rad/s; the DA command is u / k_pow
    assert da.shape == (2,)
    np.testing.assert_allclose(da, np.array([1.0, -1.0]) * (0.06 + 0.7 * T_S) / K_POW)
    ctrl.reset()
    assert all(loop.integrator_v == 0.0 for loop in ctrl.loops)


@settings(derandomize=True, max_examples=300, deadline=None)
@given(
    setpoint=st.floats(-400.0, 400.0),
    measured=st.floats(-280.0, 280.0),
    integrator=st.floats(-20.0, 20.0),
    feedforward=st.booleans(),
)
def test_predicted_current_never_commands_past_the_limit(setpoint, measured, integrator, feedforward):
    """After the DA's rounding and the amplifier, (u − k_e ω)/R stays within ±I_max (eq 1), and the DA code is
    in range, for any setpoint, measured speed (up to the no-load speed at full DA) and integrator state."""
    vehicle = _VEHICLE
    ctrl = PIWheelController(vehicle, GAINS, WheelLoopOptions(coulomb_feedforward=feedforward))
    for loop in ctrl.loops:
        loop.integrator_v = integrator
    da = ctrl.update(np.array([setpoint, -setpoint]), np.array([measured, -measured]))
    out = Actuator(vehicle).apply(da)
    assert not np.any(out.da_clipped)
    current = (out.motor_voltage_v - K_E * np.array([measured, -measured])) / R
    assert np.all(np.abs(current) <= I_MAX + 1e-12)


_VEHICLE = load_vehicle()


def test_per_side_motor_constants():
    v = load_vehicle(None, ["motor.right.resistance_ohm=0.5"])
    ctrl = PIWheelController(v, GAINS)
    left, right = ctrl.loops
    lo_l, hi_l = left.usable_voltage_v(50.0)
    lo_r, hi_r = right.usable_voltage_v(50.0)
    quantum = K_POW * 10.0 / 4096
    assert hi_l - K_E * 50 == pytest.approx(0.38 * I_MAX - quantum / 2)
    assert hi_r - K_E * 50 == pytest.approx(0.5 * I_MAX - quantum / 2)


def test_coulomb_feedforward_value():
    v = _VEHICLE
    on = PIWheelController(v, GAINS).loops[0]  # on by default
    off = PIWheelController(v, GAINS, PLAIN_PI).loops[0]
    u_ff = TAU_C * R / K_T  # 0.9148 V balances the Coulomb torque at standstill (eq 1)
    assert on.feedforward_v(10.0) == pytest.approx(u_ff)
    assert on.feedforward_v(-10.0) == pytest.approx(-u_ff)
    assert on.feedforward_v(0.0) == 0.0
    assert off.feedforward_v(10.0) == 0.0


# ----------------------------------------------------------------------------------------------------
# on the full nonlinear plant through the DA converter and amplifier


def test_anti_windup_cuts_the_overshoot_of_a_saturating_step(vehicle):
    """The 0.3 m/s step drives the current limit (R I_max = 2.09 V < k_p e = 6.5 V at the start)."""
    with_aw = wheel_step_response(vehicle, GAINS, options=PLAIN_PI)
    without = wheel_step_response(
        vehicle, GAINS, options=WheelLoopOptions(coulomb_feedforward=False, anti_windup=False)
    )
    assert np.max(with_aw.current_peak_a) == pytest.approx(I_MAX, rel=1e-3)  # it really saturated
    assert without.metrics.overshoot_pct > 20.0
    assert with_aw.metrics.overshoot_pct < 2.0
    assert with_aw.metrics.overshoot_pct < without.metrics.overshoot_pct / 10


def test_closed_loop_current_prediction_holds(vehicle):
    """In the closed loop, the current at each sample start computed from the motor voltage applied and the
    measured speed never exceeds I_max (the plant's own clip never has to act at a sample start)."""
    res = wheel_step_response(vehicle, GAINS, wheel_speed_step_m_s=-0.5)
    predicted = (res.motor_voltage_v - K_E * res.omega_motor_rad_s[:-1]) / R
    assert np.max(np.abs(predicted)) <= I_MAX + 1e-12
    assert np.max(np.abs(predicted)) > 0.95 * I_MAX


def test_current_limited_acceleration_is_near_eq5(vehicle):
    """While the current limit acts the wheels accelerate at about a_lim of eq 5 (0.657 m/s²): the 10-90 %
    rise of a 0.3 m/s step cannot be faster than 0.8·0.3/a_lim and is not much slower."""
    res = wheel_step_response(vehicle, GAINS)
    bound_s = 0.8 * 0.3 / 0.657
    assert bound_s * 0.97 <= res.metrics.rise_time_s <= bound_s * 1.5


def test_integrator_removes_the_coulomb_offset(vehicle):
    """Steady state of eq 1 with Coulomb friction: k_t/R (u − k_e ω) = τ_c. A P controller u = k_p (ω_ref − ω)
    settles at ω = (k_p ω_ref − R τ_c/k_t)/(k_p + k_e); the PI's integrator removes that error."""
    kp = GAINS.kp
    p_only = wheel_step_response(vehicle, PIGains(kp=kp, ki=0.0, dt_s=T_S), options=PLAIN_PI)
    omega_p = (kp * OMEGA_STEP - R * TAU_C / K_T) / (kp + K_E)
    expected_pct = (1 - omega_p / OMEGA_STEP) * 100  # about 41 %
    assert p_only.metrics.steady_state_error_pct == pytest.approx(expected_pct, abs=0.5)
    pi = wheel_step_response(vehicle, GAINS)
    assert pi.metrics.steady_state_error_pct < 0.2
    assert pi.metrics.settling_time_s < 1.5


def test_feedforward_cancels_coulomb_friction(vehicle):
    """With the feed-forward a P controller's offset is only that of the back-EMF: ω = k_p ω_ref/(k_p + k_e);
    with the PI the integrator settles lower by exactly τ_c R/k_t."""
    kp = GAINS.kp
    p_ff = wheel_step_response(vehicle, PIGains(kp=kp, ki=0.0, dt_s=T_S))  # the feed-forward is on by default
    expected_pct = K_E / (kp + K_E) * 100
    assert p_ff.metrics.steady_state_error_pct == pytest.approx(expected_pct, abs=0.5)

    integrators = {}
    for ff in (False, True):
        ctrl = PIWheelController(vehicle, GAINS, WheelLoopOptions(coulomb_feedforward=ff))
        res = wheel_step_response(vehicle, controller=ctrl)
        assert res.metrics.steady_state_error_pct < 0.2
        integrators[ff] = ctrl.loops[0].integrator_v
    assert integrators[False] - integrators[True] == pytest.approx(TAU_C * R / K_T, abs=0.02)


def test_step_metrics_on_a_known_curve():
    """First-order response 1 − e^{−t/τ}: 10-90 % rise τ ln 9, 2 % settling τ ln 50, no overshoot."""
    tau = 0.2
    t = np.linspace(0.0, 3.0, 30001)
    m = step_metrics(t, 5.0 * (1 - np.exp(-t / tau)), 5.0)
    assert m.rise_time_s == pytest.approx(tau * math.log(9), rel=1e-4)
    assert m.settling_time_s == pytest.approx(tau * math.log(50), rel=1e-4)
    assert m.overshoot_pct == 0.0
    assert m.steady_state_error_pct < 0.01


@pytest.mark.parametrize("sign", [1.0, -1.0], ids=["accelerating", "braking"])
def test_when_both_wheels_ask_past_the_current_limit_their_difference_is_kept(vehicle, sign):
    """Both loops asking more current than I_max the same way: the wheel asking more gets I_max, the other I_max
    less the difference they asked for (eq 1's predicted currents), so the torque difference that steers the vehicle
    survives the saturation; each wheel alone past the limit is clamped as before."""
    setpoint, measured = sign * np.array([40.0, 38.0]), np.array([0.0, 0.0])

    def currents(steering_priority: bool) -> tuple[np.ndarray, np.ndarray]:
        ctrl = PIWheelController(vehicle, GAINS, WheelLoopOptions(steering_priority=steering_priority))
        loops = zip(ctrl.loops, setpoint, measured, strict=True)
        asked = np.array([loop.demand(s, m).voltage_v for loop, s, m in loops])
        volts = ctrl.motor_voltages_v(setpoint, measured)
        return (asked - K_E * measured) / R, (volts - K_E * measured) / R

    asked, kept = currents(True)
    assert np.all(sign * asked > I_MAX)  # both past the limit, the left further
    assert sign * kept[0] == pytest.approx(I_MAX, abs=0.01)
    assert kept[0] - kept[1] == pytest.approx(asked[0] - asked[1], rel=1e-9)
    _, clamped = currents(False)
    np.testing.assert_allclose(sign * clamped, [I_MAX, I_MAX], atol=0.01)


def test_a_loop_held_below_its_limit_for_the_other_wheel_does_not_wind_up(vehicle):
    """While the steering priority holds a wheel below its own current limit, its integrator stops as at its own
    limit: it never alone asks for more than the output it was given."""
    ctrl = PIWheelController(vehicle, GAINS)
    for _ in range(50):
        volts = ctrl.motor_voltages_v(np.array([40.0, 38.0]), np.array([0.0, 0.0]))
    assert ctrl.loops[1].integrator_v <= volts[1] + 1e-12


def test_a_wheel_at_rest_is_released_to_stiction_until_it_is_asked_to_move(vehicle):
    """A stopped motor draws no armature current at 0 V (eq 1 with ω = 0), and stiction holds it at any torque below
    its break-away: at rest the loop releases the wheel, whatever its speed estimate wanders, and resumes from its
    integrator when the setpoint leaves zero."""
    loop = PISpeedLoop(
        GAINS,
        vehicle.motor.left,
        current_limit_a=I_MAX,
        voltage_min_v=-10.0,
        voltage_max_v=10.0,
        standstill_rad_s=0.1,
        coulomb_feedforward=False,
        anti_windup=True,
    )
    for _ in range(20):  # driving, then braking to a stop: the integrator holds what friction needed
        loop.update(5.0, 4.0)
    held = loop.integrator_v
    assert held != 0.0 and loop.update(0.0, 0.05) == 0.0  # stopped with a zero setpoint: released
    assert all(loop.update(0.0, w) == 0.0 for w in (0.4, -0.4, 0.2))  # an estimate's wander is not motion
    assert loop.integrator_v == held
    assert loop.update(1.0, 0.0) == pytest.approx(GAINS.kp * 1.0 + held + GAINS.ki * T_S * 1.0, rel=1e-12)
