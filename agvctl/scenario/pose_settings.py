"""Pose-controller settings files: the ``[controller]`` keys of one pose controller, kept in a file of their own.

``agvctl tune --pose`` writes one; an experiment file takes it as ``[controller] pose_settings = "tuned.toml"`` and a
fuzz file as ``[pose_settings] mpc = "tuned.toml"``. The file holds the controller's settings keys as an experiment's
``[controller]`` table would (nested tables such as ``[docking]`` included) and, optionally, ``pose = "<name>"``,
which must then be the controller it is used with. Keys set beside it in the ``[controller]`` table win over the
file's, key by key.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agvctl.config import build, join_key, load_toml
from agvctl.config.references import is_reference
from agvctl.controllers.registry import pose_controllers
from agvctl.errors import ConfigError

__all__ = ["load_pose_settings", "load_settings_table", "merged_settings"]


def merged_settings(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``over``'s keys in place of its own, tables merged key by key (not replaced whole).

    Parameters
    ----------
    base : Mapping
        The settings underneath (e.g. a settings file's).
    over : Mapping
        The settings that win (e.g. an experiment's own ``[controller]`` keys).

    Returns
    -------
    dict
        A new nested mapping; neither argument is changed.
    """
    out: dict[str, Any] = {k: dict(v) if isinstance(v, Mapping) else v for k, v in base.items()}
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merged_settings(out[key], value)
        else:
            out[key] = dict(value) if isinstance(value, Mapping) else value
    return out


def load_pose_settings(path: str | Path, pose: str, *, source: str, key: str) -> dict[str, Any]:
    """The settings keys of the file at ``path`` for the pose controller ``pose``.

    Parameters
    ----------
    path : str or Path
        The settings file (TOML), already resolved against the file that names it.
    pose : str
        The pose controller the settings are for; a ``pose`` key in the file must name it.
    source : str
        The file that names the settings file, for errors about the reference itself.
    key : str
        The key that names it (``controller.pose_settings``), for errors about the reference itself.

    Returns
    -------
    dict
        The file's keys without ``pose``; the caller builds them into the controller's settings, which checks them.

    Raises
    ------
    ConfigError
        The file is missing (naming ``source`` and ``key``), unreadable or not TOML, or its ``pose`` names another
        controller (naming the settings file and its key).
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError(source, key, f"settings file not found: {path}")
    data = load_toml(path)
    named = data.pop("pose", pose)
    if named != pose:
        raise ConfigError(str(path), "pose", f"settings of {named!r}, used with pose = {pose!r}")
    return data


def load_settings_table(table: Any, source: str, prefix: str) -> dict[str, dict[str, Any]]:
    """A fuzz file's ``[pose_settings]`` table (controller name → settings file, relative to ``source``), read.

    Parameters
    ----------
    table : Mapping
        The table as in the file.
    source : str
        The file holding the table.
    prefix : str
        The table's key (``pose_settings``).

    Returns
    -------
    dict
        Per controller, its settings file's keys, each file checked against the controller's settings.

    Raises
    ------
    ConfigError
        Not a table, a name that is not a pose controller with settings, a value that is not a file name, or
        anything :func:`load_pose_settings` refuses; the settings' own errors name the settings file.
    """
    if not isinstance(table, Mapping):
        raise ConfigError(source, prefix, "expected a table of controller = settings file")
    out: dict[str, dict[str, Any]] = {}
    for name, file in table.items():
        key = join_key(prefix, str(name))
        if name in pose_controllers or is_reference(name):
            settings = pose_controllers.resolve(name, source=source, key=key).settings
        else:
            settings = None
        if settings is None:
            takes = [c for c, kind in pose_controllers.builtins.items() if kind.settings is not None]
            raise ConfigError(
                source, key, f"must be a pose controller with settings: {', '.join(map(repr, takes))} or yours"
            )
        if not isinstance(file, str) or not file:
            raise ConfigError(source, key, f"expected the name of a settings file (got {file!r})")
        path = Path(file) if Path(file).is_absolute() else Path(source).parent / file
        out[str(name)] = load_pose_settings(path, str(name), source=source, key=key)
        build(settings, out[str(name)], source=str(path))
    return out
