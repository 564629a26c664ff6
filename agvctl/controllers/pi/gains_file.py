"""Gains files: the ``[pi]`` table ``agvctl tune --out`` writes and experiments read (``[controller] pi_gains``)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from agvctl.config import build, document_fields, dump_toml, load_toml, number
from agvctl.controllers.pi.options import PIGains
from agvctl.errors import ConfigError

__all__ = ["GainsFile", "PISettings", "gains_toml", "load_gains"]


@document_fields
@dataclass(frozen=True)
class PISettings:
    """The ``[pi]`` table of a gains file."""

    kp_v_s_rad: float = number(ge=0, doc="k_p, V s/rad.")
    ki_v_rad: float = number(ge=0, doc="k_i, V/rad.")
    dt_s: float = number(gt=0, doc="The sample period the gains were designed for, s.")
    coulomb_feedforward: bool | None = None
    """Whether the gains were verified with the Coulomb-friction feed-forward (None: not recorded). An experiment
    that reads the file must use the same (its ``[controller] coulomb_feedforward``)."""

    def validate(self, *, source: str, prefix: str) -> None:
        if self.kp_v_s_rad == 0 and self.ki_v_rad == 0:
            raise ConfigError(
                source,
                f"{prefix}.kp_v_s_rad" if prefix else "kp_v_s_rad",
                "kp_v_s_rad and ki_v_rad are both zero",
            )

    @property
    def gains(self) -> PIGains:
        return PIGains(kp=self.kp_v_s_rad, ki=self.ki_v_rad, dt_s=self.dt_s)


@document_fields
@dataclass(frozen=True)
class GainsFile:
    """A gains TOML file as written by ``agvctl tune --out``."""

    pi: PISettings
    """Its one table, ``[pi]``."""


def load_gains(path: str | Path) -> PISettings:
    """Read a gains TOML file strictly.

    Parameters
    ----------
    path : str or Path
        The file, as :func:`gains_toml` writes it.

    Returns
    -------
    PISettings
        Its ``[pi]`` table.

    Raises
    ------
    ConfigError
        Unknown keys, wrong types, bad values, in one line naming the file and key.
    """
    return build(GainsFile, load_toml(path), source=str(path)).pi


def gains_toml(gains: PIGains, *, coulomb_feedforward: bool | None = None, header: str = "") -> str:
    """The text of a gains file, read back by :func:`load_gains`.

    Parameters
    ----------
    gains : PIGains
        The gains.
    coulomb_feedforward : bool or None
        Whether the gains were verified with the Coulomb-friction feed-forward (None: not recorded).
    header : str
        Comment lines above the table (how the gains were found).

    Returns
    -------
    str
        The TOML text.
    """
    settings = PISettings(
        kp_v_s_rad=gains.kp, ki_v_rad=gains.ki, dt_s=gains.dt_s, coulomb_feedforward=coulomb_feedforward
    )
    table = {k: v for k, v in dataclasses.asdict(settings).items() if v is not None}
    return dump_toml({"pi": table}, header=header)
