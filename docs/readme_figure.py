"""Draw the README's picture, ``docs/_static/figure8.png``, from a real run of ``experiments/figure8.toml``.

    python docs/readme_figure.py

The path against the reference, and the tracking and cross-track errors over time, of the same closed loop
``agvctl run experiments/figure8.toml`` runs.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from agvctl.evaluation.metrics import closed_loop_metrics  # noqa: E402
from agvctl.scenario.experiment import load_experiment, run_experiment  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "_static" / "figure8.png"


def main() -> None:
    result = run_experiment(load_experiment(ROOT / "experiments" / "figure8.toml"))
    log, metrics = result.log, closed_loop_metrics(result)
    fig, (ax_path, ax_err) = plt.subplots(1, 2, figsize=(9, 3.4), gridspec_kw={"width_ratios": [1.25, 1]})
    ax_path.plot(log["ref_x_m"], log["ref_y_m"], "k--", lw=1, label="reference")
    ax_path.plot(log["x_m"], log["y_m"], lw=1.5, alpha=0.8, label="vehicle (full plant)")
    ax_path.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="figure-8 at 0.5 m/s, MPC over PI loops")
    ax_path.legend(loc="upper right", fontsize=7)
    ax_err.plot(log["t_s"], log["position_error_m"] * 1e3, lw=1, label="tracking error")
    ax_err.plot(log["t_s"], log["cross_track_error_m"] * 1e3, lw=1, label="cross-track error")
    rms_mm = metrics["tracking_error_rms_m"] * 1e3
    ax_err.set(xlabel="t [s]", ylabel="error [mm]", title=f"errors (tracking RMS {rms_mm:.2f} mm)")
    ax_err.legend(fontsize=7)
    for ax in (ax_path, ax_err):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=80)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
