"""The experiment file's schema, validated strictly (one-line errors naming the file and key).

See :mod:`agvctl.scenario.experiment` for the file format; this module holds its tables as frozen dataclasses, which
:func:`agvctl.config.to_dict` writes back out as the resolved ``experiment.toml`` of a run.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from agvctl.config import (
    build,
    build_fields,
    check_fields,
    check_plain_name,
    convert_value,
    did_you_mean,
    document_fields,
    join_key,
    number,
    to_dict,
)
from agvctl.config.references import Registry
from agvctl.controllers.pi.options import Braking, WheelLoopOptions
from agvctl.controllers.registry import POSE_CONTROLLERS, pose_controllers, wheel_loops
from agvctl.errors import ConfigError
from agvctl.estimation.registry import pose_estimators, wheel_speed_estimators
from agvctl.evaluation.limits import LimitsSpec
from agvctl.evaluation.path_metrics import PATH_LOG_COLUMNS
from agvctl.evaluation.payload import PAYLOAD_LOG_COLUMNS, PayloadAccelerometer
from agvctl.evaluation.requirements import RequirementSpec, check_requirement_names
from agvctl.log import PLANT_LOG_COLUMNS
from agvctl.planning.spec import StartPose
from agvctl.scenario.pose_settings import load_pose_settings, merged_settings
from agvctl.sim.loop import CONTROL_LOG_COLUMNS, MAX_INITIAL_POSE, ComputeDelay

__all__ = ["ControllerSpec", "ExperimentSpec", "PlantSpec", "RobustnessSpec", "Spread"]

_LOOPS = WheelLoopOptions()
"""The wheel loops' defaults, which the ``[controller]`` keys for them take."""

BrakingName = Literal["full", "symmetric", "gentle_stop"]
"""The names of :class:`~agvctl.controllers.pi.options.Braking`'s values, as files give them."""


@document_fields
@dataclass(frozen=True)
class PlantSpec:
    """``[plant]``: the simulated truth, as dotted-key overrides of the vehicle, and where the vehicle starts."""

    set: dict[str, Any] = dataclasses.field(default_factory=dict)
    """The true vehicle's differences from the controller's, by dotted key (``"wheels.left.radius_m" = 0.101``),
    each in the unit of its key."""
    initial_pose: StartPose | None = None
    """Where the vehicle starts (None: the reference's start)."""
    sensor_seed: int = number(ge=0, default=0)
    """The seed of the true vehicle's sensor noise (encoder phases, gyro, fixes)."""

    def __post_init__(self) -> None:
        check_fields(self)

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> PlantSpec:
        keys = ["set", "initial_pose", "sensor_seed"]
        for k in data:
            if k not in keys:
                raise ConfigError(source, join_key(prefix, k), "unknown key" + did_you_mean(k, keys, [prefix]))
        sets = data.get("set", {})
        if not isinstance(sets, Mapping):
            raise ConfigError(source, join_key(prefix, "set"), "expected a table of dotted vehicle keys")
        pose = data.get("initial_pose")
        if pose is not None:
            _check_initial_pose(pose, source, join_key(prefix, "initial_pose"))
        seed = convert_value(int, data.get("sensor_seed", 0), source, join_key(prefix, "sensor_seed"), {"ge": 0})
        return cls(
            sensor_seed=seed,
            set=dict(sets),
            initial_pose=None
            if pose is None
            else build(StartPose, pose, source=source, prefix=join_key(prefix, "initial_pose")),
        )

    def start_pose(self) -> tuple[float, float, float] | None:
        """The true start pose (x_m, y_m, theta_rad); None: the reference's start."""
        pose = self.initial_pose
        return None if pose is None else (pose.x_m, pose.y_m, math.radians(pose.theta_deg))


def _check_initial_pose(pose: Any, source: str, key: str) -> None:
    """Refuse an initial pose beyond :data:`~agvctl.sim.loop.MAX_INITIAL_POSE` (m; rad for the heading), naming
    its key, before the run is set up."""
    pose = build(StartPose, pose, source=source, prefix=key)
    for name, value in (("x_m", pose.x_m), ("y_m", pose.y_m), ("theta_deg", math.radians(pose.theta_deg))):
        if abs(value) > MAX_INITIAL_POSE:
            bound = f"{math.degrees(MAX_INITIAL_POSE):.6g}°" if name == "theta_deg" else f"{MAX_INITIAL_POSE:g} m"
            shown = getattr(pose, name)
            raise ConfigError(source, f"{key}.{name}", f"must be within ±{bound} (got {shown:g})")


