"""The search space of a pose controller's settings: a fuzz file's ``[search.<controller>]`` table, or the default.

```toml
[search.mpc]                                  # replaces the default space of the mpc controller
weight_heading = [3.0, 300.0]                 # uniform in [low, high]
weight_input_rate = { low = 1.0, high = 100.0, log = true }   # log-uniform
horizon = [10, 30]                            # an integer setting draws integers
"docking.tolerance_m" = [0.004, 0.02]         # a nested table's setting, by its dotted name
```

Every name is a numeric setting of the controller's settings dataclass (its ``[controller]`` key), every range
non-empty and inside the setting's own bounds, a log range above zero: each refused in one line naming the file and
the key, before anything runs.
"""

from __future__ import annotations

import dataclasses
import math
import operator
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from agvctl.config import did_you_mean, join_key
from agvctl.config.references import is_reference
from agvctl.controllers.baselines.c_unicycle import COMPILED_LAWS
from agvctl.controllers.registry import pose_controllers
from agvctl.errors import ConfigError

__all__ = ["DEFAULT_SPACES", "SearchParam", "SearchSpace", "search_space", "settings_table"]


@dataclass(frozen=True)
class SearchParam:
    """One setting searched: its dotted name, its range and how it is drawn.

    Parameters
    ----------
    name : str
        The setting's ``[controller]`` key; a nested table's setting by its dotted name (``docking.tolerance_m``).
    low, high : float
        The range, low < high, in the setting's own unit.
    log : bool
        Draw log-uniformly (low > 0): for weights and gains, whose effect goes with their ratios.
    integer : bool
        Draw integers (the setting is one, e.g. a horizon in samples).
    """

    name: str
    low: float
    high: float
    log: bool = False
    integer: bool = False

    def describe(self) -> str:
        """``name [low, high]`` with ``log`` or ``int`` where they apply."""
        kind = " log" if self.log else (" int" if self.integer else "")
        return f"{self.name}{kind} [{self.low:g}, {self.high:g}]"


@dataclass(frozen=True)
class SearchSpace:
    """The settings searched for one pose controller.

    Parameters
    ----------
    controller : str
        A pose controller of :data:`~agvctl.controllers.registry.pose_controllers` (a name or a reference) that
        takes settings.
    params : tuple of SearchParam
        The settings searched, in the order the sampler draws them.
    """

    controller: str
    params: tuple[SearchParam, ...]

    def describe(self) -> str:
        """One line: every setting's range."""
        return ", ".join(p.describe() for p in self.params)


DEFAULT_SPACES: dict[str, dict[str, Any]] = {
    "mpc": {
        "horizon": [10, 30],
        "weight_position": {"low": 100.0, "high": 10000.0, "log": True},
        "along_track_share": [0.3, 1.0],
        "weight_heading": {"low": 3.0, "high": 300.0, "log": True},
        "weight_input": {"low": 0.01, "high": 1.0, "log": True},
        "weight_input_rate": {"low": 1.0, "high": 100.0, "log": True},
        "weight_reversal": [0.0, 30.0],
        "turn_in_place_position_scale": [1.0, 6.0],
        "reach_lead": [1.2, 4.0],
        "governor_lag_start_m": [0.02, 0.06],
        "governor_lag_stop_m": [0.07, 0.2],
    },
    "ramsete": {
        "b_rad2_m2": {"low": 0.5, "high": 20.0, "log": True},
        "zeta": [0.3, 1.0],
    },
    "ltv_lqr": {
        "tolerance_x_m": {"low": 0.01, "high": 0.5, "log": True},
        "tolerance_y_m": {"low": 0.01, "high": 0.5, "log": True},
        "tolerance_heading_rad": {"low": 0.1, "high": 5.0, "log": True},
        "effort_speed_m_s": {"low": 0.2, "high": 5.0, "log": True},
        "effort_yaw_rate_rad_s": {"low": 0.5, "high": 10.0, "log": True},
    },
}
"""The space searched when a fuzz file has no ``[search.<controller>]`` table: the settings that shape the tracking
(weights, horizon, reach lead, governor band; Ramsete's b and ζ; the LQR's tolerances and efforts), each over the
range in which it stays a sensible design. ``nmpc`` shares the mpc's settings and space but the reversal weight,
which only the LTV MPC has; a law's generated C (``ramsete_c``, ``ltv_lqr_c``) shares the law's space."""
DEFAULT_SPACES["nmpc"] = {key: value for key, value in DEFAULT_SPACES["mpc"].items() if key != "weight_reversal"}
DEFAULT_SPACES.update({f"{name}_c": DEFAULT_SPACES[name] for name in COMPILED_LAWS})


def _field(settings: type, dotted: str, source: str, key: str) -> dataclasses.Field[Any]:
    """The dataclass field a dotted setting name names, through nested settings tables."""
    cls: Any = settings
    parts = dotted.split(".")
    for depth, part in enumerate(parts):
        fields = {f.name: f for f in dataclasses.fields(cls) if not f.metadata.get("derived")}
        if part not in fields:
            raise ConfigError(source, key, "not a setting" + did_you_mean(part, list(fields), parts[:depth]))
        field = fields[part]
        inner = typing.get_type_hints(cls)[part]
        if depth == len(parts) - 1:
            return field
        if not (isinstance(inner, type) and dataclasses.is_dataclass(inner)):
            raise ConfigError(source, key, f"'{'.'.join(parts[: depth + 1])}' is a value, not a table")
        cls = inner
    raise AssertionError("unreachable")


