"""The shipped experiments' results: every ``experiments/*.toml`` run once, as ``agvctl run`` runs it.

Prints per experiment the time-indexed tracking error (RMS, max), the largest cross-track error, the peak wheel
acceleration and the pose controller's median step time. Each experiment's own ``[limits]`` are its goals
(``agvctl check experiments/*.toml`` enforces them).

Run:  python experiments/benchmarks/shipped.py
"""

from __future__ import annotations

import sys
from pathlib import Path

from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENTS = Path(__file__).resolve().parent.parent


def main() -> int:
    print(
        f"{'experiment':<24} {'RMS [mm]':>9} {'max [mm]':>9} {'cross-track max [mm]':>21} {'peak accel [m/s²]':>18}"
        f" {'step median [ms]':>17}"
    )
    for path in sorted(EXPERIMENTS.glob("*.toml")):
        experiment = load_experiment(path)
        m = closed_loop_metrics(run_experiment(experiment))
        print(
            f"{experiment.spec.name:<24} {m['tracking_error_rms_m'] * 1e3:9.2f} {m['tracking_error_max_m'] * 1e3:9.2f}"
            f" {m['cross_track_error_max_m'] * 1e3:21.2f} {m['peak_wheel_accel_m_s2']:18.3f}"
            f" {m['solve_time_p50_ms']:17.3f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
