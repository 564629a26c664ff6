"""Building an experiment's controllers: the PI wheel loops (tuned or from a gains file) and the pose controller."""

from __future__ import annotations

import dataclasses
import functools
from typing import NamedTuple

from agvctl.config import build
from agvctl.controllers.base import FeedForwardPoseController, PoseController
from agvctl.controllers.pi import PIGains, PIWheelController, load_gains
from agvctl.controllers.tuning import closed_loop_time_constant_s, design_pi
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams
from agvctl.sim.experiment import Experiment

__all__ = ["WheelLoopDesign", "build_controllers", "default_pi_gains"]


class WheelLoopDesign(NamedTuple):
    """The PI gains and the first-order lag τ (s) that best fits their closed loop."""

    gains: PIGains
    loop_time_constant_s: float


@functools.lru_cache(maxsize=32)
def default_pi_gains(vehicle: VehicleParams) -> WheelLoopDesign:
    """The PI designed for the default spec (PM ≥ 60°, GM ≥ 10 dB, fastest) and the time constant (s) of the
    first-order lag that best fits its closed loop (the MPC's wheel-loop model)."""
    gains = design_pi(vehicle).gains
    return WheelLoopDesign(gains, closed_loop_time_constant_s(vehicle, gains))


def build_controllers(exp: Experiment, vehicle: VehicleParams) -> tuple[PoseController, PIWheelController]:
    """The pose controller and wheel loops of ``exp``, designed for ``vehicle`` (the controller's model)."""
    spec = exp.controller
    gains, loop_tau_s = default_pi_gains(vehicle)
    feedforward = spec.coulomb_feedforward
    if spec.pi_gains is not None:
        path = exp.resolve(spec.pi_gains)
        if not path.exists():
            raise ConfigError(exp.source, "controller.pi_gains", f"file not found: {path}")
        settings = load_gains(path)
        if abs(settings.dt_s - vehicle.control.sample_period_s) > 1e-12:
            raise ConfigError(
                str(path),
                "pi.dt_s",
                f"gains designed for {settings.dt_s:g} s, "
                f"the vehicle samples every {vehicle.control.sample_period_s:g} s",
            )
        gains, feedforward = settings.gains, settings.coulomb_feedforward or feedforward
        loop_tau_s = closed_loop_time_constant_s(vehicle, gains)
    wheel = PIWheelController(
        vehicle,
        gains,
        coulomb_feedforward=feedforward,
        symmetric_braking=spec.symmetric_braking,
        gentle_stop=spec.gentle_stop,
    )
    pose: PoseController
    if spec.pose == "none":
        pose = FeedForwardPoseController()
        return pose, wheel
    from agvctl.controllers.mpc_common import MpcConfig

    settings_map = dict(spec.pose_settings)
    config = build(MpcConfig, settings_map, source=exp.source, prefix="controller")
    if "wheel_loop_time_constant_s" not in settings_map:
        # the MPC predicts the wheel loops as first-order lags: the best fit to the designed closed loop
        config = dataclasses.replace(config, wheel_loop_time_constant_s=loop_tau_s)
    if spec.pose == "mpc":
        from agvctl.controllers.mpc_ltv import LtvMpcController

        pose = LtvMpcController(vehicle, config)
    else:
        from agvctl.controllers.mpc_nonlinear import NonlinearMpcController

        pose = NonlinearMpcController(vehicle, config)
    return pose, wheel
