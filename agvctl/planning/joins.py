"""Smooth joins: where the curvature of a path would jump, a window in which it changes smoothly instead.

Why not a clothoid (κ linear in s): where its sharpness dκ/ds starts or stops, the wheel accelerations
v̇ = s̈ (d ∓ κ b/2) ∓ ṡ² (dκ/ds) b/2 jump, so the wheel jerk is unbounded at any speed ṡ > 0. A join here has
continuous dκ/ds (and bounded d²κ/ds²), so the wheel speed, acceleration and jerk all stay bounded.

The window has length L, centred on the join of two constant curvatures κ₁ → κ₂. With u = σ/L ∈ [0, 1]:

    L κ(σ) = L κ₁ + L (κ₂ − κ₁) (3u² − 2u³) + Σᵢ pᵢ u²(1 − u)² (u − ½)ⁱ,   i = 0 … 5

κ and dκ/ds equal the requested values at both ends of the window. The six pᵢ are chosen so that the window
ends at exactly the requested pose (heading and both coordinates: three conditions) with the least
∫ (d²κ/du²)² du of the correction (a Gauss-Newton iteration on the minimum-norm step; weighting the first
or third derivative instead made the slalom 24 % and 5 % slower at the same limits). So the path is the
requested geometry everywhere outside the windows: every segment's end point outside a window, the final
pose, and the lines and arcs themselves are kept exactly; inside a window the path deviates from the corner
it smooths, by :attr:`JoinWindow.deviation_m` (the largest distance from a point of the window to the corner).

The window length comes from the limits: the shortest window through which the speed the neighbouring
segments allow (:func:`~agvctl.planning.speed.section_limits`) can be kept, within half of each neighbour; where
that one leaves the corner by more than the path's tolerance (``limits.drawn_path_tolerance_m``), the window of
the highest speed limit among those within it (the speed planner slows down through a window that cannot keep
the speed).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numpy.polynomial import polynomial as P
from numpy.typing import NDArray

from agvctl.planning.curve import DEGREE, Curve, curvature_bounds
from agvctl.planning.drawn import piece_distance_m
from agvctl.planning.geometry import Pose, advance
from agvctl.planning.spec import WheelLimits
from agvctl.planning.speed import section_limits

__all__ = ["JoinWindow", "design_join", "join_shape"]

FloatArray = NDArray[np.float64]

_MODES = 6
_DEVIATION_SAMPLES = 257
_SCAN = 24
_GL_X, _GL_W = np.polynomial.legendre.leggauss(32)
_TAU, _W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W
_SMOOTHSTEP = np.array([0.0, 0.0, 3.0, -2.0])


def _mode_table() -> tuple[FloatArray, FloatArray, FloatArray]:
    """Coefficients of the modes u²(1−u)²(u−½)ⁱ, of their integrals at the nodes, and the weight's inverse."""
    modes = np.zeros((_MODES, DEGREE + 1))
    for i in range(_MODES):
        c = P.polymul([0.0, 0.0, 1.0, -2.0, 1.0], P.polypow([-0.5, 1.0], i))
        modes[i, : len(c)] = c
    heading = np.array([P.polyval(_TAU, P.polyint(m)) for m in modes])  # ∂θ/∂pᵢ at the nodes
    d2 = np.array([P.polyval(_TAU, P.polyder(m, 2)) for m in modes])
    weight = (d2 * _W) @ d2.T
    return modes, heading, np.linalg.inv(weight)


_MODE_COEFFS, _MODE_HEADING, _WEIGHT_INV = _mode_table()
_MODE_TOTAL = np.array([P.polyval(1.0, P.polyint(m)) for m in _MODE_COEFFS])


def _target(k1: float, k2: float) -> complex:
    """End point of the requested window (half at L κ₁, half at L κ₂, unit length, from heading 0)."""

    def chord(k: float, th0: float) -> complex:
        return complex(0.5 * np.sinc(0.25 * k / np.pi) * np.exp(1j * (th0 + 0.25 * k)))

    return chord(k1, 0.0) + chord(k2, 0.5 * k1)


