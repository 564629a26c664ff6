"""
A small fuzz
============

Scenarios nobody tuned for: random paths of lines, arcs and turns, plants within an envelope and starts off the
path, each drawn from the seed and its index alone. Here six scenarios of the CI configuration
(``experiments/fuzz/ci.toml``), each driven by the default MPC and by Ramsete, and judged by the default gate and
the configuration's limits, as ``agvctl fuzz experiments/fuzz/ci.toml --scenarios 6 --controllers mpc,ramsete``
does.
"""

import matplotlib.pyplot as plt
import numpy as np

from agvctl.examples import example_path  # the example files installed with the package
from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config

spec = override_fuzz_config(load_fuzz_config(example_path("experiments/fuzz/ci.toml")), controllers=["mpc", "ramsete"])
report = fuzz(spec, scenarios=range(6), jobs=1)
for outcome in report.outcomes:
    verdict = "pass" if outcome.passed else "FAIL " + "; ".join(outcome.reasons)
    print(f"scenario {outcome.scenario} {outcome.controller:8s} {verdict}")
for comparison in report.comparisons():
    print(comparison)

# %%
# Each scenario's largest cross-track error and final position error, per controller.

fig, axes = plt.subplots(1, 2, figsize=(10, 4))
for ax, metric, title in zip(
    axes,
    ("cross_track_error_max_m", "final_position_error_m"),
    ("largest cross-track error", "final position error"),
    strict=True,
):
    for offset, controller in ((-0.2, "mpc"), (0.2, "ramsete")):
        runs = [o for o in report.outcomes if o.controller == controller]
        index = np.array([o.scenario for o in runs])
        ax.bar(index + offset, [o.value(metric) * 1e3 for o in runs], width=0.4, label=controller)
    ax.set(xlabel="scenario", ylabel="mm", title=title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
fig.tight_layout()
plt.show()
