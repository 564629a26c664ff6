"""What every identification procedure shares: an estimate with its standard error, and reading CSV logs strictly."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.config import MAX_LOG_BYTES, document_fields, read_text
from agvctl.errors import ConfigError

__all__ = ["Estimate", "read_csv_columns"]


@document_fields
@dataclass(frozen=True)
class Estimate:
    """An identified quantity: the estimate, its standard error (1σ) and, on the simulator, the true value, all in
    the quantity's unit."""

    estimate: float
    """The estimate."""
    stderr: float
    """One standard error. 0 when the procedure saw no scatter (noise off); NaN when it cannot be estimated."""
    truth: float | None = None
    """The plant's value (simulated procedures only)."""

    def as_dict(self) -> dict[str, float | None]:
        """``{"estimate", "stderr"[, "truth"]}`` for JSON (NaN stderr becomes ``None``)."""
        out: dict[str, float | None] = {
            "estimate": self.estimate,
            "stderr": self.stderr if math.isfinite(self.stderr) else None,
        }
        if self.truth is not None:
            out["truth"] = self.truth
        return out

    @property
    def error(self) -> float | None:
        """estimate − truth (``None`` without a truth)."""
        return None if self.truth is None else self.estimate - self.truth


def _rows(path: str | Path, source: str) -> list[tuple[int, list[str]]]:
    """The rows of a CSV file with their line numbers, blank and comment lines left out."""
    reader = csv.reader(io.StringIO(read_text(path, MAX_LOG_BYTES), newline=""))
    try:
        numbered = [(reader.line_num, row) for row in reader]
    except csv.Error as exc:
        raise ConfigError(source, "", f"cannot read: {exc}") from None
    return [
        (n, r)
        for n, r in numbered
        if r and not (len(r) == 1 and not r[0].strip()) and not r[0].lstrip().startswith("#")
    ]


def read_csv_columns(
    path: str | Path,
    numeric: Sequence[str],
    text: Sequence[str] = (),
    choices: Mapping[str, Sequence[str]] | None = None,
) -> tuple[dict[str, NDArray[np.float64]], dict[str, list[str]]]:
    """Read the named columns of a CSV log with a header row; other columns are ignored.

    Blank lines and lines starting with ``#`` are skipped; a byte-order mark (Excel's "CSV UTF-8") is dropped.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    numeric : sequence of str
        The columns whose every cell must parse as a finite number.
    text : sequence of str
        The columns read as text.
    choices : Mapping of str to sequence of str, or None
        For text columns that hold one of a few values, those values (in lower case; the file's are matched in
        any case).

    Returns
    -------
    numbers : dict of str to ndarray
        The numeric columns.
    texts : dict of str to list of str
        The text columns (those with choices in lower case).

    Raises
    ------
    ConfigError
        One line naming the file and the first missing column, or the line (counted in the file, comments
        included) and the column of the first cell that is empty, not a finite number or not one of its choices.
    """
    source = str(path)
    numbered = _rows(path, source)
    if not numbered:
        raise ConfigError(source, "", "empty file (expected a header row naming the columns)")
    header = [h.strip() for h in numbered[0][1]]
    missing = [name for name in (*numeric, *text) if name not in header]
    if missing:
        plural = "s" if len(missing) > 1 else ""
        raise ConfigError(source, "", f"missing column{plural} {', '.join(missing)}")
    body = numbered[1:]
    if not body:
        raise ConfigError(source, "", "no data rows")
    index = {name: header.index(name) for name in (*numeric, *text)}
    values: dict[str, NDArray[np.float64]] = {}
    for name in numeric:
        col = np.empty(len(body))
        j = index[name]
        for i, (line, row) in enumerate(body):
            cell = row[j].strip() if j < len(row) else ""
            try:
                value = float(cell)
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                shown = cell if cell else "empty"
                raise ConfigError(source, f"line {line}", f"{name} is not a finite number ({shown})")
            col[i] = value
        values[name] = col
    strings = {name: [(row[index[name]].strip() if index[name] < len(row) else "") for _, row in body] for name in text}
    for name, allowed in (choices or {}).items():
        strings[name] = [cell.lower() for cell in strings[name]]
        for (line, _row), cell in zip(body, strings[name], strict=True):
            if cell not in allowed:
                raise ConfigError(
                    source, f"line {line}", f"{name} must be {' or '.join(allowed)} (got {cell or 'empty'!r})"
                )
    return values, strings
