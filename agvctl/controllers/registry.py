"""The controllers an experiment can name: the pose controllers by ``[controller] pose``, the wheel loops by
``[controller] wheel_loops``.

Each is a :class:`~agvctl.config.references.Registry`: a built-in name (:data:`POSE_CONTROLLERS`,
:data:`WHEEL_LOOPS`), the name an installed package registers under the entry-point group
``agvctl.pose_controllers`` (``agvctl.wheel_loops``), or an import reference ``package.module:Name`` (or
``file.py:Name``, relative to the file naming it). A user's ``Name`` is a class or a factory called as
``Name(vehicle, settings)`` with the controller's vehicle; if it has a ``Settings`` dataclass attribute, the file's
keys are built strictly into it (for a pose controller the ``[controller]`` table's remaining keys, for wheel loops
the ``[controller.wheel_loops_settings]`` table), otherwise ``settings`` is None. What a user's controller returns
is checked each sample (:class:`CheckedPoseController`, :class:`CheckedWheelController`): a command that is not one,
or not finite, stops that run with a one-line error naming the controller. The built-in entries are not wrapped.

``run``, ``check``, ``fuzz`` and ``tune`` resolve the same string in every process, so a worker builds the same
controller from the file it reads.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.config.references import Registry, checked_vector, describe_plugin, made_by, plugin_settings
from agvctl.controllers.base import PoseCommand, PoseController, WheelSpeedController
from agvctl.controllers.baselines.c_unicycle import COMPILED_LAWS
from agvctl.controllers.baselines.feedforward import FeedForwardPoseController
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig, LtvLqrController
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController
from agvctl.controllers.mpc.config import MpcConfig, check_ltv_settings, check_nmpc_settings
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.mpc.nonlinear import NonlinearMpcController
from agvctl.controllers.pi.c_loops import CompiledPIWheelController
from agvctl.controllers.pi.gains_file import load_gains
from agvctl.controllers.pi.options import WheelLoopOptions
from agvctl.controllers.pi.tuning import WheelLoopDesign, closed_loop_time_constant_s, default_pi_gains
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams

__all__ = [
    "POSE_CONTROLLERS",
    "WHEEL_LOOPS",
    "CheckedPoseController",
    "CheckedWheelController",
    "PoseControllerKind",
    "WheelLoopDesign",
    "WheelLoopKind",
    "WheelLoops",
    "default_pi_gains",
    "design_wheel_loops",
    "pose_controllers",
    "wheel_loops",
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
    check: Callable[[Any], None] | None = None
    """What the controller asks of its settings beyond each field's range, raising a
    :class:`~agvctl.errors.ConfigError` that names the key: run where a file's settings are read, so a bad
    combination is refused before any run."""


def _mpc_wheel_loop(config: MpcConfig, wheel: WheelLoopDesign) -> MpcConfig:
    """The MPC predicts the wheel loops as first-order lags: unless set, the best fit to the experiment's own."""
    if config.wheel_loop_time_constant_s is not None:
        return config
    return dataclasses.replace(config, wheel_loop_time_constant_s=wheel.loop_time_constant_s)


POSE_CONTROLLERS: dict[str, PoseControllerKind] = {
    "mpc": PoseControllerKind(
        LtvMpcController, MpcConfig, "linear time-varying MPC on OSQP", _mpc_wheel_loop, check_ltv_settings
    ),
    "nmpc": PoseControllerKind(
        NonlinearMpcController, MpcConfig, "nonlinear MPC on CasADi/IPOPT", _mpc_wheel_loop, check_nmpc_settings
    ),
    "ramsete": PoseControllerKind(RamseteController, RamseteConfig, "WPILib's Ramsete unicycle law (yardstick)"),
    "ltv_lqr": PoseControllerKind(LtvLqrController, LtvLqrConfig, "WPILib's LTV unicycle LQR (yardstick)"),
    "none": PoseControllerKind(
        lambda vehicle, settings: FeedForwardPoseController(), None, "the reference's feed-forward only"
    ),
}
POSE_CONTROLLERS.update(
    {
        f"{name}_c": PoseControllerKind(
            law.compiled,
            law.settings,
            f"{POSE_CONTROLLERS[name].description.removesuffix(' (yardstick)')} as generated C99, called through "
            "ctypes (software-in-the-loop)",
        )
        for name, law in COMPILED_LAWS.items()
    }
)
"""The built-in pose controllers by the name an experiment's ``[controller] pose`` gives (entries of
:data:`pose_controllers`); a unicycle law's C is ``"<name>_c"``
(:data:`~agvctl.controllers.baselines.c_unicycle.COMPILED_LAWS`)."""


