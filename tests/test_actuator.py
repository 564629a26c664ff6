"""The DA converter and amplifier exactly as ERRATA's actuator-chain specification."""

import numpy as np
import pytest

from agvctl.actuator import Actuator

ALPHA = 10.0 / 4096  # V per code


def test_da_step_and_range(vehicle):
    act = Actuator(vehicle)
    assert act.volts_per_code == ALPHA
    out = act.apply([0.0, ALPHA, -ALPHA, 5.0, -5.0, 7.0, -7.0])
    assert list(out.da_code) == [0, 1, -1, 2047, -2048, 2047, -2048]
    # +5 V is not reachable: code 2047 gives 4.9976 V
    assert out.da_voltage_v[3] == pytest.approx(2047 * ALPHA) and out.da_voltage_v[3] < 5.0
    assert out.da_voltage_v[4] == -5.0
    assert list(out.da_clipped) == [False, False, False, True, False, True, True]


def test_rounds_to_nearest_code(vehicle):
    act = Actuator(vehicle)
    out = act.apply([0.4 * ALPHA, 0.6 * ALPHA, -0.6 * ALPHA, 100.4 * ALPHA])
    assert list(out.da_code) == [0, 1, -1, 100]


def test_amplifier_gain_and_voltage_limit(vehicle):
    out = Actuator(vehicle).apply([1.0])
    assert out.motor_voltage_v[0] == pytest.approx(2.0 * round(1.0 / ALPHA) * ALPHA)
    limited = Actuator(vehicle.with_overrides(["amplifier.voltage_limit_v=6.0"])).apply([4.0, -4.0, 2.0])
    np.testing.assert_allclose(limited.motor_voltage_v, [6.0, -6.0, 2.0 * round(2.0 / ALPHA) * ALPHA])
    assert list(limited.voltage_limited) == [True, True, False]


def test_codes_directly(vehicle):
    out = Actuator(vehicle).from_codes([100, 5000])
    assert out.da_voltage_v[0] == pytest.approx(100 * ALPHA)
    assert out.da_code[1] == 2047 and out.da_clipped[1]


def test_scalar_motor_voltage_is_the_chain_for_one_side(vehicle):
    actuator = Actuator(vehicle)
    requests = np.concatenate([np.linspace(-7.0, 7.0, 1001), [np.nan, 2.5 * actuator.volts_per_code]])
    expected = actuator.apply(requests).motor_voltage_v
    assert [actuator.motor_voltage_v(float(v)) for v in requests] == list(expected)
    lowered = Actuator(vehicle.with_overrides(["amplifier.voltage_limit_v=3.0"]))
    assert lowered.motor_voltage_v(4.0) == 3.0 and lowered.motor_voltage_v(-4.0) == -3.0


def test_a_pair_of_commands_gives_what_the_array_chain_gives(vehicle):
    # apply() computes one sample's (left, right) pair in plain floats: every output equal to the array chain's
    for act in (Actuator(vehicle), Actuator(vehicle.with_overrides(["amplifier.voltage_limit_v=6.0"]))):
        steps = np.array([0.5, 1.5, -0.5, -2.5, 2047.5, -2048.5, 2048.0])
        requests = np.concatenate(
            [np.linspace(-7.0, 7.0, 2001), steps * act.volts_per_code, [np.nan, np.inf, -np.inf, 1e300, -1e300, 0.0]]
        )
        expected = act.from_codes(*act.da_code(requests))
        pairs = requests.reshape(-1, 2)
        for i, pair in enumerate(pairs):
            out = act.apply(pair)
            for name in ("da_code", "da_voltage_v", "motor_voltage_v", "da_clipped", "voltage_limited"):
                got, want = getattr(out, name), getattr(expected, name)[2 * i : 2 * i + 2]
                assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), (name, pair)