_PARTS: dict[str, Registry[Any]] = {
    "wheel_loops": wheel_loops,
    "localization": pose_estimators,
    "wheel_speed": wheel_speed_estimators,
}
"""The ``[controller]`` keys naming code other than the pose controller, each with its registry; a user's entry's
settings are the table ``[controller.<key>_settings]``."""


def _part_settings(key: str, name: str, table: Any, base_dir: Path | None, source: str, prefix: str) -> Any:
    """The settings of the code ``[controller] <key>`` names, built from its ``<key>_settings`` table (None: the
    defaults; no table and no ``Settings``: None)."""
    where = join_key(prefix, f"{key}_settings")
    settings = _PARTS[key].resolve(name, source=source, key=join_key(prefix, key), base_dir=base_dir).settings
    if settings is None:
        if table is not None:
            raise ConfigError(source, where, f"{key} = {name!r} takes no settings")
        return None
    if table is not None and not isinstance(table, Mapping):
        raise ConfigError(source, where, "expected a table of settings")
    return build(settings, dict(table or {}), source=source, prefix=where)


def _with_settings_file(
    name: Any, pose: str, settings: type | None, rest: Mapping[str, Any], source: str, prefix: str
) -> tuple[dict[str, Any], Path]:
    """``rest`` over the keys of the settings file ``name`` (``[controller] pose_settings``, relative to the
    experiment file), which are checked on their own first so that their errors name the settings file; and that
    file."""
    key = join_key(prefix, "pose_settings")
    if not isinstance(name, str) or not name:
        raise ConfigError(source, key, f"expected the name of a settings file (got {name!r})")
    if settings is None:
        raise ConfigError(source, key, f"pose = {pose!r} takes no settings")
    path = Path(name) if Path(name).is_absolute() else Path(source).parent / name
    keys = load_pose_settings(path, pose, source=source, key=key)
    build(settings, keys, source=str(path))
    return merged_settings(keys, rest), path


