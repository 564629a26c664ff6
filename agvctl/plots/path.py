"""A picture of a reference: the path, its curvature against arc length, and the wheel speeds and
accelerations against their limits.

matplotlib is imported only when a plot is drawn (Agg backend, no pyplot global state).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.fileio import atomic_open
from agvctl.planning.reference import Reference
from agvctl.plots.closed_loop import draw_drawn_path

__all__ = ["plot_reference", "render_reference_png", "save_reference_plot"]


def plot_reference(ref: Reference, *, dense_period_s: float = 0.005) -> Any:
    """The figure of a reference: its path, its curvature, and its wheel speeds and accelerations against the limits.

    Four panels, top to bottom: the path in the plane (x, y in m, equal scale) over the path its file draws (wide,
    light grey), with its start, its end and the stops between its motions, titled with its length and duration;
    the curvature κ (1/m) against arc length s (m), titled with the planned path's largest distance from the drawn
    one and its tolerance (mm); each wheel's rim speed (m/s) and rim acceleration
    (m/s²) against time (s), with the plan's wheel limits as ± lines.

    Parameters
    ----------
    ref : Reference
        The planned reference (:func:`~agvctl.planning.plan`).
    dense_period_s : float
        The spacing of the samples drawn, s: finer than the control period, so that the curves are smooth.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, 6.4 × 10 inches, made without pyplot; :func:`render_reference_png` draws it.
    """
    from matplotlib.figure import Figure

    n = max(2, int(np.ceil(ref.duration_s / dense_period_s)) + 1)
    s = ref.sample(np.linspace(0.0, ref.duration_s, n))
    lim = ref.limits
    fig = Figure(figsize=(6.4, 10.0), layout="constrained")
    ax_path, ax_k, ax_v, ax_a = fig.subplots(4, 1, height_ratios=[1.4, 0.8, 1.0, 1.0])

    if ref.drawn_path is not None:
        draw_drawn_path(ax_path, ref.drawn_path)
    ax_path.plot(s.x_m, s.y_m, color="C0", lw=1.5, label="planned path")
    ax_path.plot(s.x_m[0], s.y_m[0], "o", color="C2", label="start")
    ax_path.plot(s.x_m[-1], s.y_m[-1], "x", color="C3", ms=9, label="end")
    stops = np.array([[m.start_pose.x_m, m.start_pose.y_m] for m in ref.motions[1:]]).reshape(-1, 2)
    if len(stops):
        ax_path.plot(stops[:, 0], stops[:, 1], ".", color="0.3", label="stops")
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set_xlabel("x [m]")
    ax_path.set_ylabel("y [m]")
    ax_path.set_title(f"{ref.name}: {ref.path_length_m:.2f} m in {ref.duration_s:.2f} s")
    ax_path.legend(loc="best", fontsize="small")
    ax_path.grid(True, alpha=0.3)

    moving = np.concatenate(([True], np.diff(s.path_length_m) > 0))  # a spin adds no arc length
    ax_k.plot(s.path_length_m[moving], s.curvature_1_m[moving], color="C0", lw=1.5)
    ax_k.set_xlabel("arc length s [m]")
    ax_k.set_ylabel("curvature κ [1/m]")
    tolerance = (
        f" (tolerance {ref.drawn_path_tolerance_m * 1e3:g} mm)" if np.isfinite(ref.drawn_path_tolerance_m) else ""
    )
    ax_k.set_title(
        f"largest distance from the drawn path {ref.drawn_path_deviation_m * 1e3:.1f} mm{tolerance}", fontsize="small"
    )
    ax_k.grid(True, alpha=0.3)

    for ax, left, right, limit, label in (
        (ax_v, s.wheel_speed_left_m_s, s.wheel_speed_right_m_s, lim.wheel_speed_m_s, "wheel speed [m/s]"),
        (ax_a, s.wheel_accel_left_m_s2, s.wheel_accel_right_m_s2, lim.wheel_accel_m_s2, "wheel accel [m/s²]"),
    ):
        ax.plot(s.t_s, left, color="C0", label="left")
        ax.plot(s.t_s, right, color="C1", label="right", ls="--")
        for sign in (1, -1):
            ax.axhline(sign * limit, color="C3", lw=1, ls=":", label="limit" if sign > 0 else None)
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small", ncol=3)
    ax_a.set_xlabel("t [s]")
    return fig


def render_reference_png(ref: Reference, *, dpi: int = 80) -> bytes:
    """The figure of :func:`plot_reference` as PNG bytes (what ``agvctl plan --plot`` writes).

    Parameters
    ----------
    ref : Reference
        The planned reference.
    dpi : int
        Dots per inch of the image.

    Returns
    -------
    bytes
        The PNG file's content.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot_reference(ref)
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def save_reference_plot(ref: Reference, path: str | Path, *, dpi: int = 80) -> None:
    """Write the figure of :func:`plot_reference` to a PNG file, atomically (no half-written file).

    Parameters
    ----------
    ref : Reference
        The planned reference.
    path : str or Path
        The PNG file to write; its folder is made if missing.
    dpi : int
        Dots per inch of the image.
    """
    png = render_reference_png(ref, dpi=dpi)
    with atomic_open(path, "wb") as fh:
        fh.write(png)
