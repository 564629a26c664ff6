"""Scenarios: an experiment file (a trajectory, a vehicle, the simulated truth, the controllers and the limits),
validated strictly, and run through the closed loop.

* :mod:`~agvctl.scenario.spec` — the file's schema, with one-line errors naming the file and the key.
* :mod:`~agvctl.scenario.experiment` — loading, resolving and running an experiment.
"""

from agvctl.scenario.experiment import Experiment, experiment_from_spec, load_experiment, run_experiment
from agvctl.scenario.spec import ControllerSpec, ExperimentSpec, PlantSpec

__all__ = [
    "ControllerSpec",
    "Experiment",
    "ExperimentSpec",
    "PlantSpec",
    "experiment_from_spec",
    "load_experiment",
    "run_experiment",
]
