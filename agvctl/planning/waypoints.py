"""Waypoint paths: a curvature-smooth curve through every waypoint, with the headings given or chosen.

The curve is a quintic spline r(u) = (x(u), y(u)) in the chord-length parameter u (u_i = the polyline's length
up to waypoint i, so |r'| ≈ 1), with simple knots at the waypoints and mid-way between them: r is four
times continuously differentiable, so κ and dκ/ds are continuous and d²κ/ds² bounded, which keeps the wheel
jerk bounded at speed (see :mod:`agvctl.planning.joins` for why a clothoid spline does not). Among such
splines through the waypoints (and with r'(u_i) = (cos θ_i, sin θ_i) where ``theta_deg`` is given) it is the
one with the least ∫ |r'''|² du (plus 10⁻³ ∫ |r''|² du, which makes two waypoints a straight line): the
quintic, minimum-jerk-in-u choice of WPILib's splines, with the free headings chosen by the same criterion.

For the planner the spline is turned into a :class:`~agvctl.planning.curve.Curve`: κ(s) as a cubic Hermite
interpolant in arc length of the spline's κ and dκ/ds at 16 nodes per waypoint interval, more where that would
leave the spline by more than the path's tolerance (sharp turns between close waypoints). The curve starts at
the first waypoint and stays within the tolerance of the spline, the path the file draws (the largest distance is
``drawn_path_deviation_m`` of the reference; :mod:`agvctl.planning.drawn`).
A spline whose speed |r'| drops below :data:`CUSP_SPEED` (it nearly stops and turns back: a cusp, which a
forward-driving vehicle cannot follow) is refused with a one-line :class:`~agvctl.errors.ConfigError`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.interpolate import BSpline
from scipy.sparse.linalg import splu

from agvctl.config import document_fields
from agvctl.errors import ConfigError
from agvctl.planning.curve import Curve
from agvctl.planning.drawn import CHORD_ERROR_M, MAX_VERTICES, SPACING_M, DrawnPath
from agvctl.planning.geometry import Pose
from agvctl.planning.spec import Waypoint

__all__ = ["CUSP_SPEED", "MAX_NODES_PER_SPAN", "NODES_PER_SPAN", "WaypointCurve", "waypoint_curve"]

FloatArray = NDArray[np.float64]

CUSP_SPEED = 0.2
"""Least |dr/du| allowed along the spline (1 = moving at the polyline's pace): below it the path folds back."""

_K = 5
_SPANS = 2  # knot spans per waypoint interval
NODES_PER_SPAN = 8
"""Hermite pieces of the curve per knot span of the spline, unless the curve would leave the spline by more than
the path's tolerance."""

MAX_NODES_PER_SPAN = 256
"""The most Hermite pieces per knot span: a curve that still leaves the spline by more than the path's tolerance is
refused, naming ``limits.drawn_path_tolerance_m``."""
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)


def _basis(t: FloatArray, u: FloatArray, nu: int) -> sparse.csr_matrix:
    """Values (nu = 0) or derivatives of every B-spline basis function at u: a sparse (len(u), n) matrix.

    Each row has at most ``_K + 1`` nonzeros (a B-spline's support is ``_K + 1`` knot spans); a derivative is the
    basis of degree ``_K - nu`` on the inner knots times ``nu`` differencing matrices (de Boor's derivative rule).
    """
    ops: list[sparse.spmatrix] = []
    knots = t
    for d in range(nu):
        k = _K - d
        m = len(knots) - k - 1  # coefficients at degree k
        scale = k / (knots[k + 1 : k + m] - knots[1:m])
        ops.append(sparse.diags([-scale, scale], [0, 1], shape=(m - 1, m)))
        knots = knots[1:-1]
    out = sparse.csr_matrix(BSpline.design_matrix(u, knots, _K - nu, extrapolate=False))
    for op in reversed(ops):
        out = out @ op
    return sparse.csr_matrix(out)


def _gram(t: FloatArray, nu: int) -> sparse.csr_matrix:
    """∫ B^(nu)ᵀ B^(nu) du over the knot spans (Gauss-Legendre, exact for these degrees): banded, sparse."""
    edges = np.unique(t)
    a, b = edges[:-1, None], edges[1:, None]
    u = (0.5 * (b - a) * (_GL_X + 1.0) + a).ravel()
    w = (0.5 * (b - a) * _GL_W).ravel()
    d = _basis(t, u, nu)
    return sparse.csr_matrix(d.T @ sparse.diags(w) @ d)


