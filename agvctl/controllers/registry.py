"""The controllers an experiment can name: the pose controllers by ``[controller] pose``, and the PI wheel loops.

A new pose controller is one module — a class satisfying :class:`~agvctl.controllers.base.PoseController`,
constructed as ``Controller(vehicle, settings)`` — and one line in :data:`POSE_CONTROLLERS`. The experiment loader
builds the ``[controller]`` table's remaining keys strictly into the entry's settings dataclass, once; ``run``,
``check`` and the documentation's list of names read the same table.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl.config import document_fields
from agvctl.controllers.base import PoseController
from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig, LtvLqrController
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController
from agvctl.controllers.mpc.config import MpcConfig
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController
from agvctl.controllers.pi.gains_file import load_gains
from agvctl.controllers.pi.tuning import WheelLoopDesign, closed_loop_time_constant_s, default_pi_gains
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams

__all__ = [
    "POSE_CONTROLLERS",
    "PoseControllerKind",
    "WheelLoopDesign",
    "WheelLoops",
    "default_pi_gains",
    "design_wheel_loops",
]


@document_fields
@dataclass(frozen=True)
class PoseControllerKind:
    """One entry of :data:`POSE_CONTROLLERS`."""

    make: Callable[[VehicleParams, Any], PoseController]
    """``make(vehicle, settings)``: the controller, designed for the controller's vehicle."""
    settings: type | None
    """The dataclass the ``[controller]`` table's other keys are built into (None: the controller takes none)."""
    description: str
    """What the controller is, in a few words, for ``--help`` and the docs."""
    fit_wheel_loop: Callable[[Any, WheelLoopDesign], Any] | None = None
    """Completes the settings with the experiment's wheel loops (e.g. the MPC's model of their lag)."""


def _mpc_wheel_loop(config: MpcConfig, wheel: WheelLoopDesign) -> MpcConfig:
    """The MPC predicts the wheel loops as first-order lags: unless set, the best fit to the experiment's own."""
    if config.wheel_loop_time_constant_s is not None:
        return config
    return dataclasses.replace(config, wheel_loop_time_constant_s=wheel.loop_time_constant_s)


POSE_CONTROLLERS: dict[str, PoseControllerKind] = {
    "mpc": PoseControllerKind(LtvMpcController, MpcConfig, "linear time-varying MPC on OSQP", _mpc_wheel_loop),
    "nmpc": PoseControllerKind(NonlinearMpcController, MpcConfig, "nonlinear MPC on CasADi/IPOPT", _mpc_wheel_loop),
    "ramsete": PoseControllerKind(RamseteController, RamseteConfig, "WPILib's Ramsete unicycle law (yardstick)"),
    "ltv_lqr": PoseControllerKind(LtvLqrController, LtvLqrConfig, "WPILib's LTV unicycle LQR (yardstick)"),
    "none": PoseControllerKind(
        lambda vehicle, settings: FeedForwardPoseController(), None, "the reference's feed-forward only"
    ),
}
"""The pose controllers by the name an experiment's ``[controller] pose`` gives."""


@document_fields
@dataclass(frozen=True)
class WheelLoops:
    """An experiment's PI wheel-speed loops: the gains (designed, or from a gains file) and their options, as
    :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController` takes them."""

    design: WheelLoopDesign
    """The gains and the time constant of the first-order lag that best fits their closed loop."""
    coulomb_feedforward: bool
    """Whether the loops add the Coulomb-friction feed-forward."""
    symmetric_braking: bool
    """Whether the braking current is always limited to decelerate no harder than a_lim."""
    gentle_stop: bool
    """Whether it is limited so only when a wheel is brought to a stop."""
    steering_priority: bool = True
    """Whether, when both loops ask past the current limit the same way, the difference they ask is kept."""

    def controller(self, vehicle: VehicleParams) -> PIWheelController:
        """The wheel-speed controller on ``vehicle`` (the controller's model)."""
        return PIWheelController(
            vehicle,
            self.design.gains,
            coulomb_feedforward=self.coulomb_feedforward,
            symmetric_braking=self.symmetric_braking,
            gentle_stop=self.gentle_stop,
            steering_priority=self.steering_priority,
        )


def design_wheel_loops(
    vehicle: VehicleParams,
    gains_path: Path | None,
    *,
    coulomb_feedforward: bool,
    symmetric_braking: bool,
    gentle_stop: bool,
    steering_priority: bool = True,
    source: str,
) -> WheelLoops:
    """An experiment's wheel loops: from a gains file, or designed for the default spec.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's vehicle.
    gains_path : Path or None
        A gains file written by ``agvctl tune --out`` (None: design the gains for the default spec).
    coulomb_feedforward : bool
        Add the Coulomb-friction feed-forward (a gains file's own setting adds to it).
    symmetric_braking : bool
        Always limit the braking current so as to decelerate no harder than a_lim.
    gentle_stop : bool
        Limit it so only when a wheel is brought to a stop.
    steering_priority : bool
        When both loops ask past the current limit the same way, keep the difference they ask.
    source : str
        The experiment file, as errors name it.

    Returns
    -------
    WheelLoops
        The gains, their closed loop's time constant and the options.

    Raises
    ------
    ConfigError
        A gains file that is missing, malformed, or designed for another sample period.
    """
    if gains_path is None:
        return WheelLoops(
            default_pi_gains(vehicle), coulomb_feedforward, symmetric_braking, gentle_stop, steering_priority
        )
    if not gains_path.exists():
        raise ConfigError(source, "controller.pi_gains", f"file not found: {gains_path}")
    settings = load_gains(gains_path)
    if abs(settings.dt_s - vehicle.control.sample_period_s) > 1e-12:
        raise ConfigError(
            str(gains_path),
            "pi.dt_s",
            f"gains designed for {settings.dt_s:g} s, the vehicle samples every {vehicle.control.sample_period_s:g} s",
        )
    design = WheelLoopDesign(settings.gains, closed_loop_time_constant_s(vehicle, settings.gains))
    return WheelLoops(
        design, settings.coulomb_feedforward or coulomb_feedforward, symmetric_braking, gentle_stop, steering_priority
    )
