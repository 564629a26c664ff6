"""
The report's model hierarchy
============================

The same DA voltages, held over 40 ms samples, through the report's three models: the full nonlinear model
(friction of eqs 2-4, centrifugal and coriolis terms, the current limit; eqs 52-59), the simplified linear model
(eqs 35-38, a python-control ``StateSpace``) and the decoupled per-wheel model (eqs 60-61, python-control
``TransferFunction`` objects). They part where the report says they do: Coulomb friction at low speed, the
centrifugal load in a spin, and the current limit on a full-scale start. ``experiments/model_comparison.py``
prints the same comparison as a table.
"""

import control
import matplotlib.pyplot as plt
import numpy as np

from agvctl.actuator import Actuator
from agvctl.params import load_vehicle
from agvctl.plant import decoupled_wheel_models, linear_model
from agvctl.sim import simulate_open_loop

PHASES = (  # name, duration in s, DA left and right in V
    ("creep", 3.0, 0.55, 0.55),
    ("cruise", 4.0, 2.0, 2.0),
    ("spin", 4.0, 3.0, -3.0),
    ("coast", 2.0, 0.0, 0.0),
    ("full-scale start", 2.0, 5.0, 5.0),
)

vehicle = load_vehicle()
ts = vehicle.control.sample_period_s
da = np.array([(left, right) for _, duration, left, right in PHASES for _ in range(round(duration / ts))])
t = np.arange(len(da) + 1) * ts
u = Actuator(vehicle).apply(da).motor_voltage_v  # the same motor voltages into every model
u_held = np.vstack([u, u[-1:]])

full = simulate_open_loop(vehicle, da).log
speeds = {"full (eqs 52-59)": np.column_stack([full["omega_motor_left_rad_s"], full["omega_motor_right_rad_s"]])}
linear = control.sample_system(linear_model(vehicle), ts, method="zoh")  # exact for held inputs
speeds["linear (eqs 35-38)"] = control.forced_response(linear, T=t, U=u_held.T).outputs.T
speeds["decoupled (eqs 60-61)"] = np.column_stack(
    [
        control.forced_response(control.sample_system(tf, ts, method="zoh"), T=t, U=u_held[:, i]).outputs
        for i, tf in enumerate(decoupled_wheel_models(vehicle))
    ]
)

# %%
# Vehicle speed and yaw rate from each model's wheel speeds (r/N of the motor speeds).

r_over_n = vehicle.wheels.left.radius_m / vehicle.motor.left.gear_ratio
b = vehicle.wheels.separation_m
fig, (ax_u, ax_w) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
for name, omega_motor in speeds.items():
    wheel = omega_motor * r_over_n
    ax_u.plot(t, wheel.mean(axis=1), label=name)
    ax_w.plot(t, (wheel[:, 1] - wheel[:, 0]) / b, label=name)
start = 0.0
for name, duration, _, _ in PHASES:
    for ax in (ax_u, ax_w):
        ax.axvline(start, color="k", lw=0.5, ls=":")
    ax_u.text(start + 0.1, 0.85, name, fontsize=8, transform=ax_u.get_xaxis_transform())
    start += duration
ax_u.set(ylabel="speed U [m/s]", title="same DA voltages, three models")
ax_w.set(xlabel="t [s]", ylabel="yaw rate ω [rad/s]")
ax_u.legend(fontsize=8, loc="lower right")
for ax in (ax_u, ax_w):
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()
