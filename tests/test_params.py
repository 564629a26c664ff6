"""The default vehicle against the report's own figures, and the derived constants against first principles."""

import math

import pytest

from agvctl.config import to_dict
from agvctl.params import center_of_mass_from_scales, inertia_from_dimensions, load_vehicle


def test_inertia_from_dimensions_reproduces_table(vehicle):
    # eq 64 with appendix A's dimensions gives the table's I = 5.46 kg m²
    assert inertia_from_dimensions(vehicle.frame, vehicle.battery) == pytest.approx(5.46, rel=5e-3)


def test_accel_limit_reproduces_table(vehicle):
    # eq 5 with k_t = 0.027 N m/A (ERRATA) gives the table's 0.657 m/s²
    assert vehicle.derived.accel_limit_m_s2 == pytest.approx(0.657, rel=5e-3)


def test_da_resolution(vehicle):
    assert vehicle.derived.da_volts_per_bit == 10.0 / 4096
    assert vehicle.derived.da_volts_per_bit == pytest.approx(2.44e-3, rel=1e-3)


def test_center_of_mass_from_scales_recovers_known_h():
    # build scale readings from a known mass distribution: moment balance about the wheel axle
    M, h, d_wc = 85.0, 0.12, 0.50
    castor = M * h / d_wc
    left = right = (M - castor) / 2
    M_est, h_est = center_of_mass_from_scales(left, right, castor, d_wc)
    assert M_est == pytest.approx(M)
    assert h_est == pytest.approx(h)


def test_coupling_constants_from_first_principles(vehicle):
    d = vehicle.derived
    M, b, r, N = 85.0, 0.54, 0.10, 36.0
    i_o = 5.46
    # straight-line acceleration: both wheels accelerate together, the vehicle mass is shared: k_ll + k_lr = M r²/(2N²)
    assert d.k_ll + d.k_lr == pytest.approx(M * r**2 / (2 * N**2))
    # spin: wheels opposite, the inertia about O is shared: k_ll − k_lr = 2 I_O r²/(b² N²)
    assert d.k_ll - d.k_lr == pytest.approx(2 * i_o * r**2 / (b**2 * N**2))
    assert d.k_llr == pytest.approx(M * 0.12 * r**3 / (b**2 * N**3))


def test_top_speed_is_the_steady_state_of_eq_33(vehicle):
    # k_t/R (u − k_e ω) = τ_c at steady state (f_m = 0), u = 2 · 2047 · 10/4096 V
    u = 2 * 2047 * 10 / 4096
    omega = (0.027 * u / 0.38 - 0.065) / (0.027 * 0.027 / 0.38)
    assert vehicle.derived.max_speed_m_s == pytest.approx(omega * 0.10 / 36, rel=1e-9)


def test_mechanical_time_constant_and_friction_gain(vehicle):
    d = vehicle.derived
    damping = 0.027 * 0.027 / 0.38
    assert d.left.friction_gain_p == pytest.approx(10 * damping)  # eq 62 with the preferred factor 10
    assert d.mechanical_time_constant_s == pytest.approx(d.left.inertia_equivalent_kg_m2 / damping)
    # J̃ lies between the spin and the straight-line inertia seen by one motor
    j = 2.5e-5
    assert j + d.k_ll - abs(d.k_lr) <= d.left.inertia_equivalent_kg_m2 <= j + d.k_ll + abs(d.k_lr)


def test_inertia_about_center_of_mass_adds_m_h2():
    v = load_vehicle(None, ["body.inertia_about=center_of_mass", "body.inertia_kg_m2=4.236"])
    assert v.derived.inertia_rotation_point_kg_m2 == pytest.approx(4.236 + 85 * 0.12**2)


def test_per_side_override_and_unequal_radii():
    v = load_vehicle(None, ["motor.left.coulomb_friction_n_m=0.05", "wheels.right.radius_m=0.101"])
    assert v.motor.left.coulomb_friction_n_m == 0.05 and v.motor.right.coulomb_friction_n_m == 0.065
    d = v.derived
    assert d.k_rr / d.k_ll == pytest.approx((0.101 / 0.10) ** 2)
    assert d.k_lrr / d.k_llr == pytest.approx(0.101 / 0.10)
    assert math.isfinite(d.max_speed_m_s)


def test_wheel_radius_per_side_and_common():
    """``wheels.radius_m`` sets both sides, ``wheels.left.radius_m`` one; written back, a shared radius is the
    common key and different radii are the sides' tables."""
    v = load_vehicle()
    assert v.wheels.left.radius_m == v.wheels.right.radius_m == 0.10
    assert v.wheels.side("right") is v.wheels.right
    tol = {"radius_tolerance": 0.01, "separation_tolerance": 0.02}
    assert to_dict(v)["wheels"] == {"separation_m": 0.54, **tol, "radius_m": 0.10}
    both = v.with_overrides(["wheels.radius_m=0.12"])
    assert both.wheels.left.radius_m == both.wheels.right.radius_m == 0.12
    left = v.with_overrides(["wheels.left.radius_m=0.101"])
    assert (left.wheels.left.radius_m, left.wheels.right.radius_m) == (0.101, 0.10)
    sides = {"left": {"radius_m": 0.101}, "right": {"radius_m": 0.10}}
    assert to_dict(left)["wheels"] == {"separation_m": 0.54, **tol, **sides}
    assert left.with_overrides([]) == left


def test_rim_per_motor_radian_is_r_over_n():
    v = load_vehicle(None, ["wheels.right.radius_m=0.1004", "motor.right.gear_ratio=35.5"])
    assert v.rim_per_motor_rad("left") == 0.10 / 36.0
    assert v.rim_per_motor_rad("right") == 0.1004 / 35.5
    q = 2.0 * math.pi / 2000
    assert v.to_rim("right", q) == q * 0.1004 / 35.5
    assert v.to_motor("right", 0.3) == 0.3 * 35.5 / 0.1004


def test_an_inertia_far_out_of_range_is_refused_in_one_line() -> None:
    from agvctl.errors import ConfigError

    with pytest.raises(ConfigError, match=r"body\.inertia_kg_m2: must be within \[") as info:
        load_vehicle(None, [("body.inertia_kg_m2", 2.67e17)])
    assert len(str(info.value).splitlines()) == 1
