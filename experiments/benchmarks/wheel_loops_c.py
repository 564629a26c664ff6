"""Benchmark of the PI wheel loops' step: the Python loops against the generated C ones, in the same run.

The setpoints and measured motor speeds of the figure-8 experiment's closed loop are recorded, then both
implementations step through them, interleaved sample by sample (so that both see the same machine load), each call
timed with ``perf_counter_ns``: the Python :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController` and the C
loops (``wheel_loops = "pi_c"``) through ctypes, numpy arrays in and out as the closed loop calls them. Prints the
median and p99 step time of each in µs and their ratio, and the figure-8 closed loop's wall time with each.

Run:  python experiments/benchmarks/wheel_loops_c.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.pi.c_loops import CompiledPIWheelController
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.scenario.experiment import load_experiment, run_experiment

EXPERIMENT = Path(__file__).parents[1] / "figure8.toml"


class Recording:
    """The Python loops, recording every input they are given."""

    def __init__(self, loops: PIWheelController) -> None:
        self.loops = loops
        self.inputs: list[tuple[NDArray[np.float64], NDArray[np.float64]]] = []

    def reset(self) -> None:
        self.loops.reset()

    @property
    def limited(self) -> tuple[bool, bool]:
        return self.loops.limited

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        self.inputs.append((np.array(setpoint_rad_s, dtype=float), np.array(measured_rad_s, dtype=float)))
        return self.loops.update(setpoint_rad_s, measured_rad_s)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="passes over the recorded inputs")
    args = parser.parse_args()
    experiment = load_experiment(EXPERIMENT)
    vehicle = experiment.controller_vehicle
    gains, options = experiment.wheel_loops.design.gains, experiment.wheel_loops.options
    recording = Recording(PIWheelController(vehicle, gains, options))
    run_experiment(experiment, wheel_controller=recording)
    python, c = PIWheelController(vehicle, gains, options), CompiledPIWheelController(vehicle, gains, options)
    times: dict[str, list[int]] = {"python": [], "c": []}
    clock = time.perf_counter_ns
    for _ in range(args.repeat):
        python.reset()
        c.reset()
        for setpoint, measured in recording.inputs:
            t0 = clock()
            python.update(setpoint, measured)
            t1 = clock()
            c.update(setpoint, measured)
            t2 = clock()
            times["python"].append(t1 - t0)
            times["c"].append(t2 - t1)
    median = {k: statistics.median(v) / 1e3 for k, v in times.items()}
    p99 = {k: float(np.percentile(v, 99)) / 1e3 for k, v in times.items()}
    print(f"wheel-loop step over {len(recording.inputs)} samples of {EXPERIMENT.name} x {args.repeat} passes:")
    for name in ("python", "c"):
        print(f"  {name:<7} median {median[name]:6.2f} µs   p99 {p99[name]:6.2f} µs")
    print(f"  ratio   Python / C median {median['python'] / median['c']:.1f}x")
    for name, loops in (("python", PIWheelController(vehicle, gains, options)), ("c", c)):
        walls = [run_experiment(experiment, wheel_controller=loops).wall_time_s for _ in range(3)]
        print(f"  figure-8 closed loop with the {name} loops: {min(walls):.3f} s (best of 3)")


if __name__ == "__main__":
    main()
