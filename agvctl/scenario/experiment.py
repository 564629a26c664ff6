"""Experiment files: a trajectory, a vehicle, the simulated truth, the controllers and the limits to check.

```toml
name = "figure8"
trajectory = "../trajectories/figure8.toml"     # relative to this file
vehicle = "default"                             # or a vehicle TOML path (relative to this file)
settle_s = 2.0                                  # extra time after the reference ends (<= 600 s)
[plant]                                         # the simulated truth may differ from the controller's model
set = { "wheels.right.radius_m" = 0.1005, "motor.coulomb_friction_n_m" = 0.08, "motor.stiction_n_m" = 0.09 }
initial_pose = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }
sensor_seed = 0                                 # the true sensors' noise seed (agvctl.sensing)
[controller]
pose = "mpc"            # "mpc" | "nmpc" | "ramsete" | "ltv_lqr" | "none" (a law's C: "ramsete_c"), or yours
compute_delay = "none"  # or "one_sample"
localization = "truth"  # or "odometry" (encoder counts), "ekf" (+ fixes), or yours
wheel_speed = "exact"   # or "count_difference", "kalman" (from the encoder counts), or yours
wheel_loops = "pi"      # the PI loops (pi_gains, coulomb_feedforward, ...), "pi_c" (as C), or yours
horizon = 20            # ...and the pose controller's settings (for the MPCs, controllers.mpc_common.MpcConfig)
[limits]                # agvctl.evaluation.limits.LIMITS; checked by `agvctl check`, reported by `agvctl run`
tracking_error_max_m = 0.03
```

:func:`load_experiment` reads the file once into an :class:`Experiment`: the validated file
(:class:`~agvctl.scenario.spec.ExperimentSpec`), the nominal and true vehicles, the planned reference and the wheel
loops — bad input shows as one line naming the file and key before anything runs. A name of code
(``pose``, ``localization``, ``wheel_speed``, ``wheel_loops``) is a built-in name, an installed package's entry
point or an import reference ``package.module:Name`` (:mod:`agvctl.config.references`); it is resolved again in
every process that loads the file. :func:`run_experiment` builds the controllers (or takes yours) and runs the
closed loop::

    experiment = load_experiment("experiments/line.toml")
    result = run_experiment(experiment, pose_controller=my_controller)
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl.config import build, document_fields, load_toml
from agvctl.config.references import reference_file
from agvctl.controllers.base import PoseController, WheelSpeedController
from agvctl.controllers.pi.options import braking_for
from agvctl.controllers.registry import WheelLoops, design_wheel_loops, pose_controllers
from agvctl.controllers.registry import wheel_loops as wheel_loop_kinds
from agvctl.errors import ConfigError, expect_instance
from agvctl.estimation.registry import pose_estimators, wheel_speed_estimators
from agvctl.params import VehicleParams, default_vehicle_path, load_vehicle
from agvctl.planning import PathSpec, load_path, plan
from agvctl.planning.reference import Reference
from agvctl.scenario.spec import ExperimentSpec
from agvctl.sim.loop import ClosedLoopResult, run_closed_loop

__all__ = ["Experiment", "experiment_from_spec", "load_experiment", "run_experiment"]


@document_fields
@dataclass(frozen=True)
class Experiment:
    """Everything a run needs, loaded and validated once."""

    spec: ExperimentSpec
    """The file, validated; the pose controller's settings completed (written back out as the resolved file)."""
    controller_vehicle: VehicleParams
    """The nominal model the controllers are designed for and know."""
    plant_vehicle: VehicleParams
    """The simulated truth (``[plant] set`` applied)."""
    reference: Reference
    """The planned trajectory."""
    wheel_loops: WheelLoops
    """The PI wheel-speed loops (gains designed or from the gains file)."""
    path: PathSpec | None = None
    """The trajectory file, validated (its explicit limits; None for an experiment built without one)."""
    vehicle_overrides: tuple[str, ...] = ()
    """The ``"KEY=VALUE"`` changes of the vehicle file given on top of the experiment (the command line's
    ``--set``), applied to the controllers' vehicle and so to the plant's."""

    @property
    def input_files(self) -> tuple[Path, ...]:
        """The files the experiment is read from: its own, its trajectory, its vehicle (the shipped one by default)
        and, if it names them, its gains file, its pose controller's settings file and Python files — what a command
        must never write over, and what a check looks at to see whether the experiment changed."""
        spec = self.spec
        c = spec.controller
        files = [Path(spec.source), spec.resolve(spec.trajectory)]
        files.append(default_vehicle_path() if spec.vehicle == "default" else spec.resolve(spec.vehicle))
        if c.pi_gains is not None:
            files.append(spec.resolve(c.pi_gains))
        if c.pose_settings_file is not None:
            files.append(c.pose_settings_file)
        for name in (c.pose, c.wheel_loops, c.localization, c.wheel_speed):
            code = reference_file(name, spec.base_dir)
            if code is not None:
                files.append(code)
        return tuple(files)


