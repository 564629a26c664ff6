"""
UMBmark calibration
===================

Borenstein & Feng's UMBmark on the simulator: the vehicle drives squares clockwise and counter-clockwise on its
own odometry, believing the nominal geometry, while the true right wheel is 0.5 % larger and the true wheel base
1 % wider. The clusters of return-position errors give the wheel-radius ratio and the wheel base; the squares are
driven again with the corrected geometry (``agvctl identify umbmark --simulate``, on 2 m squares here).
"""

import matplotlib.pyplot as plt

from agvctl.calibration import UmbmarkConfig, simulate_umbmark
from agvctl.params import load_vehicle

believed = load_vehicle()
truth = believed.with_overrides(["wheels.right.radius_m=0.1005", "wheels.separation_m=0.5454"])
result = simulate_umbmark(
    truth, believed, UmbmarkConfig(side_length_m=2.0, runs_per_direction=5), noise_scale=1.0, seed=1
)
print(f"E_max,syst before {result.error_before_m * 1e3:.1f} mm, after {result.error_after_m * 1e3:.2f} mm")
corrected_m = result.corrected_vehicle.wheels.separation_m
print(f"wheel base: believed {believed.wheels.separation_m} m, corrected {corrected_m:.4f} m")

fig, ax = plt.subplots(figsize=(6, 5))
for errors, when, marker in ((result.errors_before_m, "before", "o"), (result.errors_after_m, "after", "x")):
    for direction, color in (("cw", "C0"), ("ccw", "C1")):
        e = errors[direction] * 1e3
        ax.scatter(e[:, 0], e[:, 1], marker=marker, color=color, label=f"{direction}, {when}")
ax.axhline(0, color="k", lw=0.5)
ax.axvline(0, color="k", lw=0.5)
ax.set(xlabel="x error [mm]", ylabel="y error [mm]", title="return-position errors", aspect="equal")
ax.legend(fontsize=8)
ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()