def _numeric_kind(settings: type, dotted: str, source: str, key: str) -> tuple[bool, Mapping[str, Any]]:
    """(integer, bounds metadata) of a numeric setting; any other setting is refused."""
    field = _field(settings, dotted, source, key)
    owner: Any = settings
    for part in dotted.split(".")[:-1]:
        owner = typing.get_type_hints(owner)[part]
    hint = typing.get_type_hints(owner)[field.name]
    args = [a for a in typing.get_args(hint) if a is not type(None)] if isinstance(hint, types.UnionType) else [hint]
    if len(args) != 1 or args[0] not in (int, float):
        raise ConfigError(source, key, "not a numeric setting: only numbers can be searched")
    return args[0] is int, field.metadata


def _param(settings: type, name: str, value: Any, source: str, key: str) -> SearchParam:
    integer, meta = _numeric_kind(settings, name, source, key)
    log = False
    if isinstance(value, Mapping):
        unknown = set(value) - {"low", "high", "log"}
        if unknown or not {"low", "high"} <= set(value):
            raise ConfigError(source, key, "expected [low, high] or { low = …, high = …, log = true }")
        log = value.get("log", False)
        if not isinstance(log, bool):
            raise ConfigError(source, join_key(key, "log"), f"expected true or false (got {log!r})")
        bounds = [value["low"], value["high"]]
    elif isinstance(value, (list, tuple)) and len(value) == 2:
        bounds = list(value)
    else:
        raise ConfigError(source, key, f"expected [low, high] or {{ low = …, high = … }} (got {value!r})")
    for b in bounds:
        if isinstance(b, bool) or not isinstance(b, (int, float)) or not math.isfinite(b):
            raise ConfigError(source, key, f"the range's ends must be finite numbers (got {b!r})")
        if integer and b != int(b):
            raise ConfigError(source, key, f"an integer setting: the range's ends must be integers (got {b!r})")
    low, high = float(bounds[0]), float(bounds[1])
    if not low < high:
        raise ConfigError(source, key, f"an empty range: low {low:g} must be below high {high:g}")
    if log and low <= 0:
        raise ConfigError(source, key, f"a log range must be above 0 (low is {low:g})")
    validity = (("gt", "low", ">", operator.gt), ("ge", "low", ">=", operator.ge), ("le", "high", "<=", operator.le))
    for name_, end, sign, holds in validity:
        bound = meta.get(name_)
        if bound is not None and not holds(low if end == "low" else high, bound):
            raise ConfigError(source, key, f"outside the setting's validity: {end} must be {sign} {bound:g}")
    return SearchParam(name, low, high, log, integer)


def search_space(controller: str, table: Mapping[str, Any] | None, *, source: str) -> SearchSpace:
    """The search space of ``controller``: its ``[search.<controller>]`` table, or :data:`DEFAULT_SPACES`.

    Parameters
    ----------
    controller : str
        A pose controller that takes settings.
    table : Mapping or None
        The fuzz file's ``[search]`` table (all controllers'); None or without the controller: the default.
    source : str
        The fuzz file, named in errors.

    Returns
    -------
    SearchSpace
        Every setting checked as the module notes say.

    Raises
    ------
    ConfigError
        One line naming ``source`` and the ``search.<controller>.<setting>`` key.
    """
    if not isinstance(controller, str):
        raise ConfigError("search_space", "controller", f"expected a pose controller's name (got {controller!r:.60})")
    if table is not None and not isinstance(table, Mapping):
        raise ConfigError(source, "search", "expected a table of [search.<controller>] tables")
    kind = pose_controllers.resolve(controller, source=source, key="controllers")
    if kind.settings is None:
        takes = ", ".join(repr(c) for c in pose_controllers.builtins if pose_controllers.builtins[c].settings)
        raise ConfigError(
            source,
            "controllers",
            f"{controller!r} has no settings to tune; tune one of {takes}, or one with a Settings dataclass",
        )
    table = table or {}
    for name in table:
        if not (name in pose_controllers or is_reference(name)):
            raise ConfigError(
                source, f"search.{name}", "not a pose controller" + did_you_mean(name, pose_controllers.names(), [])
            )
        if not isinstance(table[name], Mapping):
            raise ConfigError(source, f"search.{name}", "expected a table of setting = [low, high]")
    own = table.get(controller)
    chosen, where = (own, source) if own is not None else (DEFAULT_SPACES.get(controller, {}), "the default space")
    if own is None and not chosen:
        raise ConfigError(
            source, f"search.{controller}", f'no default space: declare [search."{controller}"] in the fuzz file'
        )
    if not chosen:
        raise ConfigError(source, f"search.{controller}", "give at least one setting to search")
    params = tuple(
        _param(kind.settings, str(name), value, where, f"search.{controller}.{name}") for name, value in chosen.items()
    )
    return SearchSpace(controller, params)


def settings_table(values: Mapping[str, float]) -> dict[str, Any]:
    """The ``[controller]`` keys for the drawn values: dotted names nested into their tables.

    Parameters
    ----------
    values : Mapping
        Setting name (dotted for nested tables) → value.

    Returns
    -------
    dict
        ``{"weight_heading": 30.0, "docking": {"tolerance_m": 0.01}}``, integers as ``int``.
    """
    out: dict[str, Any] = {}
    for name, value in values.items():
        *tables, last = name.split(".")
        node = out
        for t in tables:
            node = node.setdefault(t, {})
        node[last] = value
    return out