def _fit(points: FloatArray, headings: Sequence[float | None]) -> tuple[BSpline, FloatArray]:
    """The spline through ``points`` (see the module docstring) and the waypoints' parameters u_i.

    The optimality conditions are a sparse, banded system (each B-spline overlaps ``2 _K + 1`` others), solved
    by a sparse LU factorisation: work and memory grow linearly with the number of waypoints.
    """
    u_i = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
    steps = np.linspace(0.0, 1.0, _SPANS + 1)[1:-1]
    interior = np.concatenate([u_i[1:-1], (u_i[:-1, None] + np.diff(u_i)[:, None] * steps).ravel()])
    t = np.concatenate([[0.0] * (_K + 1), np.sort(interior), [u_i[-1]] * (_K + 1)])
    mean_step = u_i[-1] / (len(u_i) - 1)
    energy = _gram(t, 3) + 1e-3 / mean_step**2 * _gram(t, 2)
    rows = [_basis(t, u_i, 0)]
    rhs = [points]
    given = [i for i, h in enumerate(headings) if h is not None]
    if given:
        rows.append(_basis(t, u_i[given], 1))
        rhs.append(np.array([[math.cos(headings[i] or 0.0), math.sin(headings[i] or 0.0)] for i in given]))
    a, b = sparse.vstack(rows), np.vstack(rhs)
    n = energy.shape[0]
    kkt = sparse.bmat([[energy, a.T], [a, None]], format="csc")
    sol = np.asarray(splu(kkt).solve(np.vstack([np.zeros((n, 2)), b])))
    return BSpline(t, sol[:n], _K), u_i


def _cusp_check(spline: BSpline, u_i: FloatArray, waypoints: Sequence[Waypoint], source: str) -> None:
    u = np.linspace(0.0, u_i[-1], 64 * len(u_i))
    speed = np.hypot(*spline.derivative(1)(u).T)
    worst = int(np.argmin(speed))
    if speed[worst] >= CUSP_SPEED:
        return
    i = int(np.argmin(np.abs(u_i - u[worst])))
    near = [j for j in (i, i - 1, i + 1) if 0 <= j < len(waypoints) and waypoints[j].theta_deg is not None]
    key = f"waypoints[{near[0]}].theta_deg" if near else f"waypoints[{i}]"
    raise ConfigError(
        source,
        key,
        "the path through here would fold back on itself (a cusp, which cannot be "
        "driven forwards); change the heading or add a waypoint",
    )


def _drawn(spline: BSpline, u_end: float, kappa_max: float) -> DrawnPath:
    """The spline as a drawn path: chords within :data:`~agvctl.planning.drawn.CHORD_ERROR_M` of it, at most
    :data:`~agvctl.planning.drawn.SPACING_M` long."""
    step = SPACING_M if kappa_max <= 0 else min(SPACING_M, math.sqrt(8.0 * CHORD_ERROR_M / kappa_max))
    u = np.linspace(0.0, u_end, 64 * 8)
    pace = float(np.max(np.hypot(*spline.derivative(1)(u).T)))  # |dr/du|: chord length per unit of u
    n = min(MAX_VERTICES - 1, max(1, math.ceil(u_end * pace / step)))
    points = spline(np.linspace(0.0, u_end, n + 1))
    return DrawnPath(points[:, 0], points[:, 1])


@document_fields
@dataclass(frozen=True, eq=False)
class WaypointCurve:
    """The curve the planner drives through waypoints, and the spline it stands for."""

    curve: Curve
    """The path through the waypoints."""
    s_i: FloatArray
    """The arc length at each waypoint, m."""
    drawn: DrawnPath
    """The spline, the path the waypoints draw."""
    deviation_m: float
    """The largest distance from a point of the curve to the spline, m (the curve sampled at every quarter of each
    of its pieces, a centimetre or so apart: the distance between the two smooth curves changes over lengths like
    the pieces')."""
    pieces_per_span: int
    """The curve's pieces per knot span of the spline (half a waypoint interval)."""


