"""The shipped example files, installed with the package: the experiments (``experiments/``, with their fuzz,
robustness and CI files), the path files (``trajectories/``) they name and the controllers of the user's own they
name by a file reference (``pose = "pure_pursuit.py:PurePursuit"``), so the examples and the gallery's scripts run
outside a checkout.

>>> from agvctl.scenario.experiment import load_experiment
>>> load_experiment(example_path("experiments/figure8.toml")).spec.name
'figure8'
"""

from __future__ import annotations

import shutil
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from agvctl.config.references import is_reference
from agvctl.errors import ConfigError

__all__ = ["EXAMPLE_FOLDERS", "copy_examples", "example_files", "example_path"]

EXAMPLE_FOLDERS = ("experiments", "trajectories")
"""The folders of example files, side by side as in the repository (an experiment names its path file as
``../trajectories/NAME.toml``)."""

_ROOT = Path(__file__).resolve().parent
_SUFFIXES = (".toml", ".csv")


def example_path(name: str) -> Path:
    """The installed example file ``name``, e.g. ``"experiments/figure8.toml"``.

    Parameters
    ----------
    name : str
        The file's path in the repository, under one of :data:`EXAMPLE_FOLDERS`.

    Returns
    -------
    Path
        Where it is installed.

    Raises
    ------
    ConfigError
        ``name`` is not a shipped example file.
    """
    path = _ROOT / name
    if Path(name).parts[:1] not in [(f,) for f in EXAMPLE_FOLDERS] or ".." in Path(name).parts or not path.is_file():
        raise ConfigError("example_path", "name", f"no shipped example file {name!r}")
    return path


def copy_examples(destination: str | Path) -> list[Path]:
    """Copy the example files into ``destination`` (``experiments/`` and ``trajectories/`` side by side), to run
    and change them there.

    Parameters
    ----------
    destination : str or Path
        A folder that does not exist yet, or an empty one.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ConfigError
        ``destination`` exists and is not an empty folder (nothing of it is replaced).
    """
    destination = Path(destination)
    if destination.exists() and (not destination.is_dir() or any(destination.iterdir())):
        raise ConfigError(str(destination), "", "exists and is not an empty folder; nothing copied")
    written = []
    for name in example_files():
        target = destination / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(_ROOT / name, target)
        written.append(target)
    return written


def example_files() -> list[str]:
    """The shipped example files, by their paths in the repository: every experiment, path and CSV file, and each
    Python file one of them names by a file reference (the controllers of the examples of one's own code).

    Returns
    -------
    list of str
        The paths, sorted, e.g. ``"experiments/figure8.toml"``.
    """
    names: set[str] = set()
    for folder in EXAMPLE_FOLDERS:
        for source in (_ROOT / folder).rglob("*"):
            if source.is_file() and source.suffix in _SUFFIXES:
                name = source.relative_to(_ROOT).as_posix()
                names.add(name)
                if source.suffix == ".toml":
                    names.update(_code_named_by(name))
    return sorted(names)


def _code_named_by(name: str) -> Iterator[str]:
    """The example Python files the TOML file ``name`` names by a file reference (a key or a value)."""
    folder = Path(name).parent
    for text in _strings(tomllib.loads((_ROOT / name).read_text(encoding="utf-8"))):
        where = text.partition(":")[0].strip()
        if is_reference(text) and where.endswith(".py"):
            code = Path(folder, where)
            if ".." not in code.parts and (_ROOT / code).is_file():
                yield code.as_posix()


def _strings(value: Any) -> Iterator[str]:
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for key, item in value.items():
            yield key
            yield from _strings(item)
    elif isinstance(value, list):
        for item in value:
            yield from _strings(item)