def join_shape(k1_l: float, k2_l: float, guess: FloatArray | None = None) -> FloatArray | None:
    """The mode weights p of a window between two curvatures, by the Gauss-Newton iteration of the module notes.

    Parameters
    ----------
    k1_l, k2_l : float
        The curvatures before and after the join times the window's length, κ₁L and κ₂L (dimensionless).
    guess : ndarray or None
        Weights to start from (a neighbouring window's); None starts from zero.

    Returns
    -------
    ndarray or None
        The six weights pᵢ, or None if the iteration does not converge (the window is too long for its
        curvatures).
    """
    base = np.zeros(DEGREE + 1)
    base[0] = k1_l
    base[:4] += (k2_l - k1_l) * _SMOOTHSTEP
    base_heading = P.polyval(_TAU, P.polyint(base))
    base_total = P.polyval(1.0, P.polyint(base))
    goal = _target(k1_l, k2_l)
    p = np.zeros(_MODES) if guess is None else guess.copy()
    for _ in range(40):
        theta = base_heading + p @ _MODE_HEADING
        e = np.exp(1j * theta)
        z = complex(e @ _W)
        r = np.array([base_total + p @ _MODE_TOTAL - 0.5 * (k1_l + k2_l), z.real - goal.real, z.imag - goal.imag])
        if not np.all(np.isfinite(r)):
            return None
        if np.max(np.abs(r)) < 1e-13:
            return p
        dz = (1j * e * _MODE_HEADING) @ _W
        jac = np.vstack([_MODE_TOTAL, dz.real, dz.imag])
        p = p - _WEIGHT_INV @ jac.T @ np.linalg.solve(jac @ _WEIGHT_INV @ jac.T, r)
    return None


def _coeffs(k1: float, k2: float, length_m: float, p: FloatArray) -> FloatArray:
    """κ(σ) coefficients (ascending powers of σ in m) of a window of length L with mode weights p."""
    scaled = np.zeros(DEGREE + 1)
    scaled[0] = k1 * length_m
    scaled[:4] += (k2 - k1) * length_m * _SMOOTHSTEP
    scaled += p @ _MODE_COEFFS
    return scaled / length_m ** (np.arange(DEGREE + 1) + 1.0)


class JoinWindow:
    """A designed window: its length, curvature coefficients, bounds and deviation from the corner.

    Parameters
    ----------
    k1 : float
        The curvature before the join, 1/m.
    k2 : float
        The curvature after it, 1/m.
    length_m : float
        The window's length L, m.
    p : ndarray
        The mode weights, from :func:`join_shape`.
    """

    def __init__(self, k1: float, k2: float, length_m: float, p: FloatArray) -> None:
        coeffs = _coeffs(k1, k2, length_m, p)
        self._set(k1, k2, length_m, coeffs, curvature_bounds(np.array([length_m]), coeffs[None, :])[0])

    def _set(self, k1: float, k2: float, length_m: float, coeffs: FloatArray, bounds: FloatArray) -> None:
        self.length_m = length_m
        self.coeffs = coeffs
        k0, k1_max, k2_max = (float(b) for b in bounds)
        self.bounds = (k0, k1_max, k2_max)
        """max |κ| (1/m), |dκ/ds| (1/m²), |d²κ/ds²| (1/m³) over the window."""
        self._corner = (k1, k2)

    @classmethod
    def many(cls, k1: float, k2: float, lengths_m: list[float], ps: list[FloatArray]) -> list[JoinWindow]:
        """Windows between the same curvatures, their bounds computed together (the same as each window's own, in a
        fraction of the time).

        Parameters
        ----------
        k1, k2 : float
            The curvatures before and after the join, 1/m.
        lengths_m : list of float
            The windows' lengths, m.
        ps : list of ndarray
            Their mode weights, from :func:`join_shape`, one per length.

        Returns
        -------
        list of JoinWindow
            One window per length, in order.
        """
        if not lengths_m:
            return []
        coeffs = np.array([_coeffs(k1, k2, length, p) for length, p in zip(lengths_m, ps, strict=True)])
        bounds = curvature_bounds(np.array(lengths_m), coeffs)
        out = []
        for length, c, b in zip(lengths_m, coeffs, bounds, strict=True):
            w = cls.__new__(cls)
            w._set(k1, k2, length, c, b)
            out.append(w)
        return out

    @functools.cached_property
    def deviation_m(self) -> float:
        """The largest distance from a point of the window to the corner it replaces (the two halves of the
        neighbouring segments it spans, as drawn), m: the exact distance of 257 points of the window to them.
        Computed when first asked."""
        k1, k2 = self._corner
        half = 0.5 * self.length_m
        origin = Pose(0.0, 0.0, 0.0)
        mid = advance(origin, displacement_m=half, curvature_1_m=k1)
        window = Curve(origin, [self.length_m], self.coeffs[None, :])
        w = window.evaluate(np.linspace(0.0, self.length_m, _DEVIATION_SAMPLES))
        first = piece_distance_m(w.x_m, w.y_m, origin, half, k1)
        second = piece_distance_m(w.x_m, w.y_m, mid, half, k2)
        return float(np.max(np.minimum(first, second)))