def waypoint_curve(
    waypoints: Sequence[Waypoint], *, source: str = "<path>", max_deviation_m: float = math.inf
) -> WaypointCurve:
    """The smooth path through waypoints as a polynomial-curvature curve.

    The curve has :data:`NODES_PER_SPAN` pieces per knot span of the spline, twice as many (up to
    :data:`MAX_NODES_PER_SPAN`) as long as it leaves the spline by more than ``max_deviation_m``.

    Parameters
    ----------
    waypoints : sequence of Waypoint
        The points, with their headings where given.
    source : str
        What errors name as the file.
    max_deviation_m : float
        How far the curve may leave the spline, m.

    Returns
    -------
    WaypointCurve
        The curve, the spline as a drawn path, and how far the one leaves the other.

    Raises
    ------
    ConfigError
        A path that would fold back on itself near a waypoint (a cusp, which cannot be driven forwards), naming
        the waypoint or its heading.
    """
    points = np.array([[w.x_m, w.y_m] for w in waypoints], dtype=float)
    headings = [None if w.theta_deg is None else math.radians(w.theta_deg) for w in waypoints]
    spline, u_i = _fit(points, headings)
    _cusp_check(spline, u_i, waypoints, source)
    drawn: DrawnPath | None = None
    pieces = NODES_PER_SPAN
    while True:
        curve, s_nodes, s_i, kappa_max = _hermite(spline, u_i, points[0], pieces)
        if drawn is None:
            drawn = _drawn(spline, float(u_i[-1]), kappa_max)
        quarters = s_nodes[:-1, None] + np.diff(s_nodes)[:, None] * np.array([0.0, 0.25, 0.5, 0.75])
        at = curve.evaluate(np.append(quarters.ravel(), s_nodes[-1]))
        deviation = float(np.max(drawn.distance_m(at.x_m, at.y_m)))
        if deviation <= max_deviation_m or 2 * pieces > MAX_NODES_PER_SPAN:
            return WaypointCurve(curve, s_i, drawn, deviation, pieces)
        pieces *= 2


def _hermite(
    spline: BSpline, u_i: FloatArray, start_point: FloatArray, pieces: int
) -> tuple[Curve, FloatArray, FloatArray, float]:
    """The curve of ``pieces`` Hermite pieces per knot span; the arc length at its nodes and at the waypoints, and
    the spline's largest |κ| at the nodes."""
    d1, d2, d3 = (spline.derivative(k) for k in (1, 2, 3))
    edges = np.unique(spline.t)
    nodes = np.concatenate(
        [np.linspace(a, b, pieces + 1)[:-1] for a, b in zip(edges[:-1], edges[1:], strict=True)] + [edges[-1:]]
    )
    r1, r2, r3 = d1(nodes), d2(nodes), d3(nodes)
    speed = np.hypot(r1[:, 0], r1[:, 1])
    cross12 = r1[:, 0] * r2[:, 1] - r1[:, 1] * r2[:, 0]
    cross13 = r1[:, 0] * r3[:, 1] - r1[:, 1] * r3[:, 0]
    kappa = cross12 / speed**3
    dkappa_du = cross13 / speed**3 - 3.0 * cross12 * np.sum(r1 * r2, axis=1) / speed**5
    slope = dkappa_du / speed  # dκ/ds
    a, b = nodes[:-1, None], nodes[1:, None]
    uq = 0.5 * (b - a) * (_GL_X + 1.0) + a
    ds = np.hypot(*np.moveaxis(d1(uq.ravel()).reshape(*uq.shape, 2), -1, 0)) @ _GL_W * 0.5 * (b - a).ravel()
    dk = np.diff(kappa)
    coeffs = np.column_stack(
        [
            kappa[:-1],
            slope[:-1],
            (3.0 * dk / ds - 2.0 * slope[:-1] - slope[1:]) / ds,
            (slope[:-1] + slope[1:] - 2.0 * dk / ds) / ds**2,
        ]
    )
    start = Pose(float(start_point[0]), float(start_point[1]), math.atan2(r1[0, 1], r1[0, 0]))
    curve = Curve(start, ds, coeffs)
    s_nodes = np.concatenate(([0.0], np.cumsum(ds)))
    return curve, s_nodes, np.interp(u_i, nodes, s_nodes), float(np.max(np.abs(kappa)))
