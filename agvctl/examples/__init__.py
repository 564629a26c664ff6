"""The shipped example files, installed with the package: the experiments (``experiments/``, with their fuzz,
robustness and CI files) and the path files (``trajectories/``) they name, so the examples and the gallery's scripts
run outside a checkout.

>>> from agvctl.scenario.experiment import load_experiment
>>> load_experiment(example_path("experiments/figure8.toml")).spec.name
'figure8'
"""

from __future__ import annotations

import shutil
from pathlib import Path

from agvctl.errors import ConfigError

__all__ = ["EXAMPLE_FOLDERS", "copy_examples", "example_path"]

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
    for folder in EXAMPLE_FOLDERS:
        for source in sorted((_ROOT / folder).rglob("*")):
            if source.is_file() and source.suffix in _SUFFIXES:
                target = destination / folder / source.relative_to(_ROOT / folder)
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(source, target)
                written.append(target)
    return written