@document_fields
@dataclass(frozen=True)
class ControllerSpec:
    """The controllers of an experiment. Keys other than these go to the pose controller's settings, over those of
    the settings file ``pose_settings = "FILE"`` names (:mod:`agvctl.scenario.pose_settings`), if any.

    ``pose``, ``wheel_loops``, ``localization`` and ``wheel_speed`` each name code through its registry
    (:class:`~agvctl.config.references.Registry`): a built-in name, an installed package's entry-point name, or a
    reference ``package.module:Name`` (``file.py:Name`` relative to the experiment file). A file naming code runs
    that code.
    """

    pose: str = "mpc"
    """The pose controller: a name or reference of :data:`~agvctl.controllers.registry.pose_controllers`."""
    compute_delay: ComputeDelay = "none"
    """``"one_sample"`` applies the setpoints computed at one sample from the next."""
    localization: str = "truth"
    """The pose estimator: a name or reference of :data:`~agvctl.estimation.registry.pose_estimators`."""
    wheel_speed: str = "exact"
    """How the loops measure the motor speeds: a name or reference of
    :data:`~agvctl.estimation.registry.wheel_speed_estimators`."""
    wheel_loops: str = "pi"
    """The wheel-speed loops: a name or reference of :data:`~agvctl.controllers.registry.wheel_loops` (``"pi"``:
    the PI loops below; ``"pi_c"``: the same loops as generated C, compiled and run through ctypes)."""
    pi_gains: str | None = None
    """A gains file written by ``agvctl tune --out`` (relative to the experiment); None: tuned on the fly."""
    coulomb_feedforward: bool = _LOOPS.coulomb_feedforward
    """Add the Coulomb-friction voltage τ_c R/k_t to the PI output (ramped in near zero speed): the wheels then
    answer small setpoints instead of sitting in the friction until the integrator winds up
    (:attr:`~agvctl.controllers.pi.options.WheelLoopOptions.coulomb_feedforward`)."""
    braking: BrakingName | None = None
    """How hard the PI loops may brake a wheel: ``"full"`` (the current limit), ``"symmetric"`` (always no harder
    than a_lim, eq 5, friction helping) or ``"gentle_stop"`` (so only in the last sample before a wheel stops;
    for paths that stop wheels to reverse them) (:class:`~agvctl.controllers.pi.options.Braking`). None (default):
    ``"gentle_stop"`` on a path whose ``[limits]`` bound the body's acceleration (a payload's), ``"full"`` elsewhere
    (:func:`~agvctl.controllers.pi.options.braking_for`); a loaded experiment holds the one it takes."""
    steering_priority: bool = _LOOPS.steering_priority
    """When both wheel loops ask for more current than the amplifier gives, the same way, keep the difference of
    the currents they ask (the torque that steers) and give up speed instead
    (``docs/decisions/0026-steering-priority.md``)."""
    pose_settings: Any = dataclasses.field(default=None, metadata={"derived": True})
    """The pose controller's settings (an instance of its entry's ``settings``), validated once."""
    wheel_loops_settings: Any = dataclasses.field(default=None, metadata={"derived": True})
    """A user's wheel loops' settings (``[controller.wheel_loops_settings]``), validated once."""
    localization_settings: Any = dataclasses.field(default=None, metadata={"derived": True})
    """A user's pose estimator's settings (``[controller.localization_settings]``), validated once."""
    wheel_speed_settings: Any = dataclasses.field(default=None, metadata={"derived": True})
    """A user's wheel-speed estimator's settings (``[controller.wheel_speed_settings]``), validated once."""
    pose_settings_file: Path | None = dataclasses.field(default=None, metadata={"derived": True})
    """The settings file ``pose_settings = "FILE"`` names, resolved (None: none): an input of the experiment."""

    @property
    def wheel_loop_options(self) -> WheelLoopOptions:
        """The PI wheel loops' options this table sets (the others at their defaults; braking unset: full, until an
        experiment's path sets it)."""
        return WheelLoopOptions(
            coulomb_feedforward=self.coulomb_feedforward,
            braking=_LOOPS.braking if self.braking is None else Braking(self.braking),
            steering_priority=self.steering_priority,
        )

    def __post_init__(self) -> None:
        check_fields(self)
        kind = POSE_CONTROLLERS.get(self.pose)  # a reference's defaults are filled in where it is resolved
        if self.pose_settings is None and kind is not None and kind.settings is not None:
            object.__setattr__(self, "pose_settings", kind.settings())

    @classmethod
    def from_file(
        cls, data: Mapping[str, Any], *, source: str, prefix: str, base_dir: Path | None = None
    ) -> ControllerSpec:
        """The ``[controller]`` table, every name resolved (its code imported) and every settings table built.

        ``base_dir`` is what file references are relative to (default: the folder of ``source``)."""
        own = [f.name for f in dataclasses.fields(cls) if not f.metadata.get("derived")]
        for old in ("symmetric_braking", "gentle_stop"):
            if old in data:
                raise ConfigError(source, join_key(prefix, old), 'replaced by braking = "symmetric" or "gentle_stop"')
        settings_keys = [f"{key}_settings" for key in _PARTS]
        base: ControllerSpec = build_fields(
            cls, {k: v for k, v in data.items() if k in own}, source=source, prefix=prefix
        )
        parts = {
            f"{key}_settings": _part_settings(
                key, getattr(base, key), data.get(f"{key}_settings"), base_dir, source, prefix
            )
            for key in _PARTS
        }
        pose_key = join_key(prefix, "pose")
        kind = pose_controllers.resolve(base.pose, source=source, key=pose_key, base_dir=base_dir)
        rest = {k: v for k, v in data.items() if k not in own and k != "pose_settings" and k not in settings_keys}
        settings_file = None
        if "pose_settings" in data:
            rest, settings_file = _with_settings_file(
                data["pose_settings"], base.pose, kind.settings, rest, source, prefix
            )
        if kind.settings is None:
            if rest:
                key = next(iter(rest))
                raise ConfigError(
                    source,
                    join_key(prefix, key),
                    f"not used with pose = {base.pose!r}" + did_you_mean(key, own, [prefix]),
                )
            return dataclasses.replace(base, pose_settings=None, **parts)
        pose_settings: Any = build(kind.settings, rest, source=source, prefix=prefix)
        if kind.check is not None:
            try:
                kind.check(pose_settings)
            except ConfigError as exc:  # the controller's rule, at the file's key
                raise ConfigError(source, join_key(prefix, exc.key), exc.problem) from None
        return dataclasses.replace(base, pose_settings=pose_settings, pose_settings_file=settings_file, **parts)

    def to_file(self) -> dict[str, Any]:
        own = {
            f.name: getattr(self, f.name)
            for f in dataclasses.fields(self)
            if not f.metadata.get("derived") and getattr(self, f.name) is not None
        }
        parts = {
            f"{key}_settings": to_dict(getattr(self, f"{key}_settings"))
            for key in _PARTS
            if getattr(self, f"{key}_settings") is not None
        }
        return {**own, **(to_dict(self.pose_settings) if self.pose_settings is not None else {}), **parts}


