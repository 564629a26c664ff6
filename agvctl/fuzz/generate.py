"""Random scenarios for the fuzzer: a path file, a plant within the envelope and an off-path start, from (seed, i).

Scenario i of seed s draws from ``numpy.random.default_rng([s, i])`` alone, so it is the same whatever the other
scenarios, the number of jobs or the order they run in. Each becomes a path file and one experiment file per
controller (:func:`scenario_files`): plain TOML that :func:`agvctl.scenario.experiment.load_experiment` reads, so a
failing scenario is written out as files ``agvctl run`` reproduces exactly.

Every value comes through a :class:`Draws` by the name of what it is, so the same code draws a scenario at random
(:class:`RandomDraws`) or from an optimiser's proposals (:func:`draw_scenario`; :mod:`agvctl.falsify` searches the
envelope so): one definition of the envelope for both.

What is drawn, in this order:

- the path: ``paths.segments`` segments, each of a type drawn from ``paths.segment_types`` (a path of turns only
  gets its last segment redrawn as a line or arc, so it has a path to follow), lengths, radii and angles uniform in
  their ranges, left or right at random; ``join`` uniform among ``paths.join``; with probability
  ``paths.explicit_limits_fraction`` a ``[limits]`` table with wheel speed and acceleration uniform in the given
  fractions of the vehicle's physical maxima (no-load top speed, a_lim of eq 5; rounded down so they never
  exceed them), else the vehicle's defaults;
- the plant: each key of the envelope (in sorted order) uniform in nominal · (1 + [low, high]). Stiction is kept
  at or above Coulomb friction on each side: if the drawn Coulomb friction exceeds the drawn stiction, the two are
  exchanged (with equal ranges, as by default, that draws the pair uniformly over the part of the box where
  τ_s ≥ τ_c); if only one of them is drawn, stiction is raised to the Coulomb friction;
- the start: an offset uniform in [0, ``start.offset_max_m``] in a uniformly random direction, and a heading
  off by up to ``start.heading_max_deg``;
- the sensors' noise seed (``[plant] sensor_seed``), and for each list of ``[estimators]`` one of its names.

Values are rounded for readable files (1 mm, 0.1°, six significant digits for the plant) before use.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from agvctl.config import document_fields, dump_toml
from agvctl.config.references import absolute_reference, plain_label
from agvctl.errors import ConfigError
from agvctl.evaluation.payload import PayloadAccelerometer
from agvctl.fuzz.spec import FuzzSpec, PathGenSpec, keep_stiction_above_coulomb, nominal_value
from agvctl.params import VehicleParams
from agvctl.scenario.pose_settings import merged_settings

__all__ = ["Draws", "RandomDraws", "Scenario", "draw_scenario", "generate_scenario", "scenario_files"]


@document_fields
@dataclass(frozen=True)
class Scenario:
    """One drawn scenario: the path file's data, the plant's overrides and the true start pose."""

    seed: int
    """The configuration's seed."""
    index: int
    """The scenario's number."""
    path: dict[str, Any]
    """The path file as TOML data (``segments``, ``join``, optional ``limits``)."""
    plant_set: dict[str, float]
    """``[plant] set``: dotted vehicle keys and their true values, each in the unit of its key."""
    initial_pose: dict[str, float]
    """``[plant] initial_pose``: ``x_m`` and ``y_m`` in m, ``theta_deg`` in °."""
    sensor_seed: int = 0
    """``[plant] sensor_seed``: the true sensors' noise."""
    estimators: dict[str, str] = field(default_factory=dict)
    """The ``[controller]`` estimator keys drawn (``localization``, ``wheel_speed``)."""
    prefix: str = "s"
    """The name's prefix: ``s`` for a random scenario, ``search`` for one a search proposed."""

    @property
    def name(self) -> str:
        return f"{self.prefix}{self.seed}_{self.index:05d}"


def _sig(value: float, digits: int = 6) -> float:
    return float(f"{value:.{digits}g}")


class Draws(Protocol):
    """Where a scenario's values come from, each by the name of what it is (``segments``, ``segment2.type``,
    ``plant.body.mass_kg``, ``start.heading_deg``): random draws (:class:`RandomDraws`) for ``agvctl fuzz``, an
    optimiser's proposals for a search over the same envelope (:mod:`agvctl.falsify`). A name always has the
    same range or options."""

    def uniform(self, name: str, low: float, high: float) -> float:
        """A number in [low, high]."""
        ...

    def integer(self, name: str, low: int, high: int) -> int:
        """An integer in [low, high], both included."""
        ...

    def choice(self, name: str, options: Sequence[str]) -> str:
        """One of ``options``."""
        ...

    def chance(self, name: str, probability: float) -> bool:
        """True with ``probability`` (0 ≤ probability ≤ 1): a search may pick either where both can happen."""
        ...


