"""The fuzz configuration file (``experiments/fuzz/*.toml``): what scenarios to draw, which controllers, the limits.

```toml
name = "acceptance"                 # optional (default: the file's stem); a plain name: out/fuzz/<name>
seed = 10                           # scenario i of seed s depends on (s, i) alone
scenarios = 500
controllers = ["mpc", "ramsete"]    # pose controllers (names or "package.module:Name"); the first is compared
vehicle = "default"                 # or a vehicle TOML (relative to this file): the controllers' nominal model
settle_s = 3.0                      # each run's time after the reference ends

[paths]                             # every key optional; these are the defaults
segments = [2, 6]                   # how many segments, inclusive
segment_types = ["line", "arc", "turn"]
line_length_m = [0.3, 2.5]
arc_radius_m = [0.3, 1.5]
arc_angle_deg = [20.0, 180.0]       # magnitude; left or right at random (turns too)
turn_angle_deg = [20.0, 180.0]
join = ["smooth", "stop"]
explicit_limits_fraction = 0.5      # share of paths with a [limits] table; the others plan with the defaults
wheel_speed_fraction = [0.3, 1.0]   # explicit limits, as fractions of the vehicle's physical maxima
wheel_accel_fraction = [0.3, 1.0]

[start]                             # the true start pose, off the path's start
offset_max_m = 0.05
heading_max_deg = 5.0

[plant]                             # relative ranges [low, high] of dotted vehicle keys (replaces the defaults)
"wheels.left.radius_m" = [-0.01, 0.01]
"body.mass_kg" = [-0.10, 0.30]

[controller]                        # more keys for every run's [controller] table (pose comes from controllers)

[estimators]                        # optional: each scenario draws one of each list (uniformly)
localization = ["ekf"]              # pose estimators (names or references)
wheel_speed = ["kalman", "count_difference"]

[limits]                            # experiment-file limit keys, each replacing the default gate's bound of its key
cross_track_error_max_m = 0.05

[pose_settings]                     # optional: a controller's settings file (``agvctl tune --pose --out``)
ramsete = "tuned/ramsete.toml"
```

A controller, like an estimator, is named as in an experiment file (:mod:`agvctl.config.references`): a built-in
name, an installed package's entry-point name, or a reference ``"package.module:Name"`` (``"mine.py:Name"``
relative to this file). Each run's experiment file names the same code (a file reference by its absolute path), and
every worker resolves it again.

``[search]`` and ``[objective]`` are read by ``agvctl tune --pose`` (:mod:`agvctl.tuning`), which searches the
controllers' settings over this distribution; ``agvctl fuzz`` leaves them be.

Without ``[plant]``, the envelope is :data:`DEFAULT_ENVELOPE`. ``[plant]`` may name the true sensors too
(``"sensors.position_fix_sigma_m"``, ``"sensors.position_fix_rate_hz"``, ``"sensors.position_fix_latency_s"``, …):
the estimators keep believing the vehicle file's. Every scenario draws its own ``sensor_seed``.
Every run is judged exactly as ``agvctl check`` judges
it: the default gate (:func:`~agvctl.evaluation.limits.default_limits`) and the ``[limits]`` keys, each of which
replaces the default of its key.
Every problem is a one-line :class:`~agvctl.errors.ConfigError` naming the file and key, before anything runs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl.config import (
    as_file_error,
    build,
    build_fields,
    check_fields,
    check_key,
    check_plain_name,
    convert_value,
    document_fields,
    join_key,
    load_toml,
    number,
)
from agvctl.config.references import Registry, is_reference
from agvctl.controllers.registry import pose_controllers
from agvctl.errors import ConfigError
from agvctl.estimation.registry import pose_estimators, wheel_speed_estimators
from agvctl.evaluation.limits import LimitsSpec
from agvctl.evaluation.payload import PayloadAccelerometer
from agvctl.evaluation.requirements import RequirementSpec, check_requirement_names
from agvctl.fuzz.tables import (
    DEFAULT_ENVELOPE,
    EstimatorsSpec,
    PathGenSpec,
    Range,
    StartSpec,
    _ordered,
    keep_stiction_above_coulomb,
    nominal_value,
)
from agvctl.params import VehicleParams, load_vehicle
from agvctl.scenario.pose_settings import load_settings_table, merged_settings
from agvctl.scenario.spec import LOG_COLUMNS, ControllerSpec

__all__ = [  # the tables under the top level are agvctl.fuzz.tables's, and still importable from here
    "DEFAULT_ENVELOPE",
    "EstimatorsSpec",
    "FuzzSpec",
    "PathGenSpec",
    "StartSpec",
    "check_against_vehicle",
    "keep_stiction_above_coulomb",
    "load_fuzz_config",
    "nominal_value",
    "override_fuzz_config",
]


@document_fields
@dataclass(frozen=True)
class FuzzSpec:
    """A fuzz configuration, validated (see the module notes).

    Made in Python, it checks its fields as the file's loader does; what depends on the vehicle (the envelope's
    keys, the controller table) is checked by :func:`check_against_vehicle` when the scenarios are drawn.

    Raises
    ------
    ConfigError
        ``FuzzSpec: <argument>: <problem>``, e.g. ``FuzzSpec: controllers[0]: must be one of 'mpc', …``.
    """

    seed: int = number(ge=0, doc="The seed: scenario i of seed s depends on (s, i) alone.")
    scenarios: int = number(ge=1, le=1_000_000, doc="How many scenarios to draw.")
    controllers: tuple[str, ...] = ("mpc",)
    """Pose controllers of :data:`~agvctl.controllers.registry.pose_controllers` (names or references), each once;
    the first is compared with the others."""
    name: str = ""
    """A plain name, for ``out/fuzz/<name>`` (``""``: the file's stem)."""
    vehicle: str = "default"
    """The controllers' nominal vehicle: ``"default"`` or a vehicle file."""
    settle_s: float = number(ge=0.0, le=600.0, default=3.0, doc="Each run's time after the reference ends, s.")
    paths: PathGenSpec = dataclasses.field(default_factory=PathGenSpec)
    """``[paths]``: how paths are drawn."""
    start: StartSpec = dataclasses.field(default_factory=StartSpec)
    """``[start]``: how far the true start is off the path's."""
    plant: dict[str, Range] = dataclasses.field(default_factory=lambda: dict(DEFAULT_ENVELOPE))
    """``[plant]``: the envelope, relative ranges by dotted vehicle key (default :data:`DEFAULT_ENVELOPE`)."""
    controller: dict[str, Any] = dataclasses.field(default_factory=dict)
    """``[controller]``: more keys for every run's ``[controller]`` table."""
    estimators: EstimatorsSpec = dataclasses.field(default_factory=EstimatorsSpec)
    """``[estimators]``: the estimators each scenario draws from."""
    limits: LimitsSpec = dataclasses.field(default_factory=LimitsSpec)
    """``[limits]``: bounds over the default gate's, as in an experiment file."""
    requirements: tuple[RequirementSpec, ...] = ()
    """``[[requirements]]``: formulas every run is judged by too, as in an experiment file."""
    payload: PayloadAccelerometer = dataclasses.field(default_factory=PayloadAccelerometer)
    """``[payload]``: where every run reads the payload's accelerations, as in an experiment file."""
    pose_settings: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    """Per controller, the settings of its settings file, under the ``controller`` keys of every run."""
    search: dict[str, Any] = dataclasses.field(default_factory=dict)
    """``[search]``, as in the file: read by :mod:`agvctl.tuning`."""
    objective: dict[str, Any] = dataclasses.field(default_factory=dict)
    """``[objective]``, as in the file: read by :mod:`agvctl.tuning`."""
    source: str = dataclasses.field(default="FuzzSpec", metadata={"derived": True})
    """The file it was read from, as errors name it."""

    def __post_init__(self) -> None:
        check_fields(self)
        object.__setattr__(self, "controllers", tuple(self.controllers))
        self.validate(source=type(self).__name__, prefix="")

    @classmethod
    def from_file(cls, data: Mapping[str, Any], *, source: str, prefix: str) -> FuzzSpec:
        tables = ("plant", "controller", "limits", "pose_settings", "search", "objective")
        base: FuzzSpec = build_fields(
            cls, {k: v for k, v in data.items() if k not in tables}, source=source, prefix=prefix
        )
        changes: dict[str, Any] = {}
        for name in tables:
            if name in data and not isinstance(data[name], Mapping):
                raise ConfigError(source, join_key(prefix, name), "expected a table")
        if "plant" in data:
            changes["plant"] = {
                str(k): _range(v, source, join_key(join_key(prefix, "plant"), str(k))) for k, v in data["plant"].items()
            }
        for name in ("controller", "search", "objective"):
            if name in data:
                changes[name] = dict(data[name])
        if "pose_settings" in data:
            changes["pose_settings"] = load_settings_table(
                data["pose_settings"], source, join_key(prefix, "pose_settings")
            )
        if "limits" in data:
            changes["limits"] = LimitsSpec.from_file(data["limits"], source=source, prefix=join_key(prefix, "limits"))
        with as_file_error(cls, source, prefix):
            return dataclasses.replace(base, **changes)

    def validate(self, *, source: str, prefix: str) -> None:
        """Every controller a known one, once; every ``plant`` range ordered and above −99 %; a plain ``name`` (when
        set: a file's stem fills it in)."""
        for k, pair in self.plant.items():
            _ordered(pair, source, join_key(join_key(prefix, "plant"), k), low=-0.99)
        if self.name:
            check_plain_name(self.name, source, join_key(prefix, "name"), "out/fuzz/<name>")
        check_requirement_names(self.requirements, LOG_COLUMNS, source=source, prefix=join_key(prefix, "requirements"))
        key = join_key(prefix, "controllers")
        if not self.controllers:
            raise ConfigError(source, key, "give at least one pose controller")
        for i, name in enumerate(self.controllers):
            if not isinstance(name, str) or not (name in pose_controllers or is_reference(name)):
                names = ", ".join(map(repr, pose_controllers.names()))
                raise ConfigError(
                    source, f"{key}[{i}]", f"must be one of {names} or a reference package.module:Name (got {name!r})"
                )
            if name in self.controllers[:i]:
                raise ConfigError(source, f"{key}[{i}]", f"{name!r} is listed twice")


def _range(value: Any, source: str, key: str) -> Range:
    pair = convert_value(tuple[float, ...], value, source, key)
    _ordered(pair, source, key, low=-0.99)
    return (float(pair[0]), float(pair[1]))


def check_against_vehicle(spec: FuzzSpec, vehicle: VehicleParams) -> None:
    """Check a fuzz configuration against the vehicle it names.

    Every envelope key must be a number of the vehicle, each range's ends a valid vehicle, the controller table
    valid for every controller, and the top speed finite.

    Parameters
    ----------
    spec : FuzzSpec
        The configuration.
    vehicle : VehicleParams
        The vehicle it names.

    Raises
    ------
    ConfigError
        One line naming ``spec.source`` (the file, or ``FuzzSpec`` for one made in Python) and the key.
    """
    src = spec.source
    if not math.isfinite(vehicle.derived.max_speed_m_s):
        raise ConfigError(src, "vehicle", "the vehicle has no finite top speed")
    for key, (lo, hi) in spec.plant.items():
        where = f"plant.{key}"
        nominal = nominal_value(vehicle, key)
        if nominal is None:
            try:
                check_key(VehicleParams, key, src)
            except ConfigError as exc:
                raise ConfigError(src, where, exc.problem) from None
            raise ConfigError(src, where, "not a numeric vehicle key (e.g. body.mass_kg, motor.left.stiction_n_m)")
        for end in (lo, hi):
            try:
                at_end = keep_stiction_above_coulomb({key: nominal * (1.0 + end)}, vehicle)
                vehicle.with_overrides(list(at_end.items()), source="envelope")
            except ConfigError as exc:
                raise ConfigError(src, where, f"gives an invalid vehicle at {end:+g}: {exc.problem}") from None
    if "pose" in spec.controller:
        raise ConfigError(src, "controller.pose", "set by controllers = [...]; remove it here")
    for key, _choices in spec.estimators.items():
        if key in spec.controller:
            raise ConfigError(src, f"controller.{key}", f"drawn by [estimators] {key}; remove it here")
    for i, name in enumerate(spec.controllers):
        keys = merged_settings(spec.pose_settings.get(name, {}), spec.controller)
        pose_controllers.resolve(name, source=src, key=f"controllers[{i}]")
        ControllerSpec.from_file({"pose": name, **keys}, source=src, prefix="controller")
    registries: dict[str, Registry[Any]] = {"localization": pose_estimators, "wheel_speed": wheel_speed_estimators}
    for key, choices in spec.estimators.items():
        for i, choice in enumerate(choices):
            registries[key].resolve(choice, source=src, key=f"estimators.{key}[{i}]")


def load_fuzz_config(path: str | Path) -> FuzzSpec:
    """Read and validate a fuzz configuration file (and the vehicle it names).

    ``name`` defaults to the file's stem and ``vehicle`` is resolved relative to the file.

    Parameters
    ----------
    path : str or Path
        The fuzz configuration (TOML).

    Returns
    -------
    FuzzSpec
        The validated configuration, for :func:`~agvctl.fuzz.run.fuzz`.

    Raises
    ------
    ConfigError
        A one-line message naming the file and key."""
    path = Path(path)
    spec = build(FuzzSpec, load_toml(path), source=str(path))
    vehicle_path = spec.vehicle
    if vehicle_path != "default":
        resolved = Path(vehicle_path) if Path(vehicle_path).is_absolute() else path.parent / vehicle_path
        if not resolved.exists():
            raise ConfigError(str(path), "vehicle", f"file not found: {resolved}")
        vehicle_path = str(resolved.resolve())
    check_plain_name(spec.name or path.stem, str(path), "name", "out/fuzz/<name>")
    spec = dataclasses.replace(spec, source=str(path), name=spec.name or path.stem, vehicle=vehicle_path)
    check_against_vehicle(spec, load_vehicle(None if vehicle_path == "default" else vehicle_path))
    return spec


def override_fuzz_config(
    spec: FuzzSpec,
    *,
    seed: int | None = None,
    scenarios: int | None = None,
    controllers: Sequence[str] | None = None,
) -> FuzzSpec:
    """A fuzz configuration with the command line's options in place of its values, validated as in the file.

    Parameters
    ----------
    spec : FuzzSpec
        The configuration.
    seed : int or None
        A new seed (None: keep the file's).
    scenarios : int or None
        A new number of scenarios.
    controllers : sequence of str or None
        New pose controllers.

    Returns
    -------
    FuzzSpec
        The configuration with them.

    Raises
    ------
    ConfigError
        A value out of range, naming the option (``--seed``, ``--scenarios``, ``--controllers``).
    """
    if seed is not None and seed < 0:
        raise ConfigError("--seed", "", f"must be >= 0 (got {seed})")
    if scenarios is not None and not 1 <= scenarios <= 1_000_000:
        raise ConfigError("--scenarios", "", f"must be between 1 and 1000000 (got {scenarios})")
    changes: dict[str, Any] = {}
    if seed is not None:
        changes["seed"] = seed
    if scenarios is not None:
        changes["scenarios"] = scenarios
    if controllers is not None:
        changes["controllers"] = tuple(controllers)
    out = dataclasses.replace(spec, **changes)
    if controllers is not None:
        out.validate(source="--controllers", prefix="")
        try:
            check_against_vehicle(out, load_vehicle(None if out.vehicle == "default" else out.vehicle))
        except ConfigError as exc:
            raise ConfigError("--controllers", "", f"{exc}") from None
    return out