class CheckedPoseController:
    """A user's pose controller, each command it returns checked: a :class:`~agvctl.controllers.base.PoseCommand`
    with finite float wheel speeds, or the run stops with a one-line error naming the controller and what it
    returned. Every other attribute is the controller's own.

    Parameters
    ----------
    inner : PoseController
        The user's controller.
    name : str
        Its name or reference, as the file gives it.
    """

    def __init__(self, inner: PoseController, name: str) -> None:
        self.inner = inner
        self.name = name

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.inner, attribute)

    def reset(self, reference: Any) -> None:
        """The controller's own ``reset``."""
        self.inner.reset(reference)

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """The controller's own command, checked."""
        command = self.inner.update(t_s, pose, wheel_speed_m_s)
        if not isinstance(command, PoseCommand):
            shape = f" of shape {np.shape(command)}" if isinstance(command, np.ndarray) else ""
            raise TypeError(
                f"pose controller {self.name!r} returned a {type(command).__name__}{shape} at t = {t_s:.2f} s, "
                "not a PoseCommand"
            )
        for field in ("wheel_speed_left_m_s", "wheel_speed_right_m_s"):
            value = getattr(command, field)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                shape = f" of shape {np.shape(value)}" if isinstance(value, np.ndarray) else ""
                raise TypeError(
                    f"pose controller {self.name!r} returned {field} = a {type(value).__name__}{shape} at "
                    f"t = {t_s:.2f} s, not a float"
                )
            if not math.isfinite(value):
                raise ValueError(f"pose controller {self.name!r} returned {field} = {value} at t = {t_s:.2f} s")
        return command


_POSE_METHODS = ("reset", "update")


def _pose_kind(obj: Any, name: str) -> PoseControllerKind:
    """The entry for a user's pose controller (or a package's own :class:`PoseControllerKind`)."""
    if isinstance(obj, PoseControllerKind):
        return obj
    settings = plugin_settings(obj, _POSE_METHODS, "PoseController")

    def make(vehicle: VehicleParams, s: Any) -> PoseController:
        return CheckedPoseController(made_by(obj, vehicle, s, name, _POSE_METHODS), name)

    return PoseControllerKind(make, settings, describe_plugin(obj, name))


pose_controllers: Registry[PoseControllerKind] = Registry(
    "agvctl.pose_controllers", "a pose controller", POSE_CONTROLLERS, _pose_kind
)
"""Every pose controller an experiment's ``[controller] pose`` or a fuzz file's ``controllers`` can name: the
built-in ones, installed packages' (entry-point group ``agvctl.pose_controllers``) and import references."""


@document_fields
@dataclass(frozen=True)
class WheelLoops:
    """An experiment's PI wheel-speed loops: the gains (designed, or from a gains file) and their options, as
    :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController` takes them."""

    design: WheelLoopDesign
    """The gains and the time constant of the first-order lag that best fits their closed loop."""
    options: WheelLoopOptions = WheelLoopOptions()
    """The loops' choices."""

    def controller(self, vehicle: VehicleParams) -> PIWheelController:
        """The wheel-speed controller on ``vehicle`` (the controller's model)."""
        return PIWheelController(vehicle, self.design.gains, self.options)