class RandomDraws:
    """:class:`Draws` from a numpy generator: uniform numbers, integers and choices, each one draw of ``rng``.

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator.
    """

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def uniform(self, name: str, low: float, high: float) -> float:
        """``rng.uniform(low, high)``, with a bound of −0.0 read as 0.0 (numpy refuses ``uniform(0.0, -0.0)``)."""
        return float(self.rng.uniform(low + 0.0, high + 0.0))

    def integer(self, name: str, low: int, high: int) -> int:
        """``rng.integers(low, high + 1)``."""
        return int(self.rng.integers(low, high + 1))

    def choice(self, name: str, options: Sequence[str]) -> str:
        """``options[rng.integers(len(options))]``."""
        return str(options[int(self.rng.integers(len(options)))])

    def chance(self, name: str, probability: float) -> bool:
        """``rng.random() < probability``."""
        return bool(self.rng.random() < probability)


def _segments(draws: Draws, p: PathGenSpec) -> list[dict[str, Any]]:
    n = draws.integer("segments", p.segments[0], p.segments[1])
    kinds = [draws.choice(f"segment{i}.type", p.segment_types) for i in range(n)]
    moving = [k for k in p.segment_types if k != "turn"]
    if moving and all(k == "turn" for k in kinds):
        kinds[-1] = draws.choice("last_segment.moving_type", moving)
    out: list[dict[str, Any]] = []
    for i, kind in enumerate(kinds):
        sign = 1.0 if draws.chance(f"segment{i}.left", 0.5) else -1.0
        if kind == "line":
            out.append(
                {"type": "line", "length_m": round(draws.uniform(f"segment{i}.line_length_m", *p.line_length_m), 3)}
            )
        elif kind == "arc":
            radius = round(draws.uniform(f"segment{i}.arc_radius_m", *p.arc_radius_m), 3)
            angle = round(sign * draws.uniform(f"segment{i}.arc_angle_deg", *p.arc_angle_deg), 1)
            out.append({"type": "arc", "radius_m": radius, "angle_deg": angle})
        else:
            angle = round(sign * draws.uniform(f"segment{i}.turn_angle_deg", *p.turn_angle_deg), 1)
            out.append({"type": "turn", "angle_deg": angle})
    return out


def _path(draws: Draws, p: PathGenSpec, vehicle: VehicleParams, name: str) -> dict[str, Any]:
    segments = _segments(draws, p)
    data: dict[str, Any] = {"name": name, "join": draws.choice("join", p.join)}
    if draws.chance("explicit_limits", p.explicit_limits_fraction):
        top, a_lim = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2
        speed = math.floor(top * draws.uniform("wheel_speed_fraction", *p.wheel_speed_fraction) * 1000) / 1000
        accel = math.floor(a_lim * draws.uniform("wheel_accel_fraction", *p.wheel_accel_fraction) * 1000) / 1000
        data["limits"] = {"wheel_speed_m_s": max(speed, 0.001), "wheel_accel_m_s2": max(accel, 0.001)}
    data["segments"] = segments
    return data


def _plant(draws: Draws, spec: FuzzSpec, vehicle: VehicleParams) -> dict[str, float]:
    values: dict[str, float] = {}
    for key in sorted(spec.plant):
        lo, hi = spec.plant[key]
        nominal = nominal_value(vehicle, key)
        assert nominal is not None  # checked when the configuration was loaded
        values[key] = _sig(nominal * (1.0 + draws.uniform(f"plant.{key}", lo, hi)))
    return keep_stiction_above_coulomb(values, vehicle)


def generate_scenario(spec: FuzzSpec, vehicle: VehicleParams, index: int) -> Scenario:
    """Scenario ``index`` of ``spec.seed``, drawn from ``default_rng([seed, index])`` alone (see the module notes).

    Parameters
    ----------
    spec : FuzzSpec
        The fuzz configuration (:func:`~agvctl.fuzz.spec.load_fuzz_config`).
    vehicle : VehicleParams
        The nominal vehicle (the configuration's): the plant's nominal values and the physical limits.
    index : int
        The scenario's number, 0 ≤ index.

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    ValueError
        A negative index.
    """
    if index < 0:
        raise ValueError(f"index must be >= 0 (got {index})")
    return draw_scenario(spec, vehicle, RandomDraws(np.random.default_rng([spec.seed, index])), index)