def design_join(
    k1: float,
    k2: float,
    *,
    speed_m_s: float,
    cap_m_s: float | None,
    limits: WheelLimits,
    half_b_m: float,
    max_length_m: float,
    max_deviation_m: float = math.inf,
) -> JoinWindow:
    """The shortest window through which a wheel-limited speed can be kept, shortened further where it would
    leave the corner by more than ``max_deviation_m``.

    Parameters
    ----------
    k1 : float
        The curvature before the join, 1/m.
    k2 : float
        The curvature after it, 1/m.
    speed_m_s : float
        The path speed to keep through the window, m/s.
    cap_m_s : float or None
        The neighbouring segments' speed cap (None: none), m/s.
    limits : WheelLimits
        The wheel limits.
    half_b_m : float
        Half the wheel separation, b/2, m.
    max_length_m : float
        The longest window allowed (half of each neighbour), m.
    max_deviation_m : float
        The largest :attr:`JoinWindow.deviation_m` allowed, m.

    Returns
    -------
    JoinWindow
        The shortest window that keeps the speed (the longest that converges if none does); if that one leaves
        the corner by more than ``max_deviation_m``, the fastest of those that do not (:func:`_within`). The speed
        planner slows down through a window that cannot keep the speed.

    Raises
    ------
    ValueError
        No window converges between the two curvatures.
    """
    best: JoinWindow | None = None
    guess: FloatArray | None = None

    def shape(length_m: float) -> FloatArray | None:
        nonlocal guess
        p = join_shape(k1 * length_m, k2 * length_m, guess)
        guess = guess if p is None else p
        return p

    def attempt(length_m: float) -> JoinWindow | None:
        p = shape(length_m)
        return None if p is None else JoinWindow(k1, k2, length_m, p)

    def scan(lengths_m: FloatArray) -> list[JoinWindow]:
        shaped = [(float(length), shape(float(length))) for length in lengths_m]
        kept = [(length, p) for length, p in shaped if p is not None]
        return JoinWindow.many(k1, k2, [length for length, _ in kept], [p for _, p in kept])

    def speed(w: JoinWindow) -> float:
        return section_limits(w.length_m, w.bounds, cap_m_s, limits, half_b_m).speed_m_s

    hi = max_length_m
    while best is None and hi > 1e-4 * max_length_m:
        best = attempt(hi)
        hi = hi if best is not None else 0.5 * hi
    if best is None:
        raise ValueError(f"no smooth join between curvatures {k1:g} and {k2:g} 1/m converges")
    best = _shortest_keeping(best, lambda w: speed(w) >= speed_m_s * (1.0 - 1e-6), attempt)
    if best.deviation_m <= max_deviation_m:
        return best
    guess = None
    return _within(max_length_m, max_deviation_m, scan, speed)


def _shortest_keeping(
    longest: JoinWindow, fast_enough: Callable[[JoinWindow], bool], attempt: Callable[[float], JoinWindow | None]
) -> JoinWindow:
    """The shortest window that keeps the speed, by bisection on log L down from ``longest`` (``longest`` itself if
    it cannot keep it)."""
    if not fast_enough(longest):
        return longest
    best, hi = longest, longest.length_m
    lo = 1e-3 * hi
    for _ in range(14):
        mid = math.sqrt(lo * hi)
        w = attempt(mid)
        if w is not None and fast_enough(w):
            hi, best = mid, w
        else:
            lo = mid
    return best


def _within(
    max_length_m: float,
    max_deviation_m: float,
    scan: Callable[[FloatArray], list[JoinWindow]],
    speed: Callable[[JoinWindow], float],
) -> JoinWindow:
    """The window that leaves the corner by at most ``max_deviation_m`` with the highest speed limit (the shortest
    of those that tie), among :data:`_SCAN` lengths spaced evenly in log L from 10⁻⁴ of ``max_length_m`` to it.

    A scan, not a bisection: for curvature jumps of |Δκ| L above about 1 neither the deviation nor the speed limit
    is monotonic in L (the figure-8's crossing keeps its 0.5 m/s within 5 mm at L = 1.6 m but not at 1.4 or 2.4 m).
    """
    windows = scan(np.geomspace(1e-4 * max_length_m, max_length_m, _SCAN))  # those that converge
    candidates = [(-speed(w), w.length_m, w) for w in windows]
    for _, _, w in sorted(candidates, key=lambda c: (c[0], c[1])):  # fastest first: its deviation decides
        if w.deviation_m <= max_deviation_m:
            return w
    raise ValueError(f"no smooth join within {max_deviation_m:g} m of the corner converges")
