"""
EKF against odometry
====================

The figure-8 on a vehicle whose right wheel is 0.5 % larger than the controllers believe, closed on estimates
from the sensors: encoder counts alone (odometry, ``experiments/figure8_odometry.toml``), and the counts fused
with late position fixes by the pose EKF with buffer and replay (``experiments/figure8_ekf.toml``). Odometry
integrates the wrong radius; the EKF estimates it.
"""

import matplotlib.pyplot as plt
import numpy as np

from agvctl.examples import example_path  # the example files installed with the package
from agvctl.scenario.experiment import load_experiment, run_experiment

logs = {
    "odometry": run_experiment(load_experiment(example_path("experiments/figure8_odometry.toml"))).log,
    "EKF": run_experiment(load_experiment(example_path("experiments/figure8_ekf.toml"))).log,
}

fig, (ax_path, ax_err) = plt.subplots(1, 2, figsize=(10, 4))
ax_path.plot(logs["EKF"]["ref_x_m"], logs["EKF"]["ref_y_m"], "k--", lw=1, label="reference")
for name, log in logs.items():
    estimate_error_m = np.hypot(log["est_x_m"] - log["x_m"], log["est_y_m"] - log["y_m"])
    print(f"{name}: estimate error RMS {np.sqrt(np.mean(estimate_error_m**2)) * 1e3:.1f} mm")
    ax_path.plot(log["x_m"], log["y_m"], lw=1.2, label=f"vehicle on {name}")
    ax_err.plot(log["t_s"], estimate_error_m * 1e3, label=name)
ax_path.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="true paths")
ax_err.set(xlabel="t [s]", ylabel="|estimate − truth| [mm]", title="position estimate error", yscale="log")
ax_err.set_ylim(bottom=0.1)
for ax in (ax_path, ax_err):
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()