def draw_scenario(spec: FuzzSpec, vehicle: VehicleParams, draws: Draws, index: int, prefix: str = "s") -> Scenario:
    """A scenario of the envelope of ``spec`` with every value taken from ``draws``, in the order of the module
    notes: the one definition of the envelope that random fuzzing and a search share.

    Parameters
    ----------
    spec : FuzzSpec
        The fuzz configuration: the envelope.
    vehicle : VehicleParams
        The nominal vehicle (the configuration's): the plant's nominal values and the physical limits.
    draws : Draws
        Where the values come from (:class:`RandomDraws` for scenario ``index`` of a seed).
    index : int
        The scenario's number, 0 ≤ index: its name (``<prefix><seed>_<index>``).
    prefix : str
        The name's prefix (``s`` for a random scenario).

    Returns
    -------
    Scenario
        The scenario.

    Raises
    ------
    ConfigError
        The drawn plant values together give an invalid vehicle.
    """
    name = f"{prefix}{spec.seed}_{index:05d}"
    path = _path(draws, spec.paths, vehicle, name)
    plant = _plant(draws, spec, vehicle)
    radius = draws.uniform("start.offset_m", 0.0, spec.start.offset_max_m)
    direction = draws.uniform("start.direction_rad", -math.pi, math.pi)
    heading = draws.uniform("start.heading_deg", -spec.start.heading_max_deg, spec.start.heading_max_deg)
    pose = {
        "x_m": round(radius * math.cos(direction), 4),
        "y_m": round(radius * math.sin(direction), 4),
        "theta_deg": round(heading, 2),
    }
    try:
        vehicle.with_overrides(list(plant.items()), source="plant")
    except ConfigError as exc:  # the envelope's ends were checked one at a time; combinations can still fail
        raise ConfigError(spec.source, "plant", f"scenario {index} gives an invalid vehicle: {exc}") from None
    sensor_seed = draws.integer("sensor_seed", 0, 2**31 - 1)
    estimators = {key: draws.choice(f"estimators.{key}", choices) for key, choices in spec.estimators.items()}
    return Scenario(spec.seed, index, path, plant, pose, sensor_seed, estimators, prefix)


def scenario_files(spec: FuzzSpec, scenario: Scenario, controller: str) -> dict[str, str]:
    """The path file and the experiment file of a scenario run with a pose controller.

    Parameters
    ----------
    spec : FuzzSpec
        The fuzz configuration the scenario was drawn from.
    scenario : Scenario
        The scenario.
    controller : str
        The pose controller's name.

    Returns
    -------
    dict of str to str
        ``{file name: TOML text}``, the path file first. Written side by side, ``agvctl run <experiment file>``
        runs the scenario.
    """
    path_name = f"{scenario.name}.path.toml"
    label = plain_label(controller)
    exp_name = f"{scenario.name}_{label}.toml"
    base_dir = Path(spec.source).parent
    origin = (
        f"fuzz scenario {scenario.index} of seed {scenario.seed} ({spec.source})"
        if scenario.prefix == "s"
        else f"run {scenario.index} of the search of seed {scenario.seed} over the envelope of {spec.source}"
    )
    table = {**merged_settings(spec.pose_settings.get(controller, {}), spec.controller), **scenario.estimators}
    for key in ("wheel_loops", "localization", "wheel_speed"):  # code it names, from any folder
        if isinstance(table.get(key), str):
            table[key] = absolute_reference(table[key], base_dir)
    experiment: dict[str, Any] = {
        "name": f"{spec.name}_{scenario.name}_{label}",
        "trajectory": path_name,
        "vehicle": spec.vehicle,
        "settle_s": spec.settle_s,
        "plant": {
            "set": dict(scenario.plant_set),
            "initial_pose": dict(scenario.initial_pose),
            "sensor_seed": scenario.sensor_seed,
        },
        "controller": {"pose": absolute_reference(controller, base_dir), **table},
        "limits": spec.limits.to_file(),
    }
    if spec.payload != PayloadAccelerometer():
        experiment["payload"] = asdict(spec.payload)
    if spec.requirements:
        experiment["requirements"] = [
            {"name": r.name, "formula": r.formula, "anchor": r.anchor} for r in spec.requirements
        ]
    return {
        path_name: dump_toml(scenario.path, header=f"{origin}: the path"),
        exp_name: dump_toml(experiment, header=f"{origin}, pose controller {controller!r}\nrun: agvctl run {exp_name}"),
    }