@document_fields
@dataclass(frozen=True)
class Spread:
    """How one vehicle value varies across Monte Carlo samples, relative to its nominal value."""

    kind: Literal["uniform", "normal"]
    """The distribution."""
    relative: float
    """Half-width of the uniform interval (value · (1 ± relative)) or the Gaussian sigma (value · (1 + N(0, σ)))."""

    def __post_init__(self) -> None:
        check_fields(self)


@document_fields
@dataclass(frozen=True)
class RobustnessSpec:
    """``[robustness]``: Monte Carlo over the plant's parameters (the controller keeps the nominal model)."""

    samples: int = number(ge=1, le=100000, default=100, doc="How many runs, each with its own plant.")
    seed: int = number(ge=0, default=0, doc="The seed the plants are drawn from.")
    spread: dict[str, Spread] = dataclasses.field(default_factory=dict)
    """How each varied vehicle value spreads, by dotted key; the file gives a relative half-width (uniform) or
    ``{ normal = SIGMA }``."""

    def __post_init__(self) -> None:
        check_fields(self)

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> RobustnessSpec:
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

    def to_file(self) -> dict[str, Any]:
        spread: dict[str, Any] = {
            k: (v.relative if v.kind == "uniform" else {"normal": v.relative}) for k, v in self.spread.items()
        }
        return {"samples": self.samples, "seed": self.seed, "spread": spread}


LOG_COLUMNS = (*PLANT_LOG_COLUMNS, *CONTROL_LOG_COLUMNS, *PATH_LOG_COLUMNS, *PAYLOAD_LOG_COLUMNS)
"""The columns of a closed-loop run's log, which a requirement's formula may name."""


@document_fields
@dataclass(frozen=True)
class ExperimentSpec:
    """An experiment file, validated. Paths are resolved relative to the file.

    :func:`~agvctl.scenario.experiment.load_experiment` reads one and makes it an
    :class:`~agvctl.scenario.experiment.Experiment`.
    """

    name: str
    """A plain name (no ``/`` or ``\\``, not ``.`` or ``..``): ``agvctl run`` writes to ``out/<name>`` by default
    and ``agvctl check`` names its histograms after it, always under their folder."""
    trajectory: str
    """The path file (``trajectories/*.toml``)."""
    vehicle: str = "default"
    """The controller's vehicle file (``"default"``: the shipped IAU AGV)."""
    settle_s: float = number(
        ge=0,
        le=600.0,
        default=2.0,
        doc="How long the run goes on after the reference ends, at most 600 s as in a fuzz configuration (the run "
        "keeps every sample), s.",
    )
    plant: PlantSpec = dataclasses.field(default_factory=PlantSpec)
    """``[plant]``: the simulated truth."""
    controller: ControllerSpec = dataclasses.field(default_factory=ControllerSpec)
    """``[controller]``: the controllers and estimators."""
    limits: LimitsSpec = dataclasses.field(default_factory=LimitsSpec)
    """``[limits]``: the bounds the run is judged by, over the default gate."""
    requirements: tuple[RequirementSpec, ...] = ()
    """``[[requirements]]``: formulas over the run's signals the run is judged by too
    (:mod:`agvctl.evaluation.requirements`)."""
    robustness: RobustnessSpec | None = None
    """``[robustness]``: Monte Carlo runs for ``agvctl check`` (None: one run)."""
    payload: PayloadAccelerometer = dataclasses.field(default_factory=PayloadAccelerometer)
    """``[payload]``: where the payload's accelerations are read (:mod:`agvctl.evaluation.payload`)."""
    source: str = dataclasses.field(default="<experiment>", metadata={"derived": True})
    """The file it was read from, as errors name it; relative paths are resolved against its folder."""

    def __post_init__(self) -> None:
        check_fields(self)

    @property
    def base_dir(self) -> Path:
        return Path(self.source).parent

    def validate(self, *, source: str, prefix: str) -> None:
        check_plain_name(self.name, source, join_key(prefix, "name"), "out/<name>")
        check_requirement_names(self.requirements, LOG_COLUMNS, source=source, prefix=join_key(prefix, "requirements"))

    def resolve(self, relative: str) -> Path:
        path = Path(relative)
        return path if path.is_absolute() else self.base_dir / path
