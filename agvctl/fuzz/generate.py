"""Random scenarios for the fuzzer: a path file, a plant within the envelope and an off-path start, from (seed, i).

Scenario i of seed s draws from ``numpy.random.default_rng([s, i])`` alone, so it is the same whatever the other
scenarios, the number of jobs or the order they run in. Each becomes a path file and one experiment file per
controller (:func:`scenario_files`): plain TOML that :func:`agvctl.scenario.experiment.load_experiment` reads, so a
failing scenario is written out as files ``agvctl run`` reproduces exactly.

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.config import document_fields, dump_toml
from agvctl.config.references import absolute_reference, plain_label
from agvctl.errors import ConfigError
from agvctl.fuzz.spec import FuzzSpec, PathGenSpec, keep_stiction_above_coulomb, nominal_value
from agvctl.params import VehicleParams
from agvctl.scenario.pose_settings import merged_settings

__all__ = ["Scenario", "generate_scenario", "scenario_files"]


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

    @property
    def name(self) -> str:
        return f"s{self.seed}_{self.index:05d}"


def _sig(value: float, digits: int = 6) -> float:
    return float(f"{value:.{digits}g}")


def _draw(rng: np.random.Generator, bounds: tuple[float, ...]) -> float:
    """Uniform in [low, high]."""
    return _uniform(rng, bounds[0], bounds[1])


def _uniform(rng: np.random.Generator, low: float, high: float) -> float:
    """``rng.uniform(low, high)``, with a bound of −0.0 read as 0.0 (numpy refuses ``uniform(0.0, -0.0)``)."""
    return float(rng.uniform(low + 0.0, high + 0.0))


def _segments(rng: np.random.Generator, p: PathGenSpec) -> list[dict[str, Any]]:
    n = int(rng.integers(p.segments[0], p.segments[1] + 1))
    kinds = [str(p.segment_types[int(rng.integers(len(p.segment_types)))]) for _ in range(n)]
    moving = [k for k in p.segment_types if k != "turn"]
    if moving and all(k == "turn" for k in kinds):
        kinds[-1] = str(moving[int(rng.integers(len(moving)))])
    out: list[dict[str, Any]] = []
    for kind in kinds:
        sign = 1.0 if rng.random() < 0.5 else -1.0
        if kind == "line":
            out.append({"type": "line", "length_m": round(_draw(rng, p.line_length_m), 3)})
        elif kind == "arc":
            radius = round(_draw(rng, p.arc_radius_m), 3)
            angle = round(sign * _draw(rng, p.arc_angle_deg), 1)
            out.append({"type": "arc", "radius_m": radius, "angle_deg": angle})
        else:
            out.append({"type": "turn", "angle_deg": round(sign * _draw(rng, p.turn_angle_deg), 1)})
    return out


def _path(rng: np.random.Generator, p: PathGenSpec, vehicle: VehicleParams, name: str) -> dict[str, Any]:
    segments = _segments(rng, p)
    data: dict[str, Any] = {"name": name, "join": str(p.join[int(rng.integers(len(p.join)))])}
    if rng.random() < p.explicit_limits_fraction:
        top, a_lim = vehicle.derived.max_speed_m_s, vehicle.derived.accel_limit_m_s2
        speed = math.floor(top * _draw(rng, p.wheel_speed_fraction) * 1000) / 1000
        accel = math.floor(a_lim * _draw(rng, p.wheel_accel_fraction) * 1000) / 1000
        data["limits"] = {"wheel_speed_m_s": max(speed, 0.001), "wheel_accel_m_s2": max(accel, 0.001)}
    data["segments"] = segments
    return data


def _plant(rng: np.random.Generator, spec: FuzzSpec, vehicle: VehicleParams) -> dict[str, float]:
    values: dict[str, float] = {}
    for key in sorted(spec.plant):
        lo, hi = spec.plant[key]
        nominal = nominal_value(vehicle, key)
        assert nominal is not None  # checked when the configuration was loaded
        values[key] = _sig(nominal * (1.0 + _uniform(rng, lo, hi)))
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
    rng = np.random.default_rng([spec.seed, index])
    name = f"s{spec.seed}_{index:05d}"
    path = _path(rng, spec.paths, vehicle, name)
    plant = _plant(rng, spec, vehicle)
    radius = _uniform(rng, 0.0, spec.start.offset_max_m)
    direction = float(rng.uniform(-math.pi, math.pi))
    heading = _uniform(rng, -spec.start.heading_max_deg, spec.start.heading_max_deg)
    pose = {
        "x_m": round(radius * math.cos(direction), 4),
        "y_m": round(radius * math.sin(direction), 4),
        "theta_deg": round(heading, 2),
    }
    try:
        vehicle.with_overrides(list(plant.items()), source="plant")
    except ConfigError as exc:  # the envelope's ends were checked one at a time; combinations can still fail
        raise ConfigError(spec.source, "plant", f"scenario {index} gives an invalid vehicle: {exc}") from None
    sensor_seed = int(rng.integers(0, 2**31))
    estimators = {key: str(choices[int(rng.integers(len(choices)))]) for key, choices in spec.estimators.items()}
    return Scenario(spec.seed, index, path, plant, pose, sensor_seed, estimators)


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
    origin = f"fuzz scenario {scenario.index} of seed {scenario.seed} ({spec.source})"
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
    if spec.requirements:
        experiment["requirements"] = [
            {"name": r.name, "formula": r.formula, "anchor": r.anchor} for r in spec.requirements
        ]
    return {
        path_name: dump_toml(scenario.path, header=f"{origin}: the path"),
        exp_name: dump_toml(experiment, header=f"{origin}, pose controller {controller!r}\nrun: agvctl run {exp_name}"),
    }
