"""The estimators an experiment can name: pose estimators by ``[controller] localization``, wheel-speed estimators
by ``[controller] wheel_speed``.

Each is a :class:`~agvctl.config.references.Registry`: a built-in name (:data:`ESTIMATORS`,
:data:`WHEEL_SPEED_ESTIMATORS`, each built from the controller's vehicle), the name an installed package registers
under the entry-point group ``agvctl.pose_estimators`` (``agvctl.wheel_speed_estimators``), or an import reference
``package.module:Name`` (or ``file.py:Name``, relative to the file naming it). A user's ``Name`` is a class or a
factory called as ``Name(vehicle, settings)``; its ``Settings`` dataclass, if it has one, is built from
``[controller.localization_settings]`` (``[controller.wheel_speed_settings]``), otherwise ``settings`` is None.
What a user's estimator returns is checked each sample (a pose of 3 finite numbers, 2 finite motor speeds): anything
else stops that run with a one-line error naming it. The built-in estimators are not wrapped.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.config.references import Registry, checked_vector, describe_plugin, made_by, plugin_settings
from agvctl.estimation.base import PoseEstimator, WheelSpeedEstimator
from agvctl.estimation.ekf import PoseEkf
from agvctl.estimation.odometry import OdometryEstimator, TruthEstimator
from agvctl.estimation.wheel_speed import CountDifference, ExactSpeed, KalmanWheelSpeed
from agvctl.params import VehicleParams
from agvctl.sensing import Measurements

__all__ = [
    "ESTIMATORS",
    "WHEEL_SPEED_ESTIMATORS",
    "CheckedPoseEstimator",
    "CheckedWheelSpeedEstimator",
    "EstimatorKind",
    "pose_estimators",
    "wheel_speed_estimators",
]

E = TypeVar("E")

ESTIMATORS: dict[str, Callable[[VehicleParams], PoseEstimator]] = {
    "truth": TruthEstimator,
    "odometry": OdometryEstimator,
    "ekf": PoseEkf,
}
"""The built-in estimators an experiment's ``[controller] localization`` can name, each built from the controller's
vehicle (entries of :data:`pose_estimators`)."""

WHEEL_SPEED_ESTIMATORS: dict[str, Callable[[VehicleParams], WheelSpeedEstimator]] = {
    "exact": ExactSpeed,
    "count_difference": CountDifference,
    "kalman": KalmanWheelSpeed,
}
"""The built-in wheel-speed estimators an experiment's ``[controller] wheel_speed`` can name, built from the
controller's vehicle (entries of :data:`wheel_speed_estimators`)."""


@document_fields
@dataclass(frozen=True)
class EstimatorKind(Generic[E]):
    """One entry of :data:`pose_estimators` or :data:`wheel_speed_estimators`."""

    make: Callable[[VehicleParams, Any], E]
    """``make(vehicle, settings)``: the estimator on the controller's vehicle."""
    settings: type | None
    """The dataclass its settings table is built into (None: it takes none)."""
    description: str
    """What it is, in a few words."""


class _Builtins(Mapping[str, EstimatorKind[E]]):
    """A built-in table (name → ``Estimator(vehicle)``) seen as registry entries, read at each lookup."""

    def __init__(self, table: Mapping[str, Callable[[VehicleParams], E]]) -> None:
        self.table = table

    def __getitem__(self, name: str) -> EstimatorKind[E]:
        build = self.table[name]
        return EstimatorKind(lambda vehicle, settings: build(vehicle), None, describe_plugin(build, name))

    def __iter__(self) -> Iterator[str]:
        return iter(self.table)

    def __len__(self) -> int:
        return len(self.table)


class CheckedPoseEstimator:
    """A user's pose estimator, each estimate checked: 3 finite numbers (x_m, y_m, theta_rad), or the run stops
    with a one-line error naming it. Every other attribute is the estimator's own.

    Parameters
    ----------
    inner : PoseEstimator
        The user's estimator.
    name : str
        Its name or reference, as the file gives it.
    """

    def __init__(self, inner: PoseEstimator, name: str) -> None:
        self.inner = inner
        self.name = name

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.inner, attribute)

    def reset(self, pose: NDArray[np.float64]) -> None:
        """The estimator's own ``reset``."""
        self.inner.reset(pose)

    def update(self, measurements: Measurements) -> NDArray[np.float64]:
        """The estimator's own estimate, checked."""
        return checked_vector(self.inner.update(measurements), 3, f"pose estimator {self.name!r}")


class CheckedWheelSpeedEstimator:
    """A user's wheel-speed estimator, each estimate checked: 2 finite motor speeds (left, right) in rad/s, or the
    run stops with a one-line error naming it. Every other attribute is the estimator's own.

    Parameters
    ----------
    inner : WheelSpeedEstimator
        The user's estimator.
    name : str
        Its name or reference, as the file gives it.
    """

    def __init__(self, inner: WheelSpeedEstimator, name: str) -> None:
        self.inner = inner
        self.name = name

    def __getattr__(self, attribute: str) -> Any:
        return getattr(self.inner, attribute)

    def reset(self) -> None:
        """The estimator's own ``reset``."""
        self.inner.reset()

    def update(self, encoder_counts: NDArray[np.int64]) -> NDArray[np.float64]:
        """The estimator's own speeds, checked."""
        speeds = self.inner.update(encoder_counts)
        return checked_vector(speeds, 2, f"wheel-speed estimator {self.name!r}")

    def applied(self, da_command_v: NDArray[np.float64]) -> None:
        """The estimator's own ``applied``."""
        self.inner.applied(da_command_v)


def _kind(
    methods: tuple[str, ...], protocol: str, wrap: Callable[[Any, str], E]
) -> Callable[[Any, str], EstimatorKind[E]]:
    def from_object(obj: Any, name: str) -> EstimatorKind[E]:
        if isinstance(obj, EstimatorKind):
            return obj
        settings = plugin_settings(obj, methods, protocol)

        def make(vehicle: VehicleParams, s: Any) -> E:
            return wrap(made_by(obj, vehicle, s, name, methods), name)

        return EstimatorKind(make, settings, describe_plugin(obj, name))

    return from_object


pose_estimators: Registry[EstimatorKind[PoseEstimator]] = Registry(
    "agvctl.pose_estimators",
    "a pose estimator",
    _Builtins(ESTIMATORS),
    _kind(("reset", "update"), "PoseEstimator", CheckedPoseEstimator),
)
"""Every pose estimator ``[controller] localization`` can name: the built-in ones, installed packages' (group
``agvctl.pose_estimators``) and import references."""

wheel_speed_estimators: Registry[EstimatorKind[WheelSpeedEstimator]] = Registry(
    "agvctl.wheel_speed_estimators",
    "a wheel-speed estimator",
    _Builtins(WHEEL_SPEED_ESTIMATORS),
    _kind(("reset", "update", "applied"), "WheelSpeedEstimator", CheckedWheelSpeedEstimator),
)
"""Every wheel-speed estimator ``[controller] wheel_speed`` can name: the built-in ones, installed packages' (group
``agvctl.wheel_speed_estimators``) and import references."""
