"""The friction experiment's log: its columns, :class:`FrictionLog`, and reading and writing it as CSV."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.calibration.common import read_csv_columns
from agvctl.config import document_fields

__all__ = ["FRICTION_LOG_COLUMNS", "SIDES", "FrictionLog", "Side", "read_friction_log"]

Side = Literal["left", "right"]
SIDES: tuple[Side, Side] = ("left", "right")

FRICTION_LOG_COLUMNS: dict[str, str] = {
    "t_s": "sample time (s), one row per control sample",
    "phase": "'hold' (the speed loops hold a constant setpoint), 'ramp' (open-loop slow DA ramp from standstill) "
    "or anything else (ignored, e.g. 'idle')",
    "setpoint_omega_motor_left_rad_s": "left speed-loop setpoint, motor shaft (rad/s); constant within a hold "
    "window, ignored elsewhere",
    "setpoint_omega_motor_right_rad_s": "right speed-loop setpoint (rad/s)",
    "omega_motor_left_rad_s": "measured left motor speed (rad/s)",
    "omega_motor_right_rad_s": "measured right motor speed (rad/s)",
    "da_voltage_left_v": "left DA converter output (V): the control input u of eqs 65-69, before the amplifier",
    "da_voltage_right_v": "right DA converter output (V)",
}
"""The friction log's columns (CSV with a header row; other columns are ignored). Values must be finite."""


@document_fields
@dataclass(frozen=True)
class FrictionLog:
    """A friction experiment's log, one row per control sample (columns as :data:`FRICTION_LOG_COLUMNS`)."""

    t_s: NDArray[np.float64]
    """The sample times, s."""
    phase: tuple[str, ...]
    """Each sample's phase: ``hold``, ``ramp`` or anything else (ignored)."""
    setpoint_rad_s: NDArray[np.float64]
    """n × 2 speed-loop setpoints (left, right), motor shaft, rad/s."""
    omega_motor_rad_s: NDArray[np.float64]
    """n × 2 measured motor speeds (left, right), rad/s."""
    da_voltage_v: NDArray[np.float64]
    """n × 2 DA output voltages (left, right): the control input u of eqs 65-69, V."""
    source: str = "<simulated>"
    """Where the log came from (for error messages)."""

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """The numeric columns by their CSV names (``phase`` is text; see :meth:`write_csv`)."""
        return {
            "t_s": self.t_s,
            "setpoint_omega_motor_left_rad_s": self.setpoint_rad_s[:, 0],
            "setpoint_omega_motor_right_rad_s": self.setpoint_rad_s[:, 1],
            "omega_motor_left_rad_s": self.omega_motor_rad_s[:, 0],
            "omega_motor_right_rad_s": self.omega_motor_rad_s[:, 1],
            "da_voltage_left_v": self.da_voltage_v[:, 0],
            "da_voltage_right_v": self.da_voltage_v[:, 1],
        }

    def write_csv(self, path: str | Path) -> None:
        """Write the log as CSV in the :data:`FRICTION_LOG_COLUMNS` format (atomically)."""
        from agvctl.fileio import atomic_open

        cols = self.columns()
        names = ["t_s", "phase", *[n for n in cols if n != "t_s"]]
        with atomic_open(path) as fh:
            fh.write(",".join(names) + "\n")
            for i in range(len(self.t_s)):
                cells = [f"{self.t_s[i]:.12g}", self.phase[i], *(f"{cols[n][i]:.12g}" for n in names[2:])]
                fh.write(",".join(cells) + "\n")


def read_friction_log(path: str | Path) -> FrictionLog:
    """Read a friction log.

    Parameters
    ----------
    path : str or Path
        The CSV file, with the columns of :data:`FRICTION_LOG_COLUMNS`.

    Returns
    -------
    FrictionLog
        The log.

    Raises
    ------
    ConfigError
        A missing column, an empty or non-finite cell, naming the file and the column or line.
    """
    numeric = [c for c in FRICTION_LOG_COLUMNS if c != "phase"]
    values, text = read_csv_columns(path, numeric, ["phase"])
    return FrictionLog(
        t_s=values["t_s"],
        phase=tuple(p.lower() for p in text["phase"]),
        setpoint_rad_s=np.column_stack(
            [values["setpoint_omega_motor_left_rad_s"], values["setpoint_omega_motor_right_rad_s"]]
        ),
        omega_motor_rad_s=np.column_stack([values["omega_motor_left_rad_s"], values["omega_motor_right_rad_s"]]),
        da_voltage_v=np.column_stack([values["da_voltage_left_v"], values["da_voltage_right_v"]]),
        source=str(path),
    )
