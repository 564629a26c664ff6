"""
Closed-loop figure-8
====================

The shipped figure-8 experiment (``experiments/figure8.toml``): a jerk-limited reference at 0.5 m/s tracked by the
LTV MPC over the PI wheel loops, through the 12-bit DA converter and the current-limited amplifier, on the full
nonlinear plant. The same run as ``agvctl run experiments/figure8.toml``.
"""

import matplotlib.pyplot as plt

from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.examples import example_path  # the example files installed with the package
from agvctl.scenario.experiment import load_experiment, run_experiment

experiment = load_experiment(example_path("experiments/figure8.toml"))
result = run_experiment(experiment)
log = result.log
metrics = closed_loop_metrics(result)
rms_mm, max_mm = metrics["tracking_error_rms_m"] * 1e3, metrics["tracking_error_max_m"] * 1e3
print(f"tracking error: RMS {rms_mm:.2f} mm, max {max_mm:.2f} mm")
print(f"cross-track error: max {metrics['cross_track_error_max_m'] * 1e3:.2f} mm")

# %%
# The path against the reference, and the errors over time: the time-indexed tracking error and the
# cross-track error (the distance to the nearest point of the reference's path).

fig, (ax_path, ax_err) = plt.subplots(1, 2, figsize=(10, 4))
ax_path.plot(log["ref_x_m"], log["ref_y_m"], "k--", lw=1, label="reference")
ax_path.plot(log["x_m"], log["y_m"], lw=1.5, label="vehicle")
ax_path.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="figure-8 at 0.5 m/s")
ax_path.legend(loc="upper right", fontsize=8)
ax_err.plot(log["t_s"], log["position_error_m"] * 1e3, label="tracking error")
ax_err.plot(log["t_s"], log["cross_track_error_m"] * 1e3, label="cross-track error")
ax_err.set(xlabel="t [s]", ylabel="error [mm]", title="errors")
ax_err.legend(fontsize=8)
for ax in (ax_path, ax_err):
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()
