"""Simulation: the plant stepped through the actuator chain, open-loop runs and batches, wheel-step responses, and
the closed loop.

* :mod:`agvctl.sim.stepper` — one sample of the compiled plant behind the DA converter and the amplifier.
* :mod:`agvctl.sim.open_loop` — voltage profiles applied open loop, one run or a batch.
* :mod:`agvctl.sim.wheel_step` — the PI wheel loops' step response.
* :mod:`agvctl.sim.loop` — the closed loop: reference, pose controller, wheel loops, sensors and estimator.
* :mod:`agvctl.sim.records` — what the closed loop records per sample, and its log.

Inside the package the layers point one way (an import-linter contract): ``loop`` → ``open_loop``, ``wheel_step``
and ``records`` → ``stepper``."""

from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.sim.open_loop import OpenLoopResult, load_input_profile, simulate_batch, simulate_open_loop
from agvctl.sim.stepper import PlantStepper
from agvctl.sim.wheel_step import StepMetrics, WheelStepResult, step_metrics, wheel_step_response

__all__ = [
    "PLANT_LOG_COLUMNS",
    "OpenLoopResult",
    "PlantStepper",
    "SimLog",
    "load_input_profile",
    "simulate_batch",
    "simulate_open_loop",
    "StepMetrics",
    "WheelStepResult",
    "step_metrics",
    "wheel_step_response",
]
