"""agvctl: control design and trajectory planning for the IAU differential-drive AGV.

The physics is that of the technical report "Models for IAU's Autonomous Guided Vehicle" (IMM-REP-1997-15),
with the corrections listed in the docs' model notes. Data flows one way (each name below is a module or an object of
``agvctl``)::

    vehicles/*.toml ──► params.load_vehicle ──► params.VehicleParams (.derived: eqs 5, 47-51, 60-64)
                            plant.FullModel (CasADi, eqs 2-4, 39-59) | plant.linear_model | plant.decoupled_wheel_models
    trajectories/*.toml ──► planning.plan ──► planning.Reference
    experiments/*.toml ──► scenario.load_experiment ──► scenario.run_experiment ──► sim.loop.run_closed_loop:
        every sample: sensing.Sensors (encoder counts, gyro, late position fixes) ─► estimation (wheel speeds;
                      the pose: odometry or the EKF) ─► controllers (MPC pose ─► PI wheel) ─► actuator.Actuator
                      (DA, amplifier) ─► plant.integrator.CompiledPlant (RK4, generated C) ─► sim.SimLog
    sim.SimLog ──► checks.runner.check_experiments (limits, JUnit) | plots | calibration (identify) ──► cli.main
    sim.SimLog ──► estimation.offline (the EKF and an RTS smoother offline)

Start with :func:`agvctl.params.load_vehicle`, :func:`agvctl.sim.simulate_open_loop` (DA voltages in, a
:class:`~agvctl.sim.SimLog` out) and :func:`agvctl.scenario.experiment.run_experiment` on
:func:`agvctl.scenario.experiment.load_experiment` (a closed-loop run from an experiment file).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from agvctl.errors import AgvctlError, ConfigError, PlanningError

if TYPE_CHECKING:
    from agvctl.params import VehicleParams, load_vehicle

__version__ = "0.2.0"

__all__ = ["AgvctlError", "ConfigError", "PlanningError", "VehicleParams", "load_vehicle", "__version__"]


def __getattr__(name: str) -> Any:
    """``VehicleParams`` and ``load_vehicle``, imported when first used: ``import agvctl`` stays light, so the
    command line starts (and answers an interrupt) before the numerical libraries are loaded."""
    if name in ("VehicleParams", "load_vehicle"):
        from agvctl import params

        return getattr(params, name)
    raise AttributeError(f"module 'agvctl' has no attribute {name!r}")
