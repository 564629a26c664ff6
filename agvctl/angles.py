"""Angles: the one wrapping convention of the package."""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["wrap_angle"]

AngleT = TypeVar("AngleT", float, NDArray[np.float64])


def wrap_angle(angle_rad: AngleT) -> AngleT:
    """An angle wrapped to [−π, π).

    Parameters
    ----------
    angle_rad : float or ndarray
        The angle (or angles), rad.

    Returns
    -------
    float or ndarray
        The same angle in [−π, π), rad.

    Examples
    --------
    >>> round(wrap_angle(3 * math.pi / 2), 6)
    -1.570796
    """
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
