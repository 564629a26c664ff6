"""Angles: the one wrapping convention of the package."""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["wrap_angle"]

AngleT = TypeVar("AngleT", float, NDArray[np.float64])


def wrap_angle(angle_rad: AngleT) -> AngleT:
    """``angle_rad`` (a number or an array) wrapped to [−π, π)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
