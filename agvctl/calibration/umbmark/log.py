"""Measured UMBmark end positions: the log's columns and reading it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.calibration.common import read_csv_columns
from agvctl.errors import ConfigError

__all__ = ["UMBMARK_LOG_COLUMNS", "read_umbmark_log"]

UMBMARK_LOG_COLUMNS: dict[str, str] = {
    "direction": "'cw' or 'ccw': the direction the square was driven",
    "x_m": "true end position measured on the floor (m), along the start heading, from the start point",
    "y_m": "true end position (m), to the left of the start heading",
    "est_x_m": "optional: the odometry's end position (m); 0 if absent (it drove back to its start)",
    "est_y_m": "optional: the odometry's end position (m); 0 if absent",
}
"""The UMBmark log's columns (CSV with a header row, one row per run); other columns are ignored."""


def read_umbmark_log(path: str | Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read measured UMBmark end positions and return the return-position errors.

    Parameters
    ----------
    path : str or Path
        The CSV file, one row per run, with the columns of :data:`UMBMARK_LOG_COLUMNS`.

    Returns
    -------
    cw_errors_m, ccw_errors_m : ndarray
        The clockwise and counter-clockwise runs' errors, each n × 2 (x, y), m.

    Raises
    ------
    ConfigError
        One line: a missing column, a non-finite cell, a direction other than cw/ccw, or a direction without runs.
    """
    source = str(path)
    values, text = read_csv_columns(path, ["x_m", "y_m"], ["direction"], {"direction": ("cw", "ccw")})
    try:
        est, _ = read_csv_columns(path, ["est_x_m", "est_y_m"])
    except ConfigError as exc:
        if "missing column" not in exc.problem:
            raise
        est = {"est_x_m": np.zeros_like(values["x_m"]), "est_y_m": np.zeros_like(values["y_m"])}
    directions = text["direction"]
    errors = np.column_stack([values["x_m"] - est["est_x_m"], values["y_m"] - est["est_y_m"]])
    mask = np.array([d == "cw" for d in directions])
    for name, m in (("cw", mask), ("ccw", ~mask)):
        if not np.any(m):
            raise ConfigError(source, "direction", f"no {name} runs; UMBmark needs both directions")
    return errors[mask], errors[~mask]
