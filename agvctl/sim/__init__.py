"""Simulation: the compiled integrator, the plant stepper, open-loop runs, batches and the log.

Inside the package the layers point one way (an import-linter contract): ``experiment`` → ``spec`` →
``controllers``/``limits``/``metrics``/``estimation`` (offline) → ``loop`` → ``estimators`` and ``wheel_speed``
(with ``open_loop`` and ``wheel_step``) → ``ekf`` → ``sensors`` and ``stepper`` → ``integrator`` and ``log``."""

from agvctl.sim.integrator import CompiledPlant, choose_substeps, compiled_plant, sample_splits
from agvctl.sim.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.sim.open_loop import OpenLoopResult, load_input_profile, simulate_batch, simulate_open_loop
from agvctl.sim.stepper import PlantStepper
from agvctl.sim.wheel_step import StepMetrics, WheelStepResult, step_metrics, wheel_step_response

__all__ = [
    "PLANT_LOG_COLUMNS",
    "CompiledPlant",
    "OpenLoopResult",
    "PlantStepper",
    "SimLog",
    "choose_substeps",
    "compiled_plant",
    "sample_splits",
    "load_input_profile",
    "simulate_batch",
    "simulate_open_loop",
    "StepMetrics",
    "WheelStepResult",
    "step_metrics",
    "wheel_step_response",
]
