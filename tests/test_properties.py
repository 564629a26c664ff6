"""Property tests: any valid vehicle and any DA input give finite results."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agvctl.params import load_vehicle
from agvctl.sim import simulate_batch

BASE = load_vehicle()


@st.composite
def vehicles(draw):
    rel = lambda lo, hi: draw(st.floats(lo, hi))  # noqa: E731
    coulomb = rel(0.0, 0.12)
    mass, h, about = 85 * rel(0.8, 3.0), rel(0.0, 0.45), draw(st.sampled_from(["rotation_point", "center_of_mass"]))
    inertia_cm = 4.236 * rel(0.4, 3.0)  # about the centre of mass: within the rules of agvctl.params.rules
    sets = [
        f"body.mass_kg={mass}",
        f"body.inertia_kg_m2={inertia_cm + (mass * h**2 if about == 'rotation_point' else 0.0)}",
        f"body.com_behind_axle_m={h}",
        f"wheels.separation_m={rel(0.3, 0.94)}",
        f"wheels.left.radius_m={rel(0.05, 0.2)}",
        f"wheels.right.radius_m={rel(0.05, 0.2)}",
        f"motor.left.coulomb_friction_n_m={coulomb}",
        f"motor.left.stiction_n_m={coulomb * rel(1.0, 2.0)}",
        f"motor.right.viscous_friction_n_m_s_rad={rel(0.0, 1e-3)}",
        f"motor.inertia_kg_m2={2.5e-5 * rel(0.2, 5.0)}",
        f"motor.gear_ratio={rel(10.0, 80.0)}",
        f"friction_model.p_factor={rel(10.0, 100.0)}",
        f"amplifier.current_limit_a={rel(10.0, 20.0)}",  # k_t I_max above the largest stiction (0.24 N m)
        f"body.inertia_about={about}",
    ]
    return BASE.with_overrides(sets)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(vehicle=vehicles(), seed=st.integers(0, 2**32 - 1))
def test_random_vehicles_and_inputs_stay_finite(vehicle, seed):
    rng = np.random.default_rng(seed)
    da = np.repeat(rng.uniform(-7.0, 7.0, size=(15, 2)), 5, axis=0)  # 3 s, switching every 0.2 s, past the DA range
    (log,) = simulate_batch([vehicle], da)
    for name in log:
        assert np.all(np.isfinite(log[name])), name
    assert np.all(np.abs(log["current_left_a"]) <= vehicle.amplifier.current_limit_a + 1e-9)
