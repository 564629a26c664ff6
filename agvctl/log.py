"""The simulation log: one row per sample, named columns in SI units."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.config import document_fields
from agvctl.fileio import write_csv

__all__ = ["PLANT_LOG_COLUMNS", "SimLog"]

PLANT_LOG_COLUMNS = (
    "t_s",
    "da_code_left",
    "da_code_right",
    "da_voltage_left_v",
    "da_voltage_right_v",
    "da_clipped_left",
    "da_clipped_right",
    "motor_voltage_left_v",
    "motor_voltage_right_v",
    "current_left_a",
    "current_right_a",
    "current_limited_left",
    "current_limited_right",
    "current_limited_fraction_left",
    "current_limited_fraction_right",
    "current_peak_left_a",
    "current_peak_right_a",
    "omega_motor_left_rad_s",
    "omega_motor_right_rad_s",
    "wheel_accel_left_m_s2",
    "wheel_accel_right_m_s2",
    "wheel_accel_peak_left_m_s2",
    "wheel_accel_peak_right_m_s2",
    "x_m",
    "y_m",
    "theta_rad",
    "speed_m_s",
    "yaw_rate_rad_s",
)
"""The plant's columns. Row k holds the state at t_k = k·T_s and the input held over [t_k, t_k+1); currents,
accelerations and speeds are at t_k just after the input switched, ``*_peak_*`` and ``*_fraction_*`` are over
the interval's integration substeps, ``current_limited_*`` is 1 if the limit acted anywhere in the interval.
The last row is the final state with the last input still applied."""


@document_fields
@dataclass
class SimLog:
    """Named, equal-length columns (numpy arrays) of one run.

    ``log["x_m"]`` is a column, ``len(log)`` the number of rows, ``"x_m" in log`` whether it has the column.
    """

    columns: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    """The columns by name, each name ending in its unit (``x_m``, ``current_left_a``; see
    :data:`PLANT_LOG_COLUMNS`)."""

    def __getitem__(self, name: str) -> NDArray[np.float64]:
        return self.columns[name]

    def __contains__(self, name: object) -> bool:
        return name in self.columns

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        return len(self.columns["t_s"]) if self.columns else 0

    def row(self, index: int) -> dict[str, float]:
        """One row as a mapping (``-1``: the final sample)."""
        return {name: float(values[index]) for name, values in self.columns.items()}

    def peak_abs(self, name: str) -> float:
        """max |column| over the run."""
        return float(np.max(np.abs(self.columns[name]))) if len(self) else 0.0

    def to_csv(self, path: str | Path) -> None:
        """Write the log as CSV at full precision (12 significant digits), atomically."""
        write_csv(path, self.columns)
