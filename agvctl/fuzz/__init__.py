"""Fuzzing: random scenarios of a declared envelope through the closed loop, for one or more pose controllers.

* :mod:`~agvctl.fuzz.spec` — the fuzz configuration file: the envelope, the controllers, the limits.
* :mod:`~agvctl.fuzz.generate` — one scenario (path, plant, start) from a seed and an index.
* :mod:`~agvctl.fuzz.run` — the runs, on local processes or Dask, and their outcomes.
* :mod:`~agvctl.fuzz.report` — per-controller statistics and comparisons, as JSON and JUnit.
"""

from agvctl.fuzz.generate import Scenario, generate_scenario
from agvctl.fuzz.report import FuzzOutcome, FuzzReport, FuzzTask
from agvctl.fuzz.run import fuzz
from agvctl.fuzz.spec import FuzzSpec, load_fuzz_config

__all__ = [
    "FuzzOutcome",
    "FuzzReport",
    "FuzzSpec",
    "FuzzTask",
    "Scenario",
    "fuzz",
    "generate_scenario",
    "load_fuzz_config",
]