def load_experiment(
    path: str | Path, *, vehicle: str | Path | None = None, vehicle_overrides: Sequence[str] = ()
) -> Experiment:
    """Read and validate an experiment file and everything it names: trajectory, vehicles, controller settings.

    Parameters
    ----------
    path : str or Path
        The experiment file (TOML); the paths it names are relative to it.
    vehicle : str, Path or None
        A vehicle file instead of the one the experiment names (relative to the working directory; ``"default"``:
        the shipped IAU AGV; None: the experiment's own).
    vehicle_overrides : sequence of str
        Dotted-key changes of the vehicle, ``"KEY=VALUE"`` (``"wheels.right.radius_m=0.101"``, values in the
        key's unit), as the command line's ``--set`` gives them: the controllers' vehicle changes, and with it the
        plant, which differs from it by the experiment's ``[plant] set``.

    Returns
    -------
    Experiment
        The validated file (``.spec``), the controllers' and the true vehicles (``.controller_vehicle``,
        ``.plant_vehicle``), the planned ``.reference`` and the designed wheel loops, ready for
        :func:`run_experiment`.

    Raises
    ------
    ConfigError
        A one-line message naming the file and key: a missing or unreadable file, an unknown or misspelt key, a
        value out of range, a path that cannot be planned; or naming ``load_experiment: path`` for an argument that
        is not a file name (bytes, a number).

    Examples
    --------
    >>> experiment = load_experiment("experiments/figure8.toml")
    >>> experiment.spec.controller.pose, f"{experiment.reference.duration_s:.1f} s"
    ('mpc', '26.6 s')
    """
    if not isinstance(path, (str, os.PathLike)) or not isinstance(os.fspath(path), str):
        raise ConfigError(
            "load_experiment", "path", f"expected a file name as a str or a Path (got {type(path).__name__})"
        )
    path = Path(path)
    spec = build(ExperimentSpec, load_toml(path), source=str(path))
    spec = dataclasses.replace(spec, source=str(path))
    if vehicle is not None and vehicle != "default":
        if not Path(vehicle).is_file():
            raise ConfigError(str(vehicle), "", "file not found")
        spec = dataclasses.replace(spec, vehicle=str(Path(vehicle).absolute()))
    elif vehicle is not None:
        spec = dataclasses.replace(spec, vehicle="default")
    return experiment_from_spec(spec, vehicle_overrides=vehicle_overrides)


@contextlib.contextmanager
def _read_for(source: str, key: str, path: Path | None) -> Iterator[None]:
    """A file that cannot be read as a whole (not a regular file, too large, not UTF-8 ...) named by the key of
    ``source`` that names it; an error at a key of the file itself names that file."""
    try:
        yield
    except ConfigError as exc:
        if path is None or exc.key or exc.source != str(path):
            raise
        raise ConfigError(source, key, f"{path}: {exc.problem}") from None


