"""
A first path and its check
==========================

A user's first files: a path of a line and an arc, and an experiment that runs it with the default controllers
and a tracking limit. ``plan`` gives the reference; ``check_experiments`` runs it and judges it against its
``[limits]`` and the default gate, as ``agvctl check`` does in CI.
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from agvctl.checks.runner import check_experiments
from agvctl.params import load_vehicle
from agvctl.planning import load_path, plan

folder = Path(tempfile.mkdtemp())
(folder / "my_path.toml").write_text(
    """name = "my-first-path"
[[segments]]
type = "line"
length_m = 1.5
[[segments]]
type = "arc"
radius_m = 0.8
angle_deg = 90
""",
    encoding="utf-8",
)
(folder / "my_experiment.toml").write_text(
    """name = "my_first_run"
trajectory = "my_path.toml"
vehicle = "default"
[controller]
pose = "mpc"
[limits]
tracking_error_rms_m = 0.01
""",
    encoding="utf-8",
)

# %%
# The reference: time-optimal within the default limits, which leave headroom for the feedback.

reference = plan(load_path(folder / "my_path.toml"), load_vehicle())
grid = reference.grid
print(f"{reference.path_length_m:.2f} m in {reference.duration_s:.2f} s")

fig, (ax_path, ax_speed) = plt.subplots(1, 2, figsize=(10, 4))
ax_path.plot(grid.x_m, grid.y_m)
ax_path.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="my-first-path")
ax_speed.plot(grid.t_s, grid.wheel_speed_left_m_s, label="left wheel")
ax_speed.plot(grid.t_s, grid.wheel_speed_right_m_s, label="right wheel")
ax_speed.set(xlabel="t [s]", ylabel="wheel speed [m/s]", title="the reference's wheel speeds")
ax_speed.legend(fontsize=8)
for ax in (ax_path, ax_speed):
    ax.grid(alpha=0.3)
fig.tight_layout()
plt.show()

# %%
# The check: every limit of the file and of the default gate, with its value and its bound.

report = check_experiments([folder / "my_experiment.toml"], jobs=1)
print("PASSED" if report.passed else "FAILED")
for experiment in report.experiments:
    for verdict in experiment.verdicts:
        print(verdict.message)