def design_wheel_loops(
    vehicle: VehicleParams,
    gains_path: Path | None,
    options: WheelLoopOptions | None = None,
    *,
    source: str,
) -> WheelLoops:
    """An experiment's wheel loops: from a gains file, or designed for the default spec.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's vehicle.
    gains_path : Path or None
        A gains file written by ``agvctl tune --out`` (None: design the gains for the default spec).
    options : WheelLoopOptions or None
        The loops' choices (None: their defaults). A gains file that records the feed-forward its gains were
        verified with must agree with them.
    source : str
        The experiment file, as errors name it.

    Returns
    -------
    WheelLoops
        The gains, their closed loop's time constant and the options.

    Raises
    ------
    ConfigError
        A gains file that is missing, malformed, designed for another sample period, or verified with another
        feed-forward setting than ``options``.
    """
    options = WheelLoopOptions() if options is None else options
    if gains_path is None:
        return WheelLoops(default_pi_gains(vehicle), options)
    if not gains_path.exists():
        raise ConfigError(source, "controller.pi_gains", f"file not found: {gains_path}")
    settings = load_gains(gains_path)
    if abs(settings.dt_s - vehicle.control.sample_period_s) > 1e-12:
        raise ConfigError(
            str(gains_path),
            "pi.dt_s",
            f"gains designed for {settings.dt_s:g} s, the vehicle samples every {vehicle.control.sample_period_s:g} s",
        )
    recorded = settings.coulomb_feedforward
    if recorded is not None and recorded != options.coulomb_feedforward:
        raise ConfigError(
            str(gains_path),
            "pi.coulomb_feedforward",
            f"the gains were verified with coulomb_feedforward = {str(recorded).lower()}, the experiment's "
            f"controller.coulomb_feedforward is {str(options.coulomb_feedforward).lower()}: make them agree",
        )
    design = WheelLoopDesign(settings.gains, closed_loop_time_constant_s(vehicle, settings.gains))
    return WheelLoops(design, options)


@document_fields
@dataclass(frozen=True)
class WheelLoopKind:
    """One entry of :data:`wheel_loops`."""

    make: Callable[[VehicleParams, Any, WheelLoops], WheelSpeedController]
    """``make(vehicle, settings, designed)``: the wheel-speed loops on the controller's vehicle (``designed``: the
    experiment's PI design, which the built-in loops use)."""
    settings: type | None
    """The dataclass ``[controller.wheel_loops_settings]`` is built into (None: the loops take none)."""
    description: str
    """What the loops are, in a few words."""


class CheckedWheelController:
    """A user's wheel-speed loops, each output checked: two finite DA voltages (left, right), or the run stops
    with a one-line error naming the loops and what they returned. Every other attribute is the loops' own.

    Parameters
    ----------
    inner : WheelSpeedController
        The user's loops.
    name : str
        Their name or reference, as the file gives it.
    """

    def __init__(self, inner: WheelSpeedController, name: str) -> None:
        self.inner = inner
        self.name = name

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.inner, attribute)

    def reset(self) -> None:
        """The loops' own ``reset``."""
        self.inner.reset()

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """The loops' own DA voltages, checked."""
        return checked_vector(self.inner.update(setpoint_rad_s, measured_rad_s), 2, f"wheel loops {self.name!r}")


_WHEEL_METHODS = ("reset", "update")


def _wheel_kind(obj: Any, name: str) -> WheelLoopKind:
    """The entry for a user's wheel loops."""
    if isinstance(obj, WheelLoopKind):
        return obj
    settings = plugin_settings(obj, _WHEEL_METHODS, "WheelSpeedController")

    def make(vehicle: VehicleParams, s: Any, designed: WheelLoops) -> WheelSpeedController:
        del designed
        return CheckedWheelController(made_by(obj, vehicle, s, name, _WHEEL_METHODS), name)

    return WheelLoopKind(make, settings, describe_plugin(obj, name))


WHEEL_LOOPS: dict[str, WheelLoopKind] = {
    "pi": WheelLoopKind(
        lambda vehicle, settings, designed: designed.controller(vehicle),
        None,
        "PI speed loops per motor (gains designed, or from [controller] pi_gains)",
    ),
    "pi_c": WheelLoopKind(
        lambda vehicle, settings, designed: CompiledPIWheelController(vehicle, designed.design.gains, designed.options),
        None,
        "the same PI loops as generated C99, compiled and called through ctypes (software-in-the-loop)",
    ),
}
"""The built-in wheel loops by the name an experiment's ``[controller] wheel_loops`` gives (entries of
:data:`wheel_loops`)."""

wheel_loops: Registry[WheelLoopKind] = Registry("agvctl.wheel_loops", "wheel loops", WHEEL_LOOPS, _wheel_kind)
"""Every wheel-speed loop ``[controller] wheel_loops`` can name: the built-in ``pi`` and ``pi_c`` (the same loops
as generated C), installed packages' (group
``agvctl.wheel_loops``) and import references."""
