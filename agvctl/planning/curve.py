"""Plane curves whose curvature is a polynomial in arc length, piece by piece (lines, arcs, smooth joins).

A :class:`Curve` is a chain of pieces; on piece p, at local arc length σ ∈ [0, L_p],

    κ(σ) = Σ_k c_pk σ^k,   θ(σ) = θ_p + ∫₀^σ κ,   (x, y)(σ) = (x_p, y_p) + d ∫₀^σ (cos θ, sin θ)

with d = ±1 the direction of travel (−1: driving in reverse, the heading stays the vehicle's). A line or an arc
(constant κ) uses the exact chord of a circular arc; any other piece a 24-point Gauss-Legendre rule on [0, σ],
exact to rounding for the short, gently turning pieces the planner makes (|Δθ| of a few radians at most).
Each piece's start pose is the previous piece's end, computed with the same rule, so the pose is continuous.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.config import document_fields
from agvctl.planning.geometry import Pose

__all__ = ["Curve", "CurveSamples", "curvature_bounds", "polyval_rows"]

FloatArray = NDArray[np.float64]

DEGREE = 9
"""Highest power of σ in a piece's curvature (the smooth joins of :mod:`agvctl.planning.joins` need 9)."""

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)
_GL_TAU = 0.5 * (_GL_X + 1.0)  # nodes on [0, 1]
_GL_W = 0.5 * _GL_W
_BOUND_SAMPLES = 65
"""Points per piece at which |κ|, |κ'| and |κ''| are sampled for their maxima (a degree ≤ 9 polynomial)."""


def polyval_rows(coeffs: FloatArray, x: FloatArray) -> FloatArray:
    """Polynomials evaluated row by row: Σ_k coeffs[..., k] x^k (Horner).

    Parameters
    ----------
    coeffs : ndarray
        Ascending coefficients, one row per element of ``x``: shape ``x.shape + (n,)``, or ``(len(x), n)``
        broadcast against an ``x`` of shape ``(len, m)``.
    x : ndarray
        Where to evaluate them.

    Returns
    -------
    ndarray
        The values, shaped like ``x``.

    Examples
    --------
    >>> polyval_rows(np.array([[1.0, 2.0], [0.0, 1.0]]), np.array([3.0, 3.0]))  # 1 + 2x and x at x = 3
    array([7., 3.])
    """
    out = np.broadcast_to(coeffs[..., -1], x.shape).copy()
    for k in range(coeffs.shape[-1] - 2, -1, -1):
        out = out * x + coeffs[..., k]
    return out


def _derivative(coeffs: FloatArray) -> FloatArray:
    """Ascending coefficients (rows) of the derivative, same width (last column zero)."""
    powers = np.arange(1, coeffs.shape[-1])
    out = np.zeros_like(coeffs)
    out[..., :-1] = coeffs[..., 1:] * powers
    return out


def _integral(coeffs: FloatArray) -> FloatArray:
    """Ascending coefficients (rows) of the integral from 0, one column wider."""
    powers = np.arange(1, coeffs.shape[-1] + 1)
    out = np.zeros(coeffs.shape[:-1] + (coeffs.shape[-1] + 1,))
    out[..., 1:] = coeffs / powers
    return out


def curvature_bounds(lengths_m: FloatArray, curvature_coeffs: FloatArray) -> FloatArray:
    """Upper bounds of the magnitudes of κ, dκ/ds and d²κ/ds² on each piece of polynomial curvature, from its
    coefficients alone.

    Each is the largest of 65 samples plus δ²/8 times the largest sample of its second derivative (δ the spacing):
    between two samples a smooth f exceeds the larger by at most δ²/8 times the largest magnitude of f''.

    Parameters
    ----------
    lengths_m : ndarray
        The pieces' lengths, m.
    curvature_coeffs : ndarray
        Ascending coefficients of κ(σ) on each piece, one row per piece (1/m, 1/m², …).

    Returns
    -------
    ndarray
        (pieces, 3): the bounds of the magnitudes of κ (1/m), dκ/ds (1/m²) and d²κ/ds² (1/m³).
    """
    k = np.atleast_2d(np.asarray(curvature_coeffs, dtype=float))
    dk = _derivative(k)
    ddk = _derivative(dk)
    d3k = _derivative(ddk)
    d4k = _derivative(d3k)
    u = np.linspace(0.0, 1.0, _BOUND_SAMPLES)
    sigma = lengths_m[:, None] * u[None, :]
    slack = (lengths_m / (_BOUND_SAMPLES - 1)) ** 2 / 8.0

    def peak(c: FloatArray) -> FloatArray:
        out: FloatArray = np.max(np.abs(polyval_rows(c[:, None, :], sigma)), axis=1)
        return out

    pairs = ((k, ddk), (dk, d3k), (ddk, d4k))
    return np.column_stack([peak(f) + slack * peak(f2) for f, f2 in pairs])


@document_fields
@dataclass(frozen=True, eq=False)
class CurveSamples:
    """A curve at an array of arc lengths: pose, and curvature with its first two derivatives in arc length."""

    x_m: FloatArray
    """x, m."""
    y_m: FloatArray
    """y, m."""
    theta_rad: FloatArray
    """The heading, rad."""
    curvature_1_m: FloatArray
    """The curvature κ, 1/m."""
    curvature_rate_1_m2: FloatArray
    """dκ/ds, 1/m²."""
    curvature_accel_1_m3: FloatArray
    """d²κ/ds², 1/m³."""


