"""Experiment files: a trajectory, a vehicle, the simulated truth, the controllers and the limits to check.

```toml
name = "figure8"
trajectory = "../trajectories/figure8.toml"     # relative to this file
vehicle = "default"                             # or a vehicle TOML path (relative to this file)
settle_s = 2.0                                  # extra time after the reference ends
[plant]                                         # the simulated truth may differ from the controller's model
set = { "wheels.radius_right_m" = 0.1005, "motor.coulomb_friction_n_m" = 0.08, "motor.stiction_n_m" = 0.09 }
initial_pose = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }
[controller]
pose = "mpc"            # "mpc" | "nmpc" | "none" (reference feed-forward only)
compute_delay = "none"  # or "one_sample"
localization = "truth"  # or "odometry" (wheel encoders, the controller's geometry)
horizon = 20            # ...and the other MPC settings of agvctl.controllers.mpc_common.MpcConfig
[limits]                # checked by `agvctl check`; `agvctl run` reports them
tracking_error_max_m = 0.03
```

:func:`load_experiment` validates everything (one-line errors naming the file and key) before anything runs;
:func:`run_experiment` plans the reference, builds the controllers and runs the closed loop.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from agvctl.config import build, build_fields, did_you_mean, join_key, load_toml, number
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams, load_vehicle
from agvctl.planning import load_path, plan
from agvctl.planning.reference import Reference
from agvctl.sim.loop import ClosedLoopResult, ComputeDelay, run_closed_loop

Localization = Literal["truth", "odometry"]

__all__ = [
    "ControllerSpec",
    "Experiment",
    "InitialPose",
    "LimitsSpec",
    "PlantSpec",
    "RobustnessSpec",
    "Spread",
    "load_experiment",
    "prepare_experiment",
    "run_experiment",
]


@dataclass(frozen=True)
class InitialPose:
    x_m: float = number(default=0.0)
    y_m: float = number(default=0.0)
    theta_deg: float = number(default=0.0)


@dataclass(frozen=True)
class PlantSpec:
    """The simulated truth: dotted-key overrides of the vehicle, and where the vehicle starts."""

    set: dict[str, Any] = dataclasses.field(default_factory=dict)
    initial_pose: InitialPose | None = None

    @classmethod
    def __from_file__(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> PlantSpec:
        for k in data:
            if k not in ("set", "initial_pose"):
                raise ConfigError(
                    source, join_key(prefix, k), "unknown key" + did_you_mean(k, ["set", "initial_pose"], [prefix])
                )
        sets = data.get("set", {})
        if not isinstance(sets, Mapping):
            raise ConfigError(source, join_key(prefix, "set"), "expected a table of dotted vehicle keys")
        pose = data.get("initial_pose")
        return cls(
            set=dict(sets),
            initial_pose=None
            if pose is None
            else build(InitialPose, pose, source=source, prefix=join_key(prefix, "initial_pose")),
        )


@dataclass(frozen=True)
class LimitsSpec:
    """What ``agvctl check`` enforces (all optional). Values are upper bounds."""

    wheel_speed_m_s: float | None = number(gt=0, default=None)
    wheel_accel_m_s2: float | None = number(gt=0, default=None)
    motor_current_a: float | None = number(gt=0, default=None)
    current_limited_fraction: float | None = number(ge=0, le=1, default=None)
    da_saturation_fraction: float | None = number(ge=0, le=1, default=None)
    tracking_error_max_m: float | None = number(gt=0, default=None)
    tracking_error_rms_m: float | None = number(gt=0, default=None)
    heading_error_max_deg: float | None = number(gt=0, default=None)
    final_position_error_m: float | None = number(gt=0, default=None)
    solve_time_p99_ms: float | None = number(gt=0, default=None)
    deadline_misses: int | None = number(ge=0, default=None)
    solver_failures: int | None = number(ge=0, default=None)

    def items(self) -> list[tuple[str, float]]:
        """The limits that are set, as (key, bound)."""
        return [
            (f.name, float(getattr(self, f.name)))
            for f in dataclasses.fields(self)
            if getattr(self, f.name) is not None
        ]


PoseKind = Literal["mpc", "nmpc", "none"]
_RUNNER_KEYS = (
    "pose",
    "compute_delay",
    "localization",
    "pi_gains",
    "coulomb_feedforward",
    "symmetric_braking",
    "gentle_stop",
)


@dataclass(frozen=True)
class ControllerSpec:
    """The controllers of an experiment. Keys other than the runner's go to the pose controller's config."""

    pose: PoseKind = "mpc"
    compute_delay: ComputeDelay = "none"
    localization: Localization = "truth"
    pi_gains: str | None = None
    """A gains file written by ``agvctl tune --out`` (relative to the experiment); default: tuned on the fly."""
    coulomb_feedforward: bool = False
    """Add the Coulomb-friction voltage τ_c R/k_t to the PI output (ramped in near zero speed)."""
    symmetric_braking: bool = False
    """Limit the braking current so that friction-assisted braking decelerates no harder than a_lim."""
    gentle_stop: bool = False
    """Limit the braking current only in the last sample before a wheel stops."""
    pose_settings: dict[str, Any] = dataclasses.field(default_factory=dict, metadata={"derived": True})

    @classmethod
    def __from_file__(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> ControllerSpec:
        runner = {k: v for k, v in data.items() if k in _RUNNER_KEYS}
        rest = {k: v for k, v in data.items() if k not in _RUNNER_KEYS}
        base: ControllerSpec = build_fields(cls, runner, source=source, prefix=prefix)
        spec = dataclasses.replace(base, pose_settings=rest)
        _pose_config(spec, source, prefix)  # validate the pose controller's settings now, before anything runs
        return spec


def _pose_config(spec: ControllerSpec, source: str, prefix: str) -> Any:
    """The pose controller's config built strictly from the experiment's remaining ``[controller]`` keys."""
    if spec.pose == "none":
        if spec.pose_settings:
            key = next(iter(spec.pose_settings))
            raise ConfigError(
                source, join_key(prefix, key), 'not used with pose = "none"' + did_you_mean(key, _RUNNER_KEYS, [prefix])
            )
        return None
    from agvctl.controllers.mpc_common import MpcConfig

    return build(MpcConfig, spec.pose_settings, source=source, prefix=prefix)


@dataclass(frozen=True)
class Spread:
    """How one vehicle value varies across Monte Carlo samples, relative to its nominal value."""

    kind: Literal["uniform", "normal"]
    relative: float
    """Half-width of the uniform interval (value · (1 ± relative)) or the Gaussian sigma (value · (1 + N(0, σ)))."""


@dataclass(frozen=True)
class RobustnessSpec:
    """``[robustness]``: Monte Carlo over the plant's parameters (the controller keeps the nominal model)."""

    samples: int = number(ge=1, le=100000, default=100)
    seed: int = number(ge=0, default=0)
    spread: dict[str, Spread] = dataclasses.field(default_factory=dict)

    @classmethod
    def __from_file__(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> RobustnessSpec:
        plain = {k: v for k, v in data.items() if k != "spread"}
        base: RobustnessSpec = build_fields(cls, plain, source=source, prefix=prefix)
        raw = data.get("spread", {})
        if not isinstance(raw, Mapping):
            raise ConfigError(source, join_key(prefix, "spread"), "expected a table of dotted vehicle keys")
        spreads: dict[str, Spread] = {}
        for key, value in raw.items():
            where = f"{join_key(prefix, 'spread')}.{key}"
            if isinstance(value, Mapping):
                if list(value) != ["normal"]:
                    raise ConfigError(source, where, "expected a relative half-width (uniform) or { normal = SIGMA }")
                kind, rel = "normal", value["normal"]
            else:
                kind, rel = "uniform", value
            if isinstance(rel, bool) or not isinstance(rel, (int, float)) or not math.isfinite(rel) or rel < 0:
                raise ConfigError(source, where, f"must be a finite relative spread >= 0 (got {rel!r})")
            if kind == "uniform" and rel >= 1:
                raise ConfigError(source, where, f"a uniform spread of ±{rel:g} would reach zero or below; use < 1")
            spreads[str(key)] = Spread(kind, float(rel))  # type: ignore[arg-type]
        return dataclasses.replace(base, spread=spreads)

    def __to_file__(self) -> dict[str, Any]:
        spread: dict[str, Any] = {
            k: (v.relative if v.kind == "uniform" else {"normal": v.relative}) for k, v in self.spread.items()
        }
        return {"samples": self.samples, "seed": self.seed, "spread": spread}


@dataclass(frozen=True)
class Experiment:
    """An experiment file, validated. Paths are resolved relative to the file."""

    name: str
    trajectory: str
    vehicle: str = "default"
    settle_s: float = number(ge=0, default=2.0)
    plant: PlantSpec = dataclasses.field(default_factory=PlantSpec)
    controller: ControllerSpec = dataclasses.field(default_factory=ControllerSpec)
    limits: LimitsSpec = dataclasses.field(default_factory=LimitsSpec)
    robustness: RobustnessSpec | None = None
    source: str = dataclasses.field(default="<experiment>", metadata={"derived": True})

    @property
    def base_dir(self) -> Path:
        return Path(self.source).parent

    def resolve(self, relative: str) -> Path:
        path = Path(relative)
        return path if path.is_absolute() else self.base_dir / path


def load_experiment(path: str | Path) -> Experiment:
    """Read and validate an experiment file, including its trajectory, vehicles and controller settings."""
    path = Path(path)
    exp = build(Experiment, load_toml(path), source=str(path))
    exp = dataclasses.replace(exp, source=str(path))
    prepare_experiment(exp)  # loads every file it names, so bad input shows before anything runs
    return exp


@dataclass(frozen=True)
class PreparedExperiment:
    """Everything an experiment needs to run, loaded and validated."""

    experiment: Experiment
    controller_vehicle: VehicleParams
    plant_vehicle: VehicleParams
    reference: Reference


def prepare_experiment(exp: Experiment) -> PreparedExperiment:
    """Load the vehicle (nominal and true), plan the reference. Errors name the experiment file and key."""
    src = exp.source
    vehicle_path = None if exp.vehicle == "default" else exp.resolve(exp.vehicle)
    if vehicle_path is not None and not vehicle_path.exists():
        raise ConfigError(src, "vehicle", f"file not found: {vehicle_path}")
    controller_vehicle = load_vehicle(vehicle_path)
    plant_vehicle = controller_vehicle.with_overrides(list(exp.plant.set.items()), source=f"{src}: plant.set")
    traj = exp.resolve(exp.trajectory)
    if not traj.exists():
        raise ConfigError(src, "trajectory", f"file not found: {traj}")
    reference = plan(load_path(traj), controller_vehicle)
    return PreparedExperiment(exp, controller_vehicle, plant_vehicle, reference)


def initial_pose_of(exp: Experiment) -> tuple[float, float, float] | None:
    """The true start pose (x_m, y_m, theta_rad) of ``[plant] initial_pose``; None: the reference's start."""
    pose = exp.plant.initial_pose
    if pose is None:
        return None
    return (pose.x_m, pose.y_m, math.radians(pose.theta_deg))


def run_experiment(
    exp: Experiment | PreparedExperiment,
    *,
    progress: Callable[[float], None] | None = None,
) -> ClosedLoopResult:
    """Run an experiment's closed loop (plan, build the controllers, simulate)."""
    from agvctl.sim.controllers import build_controllers

    prepared = exp if isinstance(exp, PreparedExperiment) else prepare_experiment(exp)
    e = prepared.experiment
    pose_ctrl, wheel_ctrl = build_controllers(e, prepared.controller_vehicle)
    return run_closed_loop(
        plant_vehicle=prepared.plant_vehicle,
        controller_vehicle=prepared.controller_vehicle,
        reference=prepared.reference,
        pose_controller=pose_ctrl,
        wheel_controller=wheel_ctrl,
        initial_pose=initial_pose_of(e),
        settle_s=e.settle_s,
        compute_delay=e.controller.compute_delay,
        localization=e.controller.localization,
        progress=progress,
    )