def experiment_from_spec(spec: ExperimentSpec, *, vehicle_overrides: Sequence[str] = ()) -> Experiment:
    """An experiment from its validated file: the vehicles (nominal and true) loaded, the reference planned, the
    wheel loops designed and the pose controller's settings completed with them.

    Parameters
    ----------
    spec : ExperimentSpec
        The experiment file, validated (its ``source`` the file, against which its paths are resolved).
    vehicle_overrides : sequence of str
        Dotted-key changes of the vehicle, ``"KEY=VALUE"`` (see :func:`load_experiment`).

    Returns
    -------
    Experiment
        Everything a run needs.

    Raises
    ------
    ConfigError
        A file it names that is missing or invalid, or a path that cannot be planned, naming the experiment file
        and key.
    """
    expect_instance(spec, ExperimentSpec, "experiment_from_spec", "spec")
    src = spec.source
    vehicle_path = None if spec.vehicle == "default" else spec.resolve(spec.vehicle)
    if vehicle_path is not None and not vehicle_path.exists():
        raise ConfigError(src, "vehicle", f"file not found: {vehicle_path}")
    with _read_for(src, "vehicle", vehicle_path):
        controller_vehicle = load_vehicle(vehicle_path, vehicle_overrides)
    plant_vehicle = controller_vehicle.with_overrides(list(spec.plant.set.items()), source=f"{src}: plant.set")
    traj = spec.resolve(spec.trajectory)
    if not traj.exists():
        raise ConfigError(src, "trajectory", f"file not found: {traj}")
    with _read_for(src, "trajectory", traj):
        path = load_path(traj)
    reference = plan(path, controller_vehicle)
    c = spec.controller
    if c.braking is None:  # the path decides: gentle stops where it limits the body's acceleration
        c = dataclasses.replace(c, braking=braking_for(reference.limits.body).value)
    wheel_loops = design_wheel_loops(
        controller_vehicle,
        None if c.pi_gains is None else spec.resolve(c.pi_gains),
        c.wheel_loop_options,
        source=src,
    )
    kind = pose_controllers.resolve(c.pose, source=src, key="controller.pose", base_dir=spec.base_dir)
    if c.pose_settings is None and kind.settings is not None:  # made in Python: the settings' defaults
        c = dataclasses.replace(c, pose_settings=build(kind.settings, {}, source=src, prefix="controller"))
    for key, registry in (
        ("wheel_loops", wheel_loop_kinds),
        ("localization", pose_estimators),
        ("wheel_speed", wheel_speed_estimators),
    ):
        part = registry.resolve(getattr(c, key), source=src, key=f"controller.{key}", base_dir=spec.base_dir)
        if getattr(c, f"{key}_settings") is None and part.settings is not None:
            defaults: Any = build(part.settings, {}, source=src, prefix=f"controller.{key}_settings")
            c = dataclasses.replace(c, **{f"{key}_settings": defaults})
    if kind.fit_wheel_loop is not None:
        c = dataclasses.replace(c, pose_settings=kind.fit_wheel_loop(c.pose_settings, wheel_loops.design))
    spec = dataclasses.replace(spec, controller=c)
    return Experiment(spec, controller_vehicle, plant_vehicle, reference, wheel_loops, path, tuple(vehicle_overrides))


def run_experiment(
    experiment: Experiment,
    *,
    pose_controller: PoseController | None = None,
    wheel_controller: WheelSpeedController | None = None,
    progress: Callable[[float], None] | None = None,
) -> ClosedLoopResult:
    """Run an experiment's closed loop.

    Parameters
    ----------
    experiment : Experiment
        From :func:`load_experiment`.
    pose_controller : PoseController or None
        Your own pose controller (wheel-speed setpoints in m/s, :class:`~agvctl.controllers.base.PoseController`)
        instead of the file's.
    wheel_controller : WheelSpeedController or None
        Your own wheel loops (DA voltages in V, :class:`~agvctl.controllers.base.WheelSpeedController`) instead of
        the file's.
    progress : callable or None
        Called with the fraction done (0…1) about every simulated second.

    Returns
    -------
    ClosedLoopResult
        The log (every signal per sample), the reference, and the wall and setup times in s.
    """
    expect_instance(experiment, Experiment, "run_experiment", "experiment")
    e = experiment
    c = e.spec.controller
    vehicle = e.controller_vehicle
    where: dict[str, Any] = {"source": e.spec.source, "base_dir": e.spec.base_dir}
    if pose_controller is None:
        kind = pose_controllers.resolve(c.pose, key="controller.pose", **where)
        try:
            pose_controller = kind.make(vehicle, c.pose_settings)
        except ConfigError as exc:  # a built-in controller refusing its settings: name the file's key
            if exc.source != getattr(kind.make, "__name__", None):
                raise
            raise ConfigError(e.spec.source, f"controller.{exc.key}", exc.problem) from None
    if wheel_controller is None:
        loops = wheel_loop_kinds.resolve(c.wheel_loops, key="controller.wheel_loops", **where)
        wheel_controller = loops.make(vehicle, c.wheel_loops_settings, e.wheel_loops)
    localization = pose_estimators.resolve(c.localization, key="controller.localization", **where)
    wheel_speed = wheel_speed_estimators.resolve(c.wheel_speed, key="controller.wheel_speed", **where)
    return run_closed_loop(
        plant_vehicle=e.plant_vehicle,
        controller_vehicle=vehicle,
        reference=e.reference,
        pose_controller=pose_controller,
        wheel_controller=wheel_controller,
        initial_pose=e.spec.plant.start_pose(),
        settle_s=e.spec.settle_s,
        compute_delay=c.compute_delay,
        localization=localization.make(vehicle, c.localization_settings),
        wheel_speed=wheel_speed.make(vehicle, c.wheel_speed_settings),
        sensor_seed=e.spec.plant.sensor_seed,
        payload=e.spec.payload,
        progress=progress,
    )
