"""The linear (35-38) and decoupled (60-61) models, and the CasADi linearisation of the full model."""

import control
import numpy as np
import pytest

from agvctl.plant import decoupled_wheel_models, linear_model, linear_model_speed_yaw_rate
from agvctl.plant.full import FullModel, PlantOptions, parameter_vector


def test_linearisation_at_rest_equals_linear_model(vehicle):
    model = FullModel(PlantOptions(friction=False, centrifugal=False, current_limit=False))
    A, B = model.linearize(np.zeros(5), np.zeros(2), parameter_vector(vehicle))
    lin = linear_model(vehicle)
    np.testing.assert_allclose(A[:2, :2], lin.A, rtol=1e-12)
    np.testing.assert_allclose(B[:2, :], lin.B, rtol=1e-12)


def test_linear_model_dc_gain_is_one_over_ke(vehicle):
    # f_m = 0: at steady state the back-EMF balances the voltage, ω = u / k_e
    dc = control.dcgain(linear_model(vehicle))
    np.testing.assert_allclose(dc, np.eye(2) / 0.027, rtol=1e-9, atol=1e-9)


def test_speed_yaw_rate_variant(vehicle):
    sys = linear_model_speed_yaw_rate(vehicle)
    dc = control.dcgain(sys)
    # equal voltages: straight at U = (u/k_e) r/N, no yaw
    assert dc[0, 0] + dc[0, 1] == pytest.approx(0.1 / 36 / 0.027)
    assert dc[1, 0] + dc[1, 1] == pytest.approx(0.0, abs=1e-12)
    assert sys.output_labels == ["speed_m_s", "yaw_rate_rad_s"]


def test_decoupled_models_time_constant(vehicle):
    left, right = decoupled_wheel_models(vehicle)
    pole = control.poles(left)[0]
    j_eq = vehicle.derived.left.inertia_equivalent_kg_m2
    assert -1 / pole.real == pytest.approx(j_eq * 0.38 / 0.027**2)
    assert control.dcgain(left) == pytest.approx(1 / 0.027)
    assert left.input_labels == ["voltage_left_v"]