class Curve:
    """A chain of polynomial-curvature pieces from ``start`` (see the module docstring). Immutable.

    Parameters
    ----------
    start : Pose
        Pose at arc length 0.
    lengths_m : sequence of float
        Length of each piece (m, > 0).
    curvature_coeffs : array (pieces, ≤ DEGREE + 1)
        Ascending coefficients of κ(σ) on each piece (1/m, 1/m², …).
    direction : int
        +1 forwards, −1 in reverse.
    """

    def __init__(
        self, start: Pose, lengths_m: Sequence[float] | FloatArray, curvature_coeffs: ArrayLike, *, direction: int = 1
    ) -> None:
        lengths = np.asarray(lengths_m, dtype=float)
        coeffs = np.atleast_2d(np.asarray(curvature_coeffs, dtype=float))
        if len(lengths) == 0 or len(lengths) != len(coeffs) or not np.all(lengths > 0):
            raise ValueError("Curve: one positive length per row of coefficients is required")
        if coeffs.shape[1] > DEGREE + 1:
            raise ValueError(f"Curve: curvature polynomials of degree at most {DEGREE}")
        used = np.flatnonzero(np.any(coeffs != 0, axis=0))
        c = coeffs[:, : (used[-1] + 1 if used.size else 1)].copy()  # Horner only over the powers in use
        self.direction = int(direction)
        self.lengths_m = lengths
        self.s0_m = np.concatenate(([0.0], np.cumsum(lengths)[:-1]))
        self.length_m = float(np.sum(lengths))
        self._k = c
        self._dk = _derivative(c)
        self._ddk = _derivative(self._dk)
        self._th = _integral(c)
        self._const = np.all(c[:, 1:] == 0, axis=1)
        # each piece starts where the previous one ends: its displacement, turned by its start heading
        dx, dy, dth = self._local(np.arange(len(lengths)), lengths, np.zeros(len(lengths)))
        self._th0 = start.theta_rad + np.concatenate(([0.0], np.cumsum(dth)[:-1]))
        cos0, sin0 = np.cos(self._th0), np.sin(self._th0)
        self._x0 = start.x_m + np.concatenate(([0.0], np.cumsum(cos0 * dx - sin0 * dy)[:-1]))
        self._y0 = start.y_m + np.concatenate(([0.0], np.cumsum(sin0 * dx + cos0 * dy)[:-1]))

    def _local(
        self, piece: NDArray[np.int64], sigma: FloatArray, theta0: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Displacement (dx, dy) and heading change from a piece's start, in the frame turned by ``theta0``."""
        k0 = self._k[piece, 0]
        dth = polyval_rows(self._th[piece], sigma)
        half = 0.5 * k0 * sigma
        chord = self.direction * sigma * np.sinc(half / np.pi)
        dx, dy = chord * np.cos(theta0 + half), chord * np.sin(theta0 + half)
        var = ~self._const[piece]
        if np.any(var):
            nodes = sigma[var, None] * _GL_TAU[None, :]
            th = theta0[var, None] + polyval_rows(self._th[piece[var]][:, None, :], nodes)
            scale = self.direction * sigma[var]
            dx[var] = scale * np.einsum("ij,j->i", np.cos(th), _GL_W)
            dy[var] = scale * np.einsum("ij,j->i", np.sin(th), _GL_W)
        return dx, dy, dth

    def piece_at(self, s_m: FloatArray) -> NDArray[np.int64]:
        """Index of the piece containing each arc length (clamped to the curve)."""
        return np.clip(np.searchsorted(self.s0_m, s_m, side="right") - 1, 0, len(self.lengths_m) - 1)

    def evaluate(self, s_m: ArrayLike) -> CurveSamples:
        """The curve at arc lengths ``s_m`` (clamped to [0, length_m])."""
        s = np.clip(np.atleast_1d(np.asarray(s_m, dtype=float)).ravel(), 0.0, self.length_m)
        p = self.piece_at(s)
        sigma = np.minimum(s - self.s0_m[p], self.lengths_m[p])
        th0 = self._th0[p]
        dx, dy, dth = self._local(p, sigma, th0)
        return CurveSamples(
            x_m=self._x0[p] + dx,
            y_m=self._y0[p] + dy,
            theta_rad=th0 + dth,
            curvature_1_m=polyval_rows(self._k[p], sigma),
            curvature_rate_1_m2=polyval_rows(self._dk[p], sigma),
            curvature_accel_1_m3=polyval_rows(self._ddk[p], sigma),
        )

    def curvatures(self, s_m: ArrayLike, orders: int = 3) -> tuple[FloatArray, ...]:
        """κ, dκ/ds and d²κ/ds² at arc lengths ``s_m`` (clamped to [0, length_m]), without the pose.

        Parameters
        ----------
        s_m : array_like
            Arc lengths, m.
        orders : int
            How many of the three, from κ (1: κ alone).

        Returns
        -------
        tuple of ndarray
            κ (1/m), dκ/ds (1/m²), d²κ/ds² (1/m³): the first ``orders`` of them.
        """
        s = np.clip(np.atleast_1d(np.asarray(s_m, dtype=float)).ravel(), 0.0, self.length_m)
        p = self.piece_at(s)
        sigma = np.minimum(s - self.s0_m[p], self.lengths_m[p])
        return tuple(polyval_rows(c[p], sigma) for c in (self._k, self._dk, self._ddk)[:orders])

    def end_pose(self) -> Pose:
        """The pose at the end of the curve."""
        e = self.evaluate([self.length_m])
        return Pose(float(e.x_m[0]), float(e.y_m[0]), float(e.theta_rad[0]))

    def piece_bounds(self) -> FloatArray:
        """(pieces, 3): upper bounds of |κ|, |dκ/ds| and |d²κ/ds²| on each piece (:func:`curvature_bounds`)."""
        return curvature_bounds(self.lengths_m, self._k)
