"""The figures of a closed-loop run: path, errors, wheel speeds, DA commands, currents, wheel acceleration against
the gate's bound, the controller's step times and (with an EKF) the estimate against the truth."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.angles import wrap_angle
from agvctl.feasibility import torque_accel_limit_m_s2
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.planning.drawn import DrawnPath
from agvctl.plots.figures import save_png, subplots

__all__ = [
    "CLOSED_LOOP_PLOTS",
    "draw_both_sides",
    "draw_drawn_path",
    "draw_errors",
    "draw_path",
    "draw_wheel_accel",
    "draw_wheel_speed",
    "save_closed_loop_plots",
]

MM_PER_M = 1e3
"""Errors are drawn in mm, the unit every report prints them in."""
LEGEND_BAND = 0.3
"""The share of the path's height added above it for the path plot's legend."""

CLOSED_LOOP_PLOTS = (
    "path.png",
    "tracking_error.png",
    "path_error.png",
    "wheel_speeds.png",
    "da.png",
    "currents.png",
    "wheel_accel.png",
    "solve_time.png",
)
"""Written by every closed-loop run; with an estimator that has a covariance (``localization = "ekf"``) also
``estimate.png``: the estimate's error against the truth with its ±3σ bounds, and the NEES."""


def save_closed_loop_plots(
    log: SimLog,
    vehicle: VehicleParams,
    out_dir: str | Path,
    title: str = "",
    *,
    wheel_accel_bound_m_s2: float | None = None,
    drawn_path: DrawnPath | None = None,
) -> list[Path]:
    """Write the closed-loop figures of :data:`CLOSED_LOOP_PLOTS` into ``out_dir``; returns their paths.

    Parameters
    ----------
    log : SimLog
        The run's log.
    vehicle : VehicleParams
        The controller's vehicle (the limits drawn: the DA range, the current limit, eq 5's a_lim).
    out_dir : str or Path
        The folder to write into (it exists).
    title : str
        Each figure's title (the experiment's name).
    wheel_accel_bound_m_s2 : float or None
        The gate's bound on the per-sample wheel acceleration, drawn in ``wheel_accel.png`` (m/s²); by default the
        default gate's, :func:`~agvctl.feasibility.torque_accel_limit_m_s2`.
    drawn_path : DrawnPath or None
        The path as its file draws it (``Reference.drawn_path``), drawn under the reference in ``path.png``; None:
        not drawn.

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(out_dir)
    figures: list[tuple[str, Callable[[], Any]]] = [
        ("path.png", lambda: _path_figure(log, drawn_path)),
        ("tracking_error.png", lambda: _tracking_error_figure(log)),
        ("path_error.png", lambda: _path_error_figure(log)),
        ("wheel_speeds.png", lambda: _wheel_speed_figure(log)),
        ("da.png", lambda: _da_figure(log, vehicle)),
        (
            "currents.png",
            lambda: _both_sides_figure(
                log, "current_{side}_a", vehicle.amplifier.current_limit_a, "limit", "armature current [A]"
            ),
        ),
        ("wheel_accel.png", lambda: _wheel_accel_figure(log, vehicle, wheel_accel_bound_m_s2)),
        ("solve_time.png", lambda: _solve_time_figure(log)),
    ]
    if np.any(np.isfinite(log["est_sigma_x_m"])):
        figures.append(("estimate.png", lambda: _estimate_figure(log)))
    written: list[Path] = []
    for name, build in figures:
        fig = build()
        if title:
            fig.suptitle(title)
        fig.tight_layout()
        save_png(fig, out / name)
        written.append(out / name)
    return written


def _path_figure(log: SimLog, drawn_path: DrawnPath | None) -> Any:
    """The vehicle's path (and its estimate, where it differs) against the reference and the drawn path."""
    fig, ax = subplots(figsize=(6.5, 6))
    draw_path(ax, log, drawn_path=drawn_path)
    return fig


def draw_path(
    ax: Any,
    log: SimLog,
    *,
    mark_time_s: float | None = None,
    mark_label: str = "",
    drawn_path: DrawnPath | None = None,
) -> None:
    """Draw on an axes the vehicle's path against the reference: the ``path.png`` figure and the page's path panel.

    The drawn path (wide, light grey, under everything), the reference (dashed), the true path with its start, and
    the estimated path where it differs from the true one, in the plane: x and y in m, equal scale, with a grid and
    a legend in a band left free above the path (it never covers it).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    log : SimLog
        The run's log (columns ``ref_x_m``, ``ref_y_m``, ``x_m``, ``y_m``, ``est_x_m``, ``est_y_m``, ``t_s``).
    mark_time_s : float or None
        An instant to mark, s: the vehicle's position at the sample nearest it is drawn as a red cross (None: no
        mark).
    mark_label : str
        The mark's legend entry (empty: none).
    drawn_path : DrawnPath or None
        The path as its file draws it (``Reference.drawn_path``); None: not drawn.
    """
    if drawn_path is not None:
        draw_drawn_path(ax, drawn_path)
    ax.plot(log["ref_x_m"], log["ref_y_m"], "k--", lw=1, label="reference")
    ax.plot(log["x_m"], log["y_m"], "C0", lw=1.5, label="vehicle (true)")
    if not np.allclose(log["est_x_m"], log["x_m"]):
        ax.plot(log["est_x_m"], log["est_y_m"], "C2", lw=1, alpha=0.8, label="estimate")
    ax.plot(log["x_m"][0], log["y_m"][0], "o", color="C0")
    if mark_time_s is not None:
        k = int(np.argmin(np.abs(log["t_s"] - mark_time_s)))
        ax.plot(log["x_m"][k], log["y_m"][k], "x", color="r", ms=10, mew=2, label=mark_label or None)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="path")
    y_min, y_max = ax.get_ylim()
    ax.set_ylim(y_min, y_max + LEGEND_BAND * (y_max - y_min))
    ax.legend(loc="upper center", ncol=2, fontsize=8)
    ax.grid(alpha=0.3)


def draw_drawn_path(ax: Any, drawn_path: DrawnPath) -> None:
    """Draw on an axes the path as its file draws it: a wide, light grey line under what is drawn next.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    drawn_path : DrawnPath
        The drawn path (``Reference.drawn_path``).
    """
    ax.plot(drawn_path.x_m, drawn_path.y_m, color="0.75", lw=5, solid_capstyle="round", zorder=0, label="drawn path")


def _tracking_error_figure(log: SimLog) -> Any:
    """Position and heading error against the time-indexed reference."""
    t = log["t_s"]
    fig, (a1, a2) = subplots(2, 1, figsize=(8, 5), sharex=True)
    a1.plot(t, log["position_error_m"] * MM_PER_M, "C3")
    a1.set(ylabel="position error [mm]")
    a2.plot(t, np.degrees(log["heading_error_rad"]), "C4")
    a2.set(xlabel="t [s]", ylabel="heading error [°]")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    return fig


def _wheel_speed_figure(log: SimLog) -> Any:
    """Each wheel's reference, setpoint and measured speed."""
    fig, axes = subplots(2, 1, figsize=(8, 5), sharex=True)
    for a, side in zip(axes, ("left", "right"), strict=True):
        draw_wheel_speed(a, log, side)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set(xlabel="t [s]")
    return fig


def draw_wheel_speed(ax: Any, log: SimLog, side: str) -> None:
    """Draw on an axes one wheel's rim speed against time: the reference, the setpoint and the speed driven.

    The reference's wheel speed (dashed) is what the plan asks; the setpoint is what the pose controller sent to the
    wheel loop; the line labelled "actual" is the plant's true rim speed ω_mot·r/N (not what the encoders report).
    Speeds in m/s, time in s, with a grid and no legend (the caller places one, for both wheels).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    log : SimLog
        The run's log (columns ``t_s``, ``ref_wheel_speed_<side>_m_s``, ``setpoint_wheel_speed_<side>_m_s``,
        ``wheel_speed_<side>_m_s``).
    side : {'left', 'right'}
        The wheel.
    """
    t = log["t_s"]
    ax.plot(t, log[f"ref_wheel_speed_{side}_m_s"], "k--", lw=1, label="reference")
    ax.plot(t, log[f"setpoint_wheel_speed_{side}_m_s"], "C1", lw=1, label="setpoint")
    ax.plot(t, log[f"wheel_speed_{side}_m_s"], "C0", lw=1.2, label="actual")
    ax.set(ylabel=f"{side} wheel [m/s]")
    ax.grid(alpha=0.3)


def _da_figure(log: SimLog, vehicle: VehicleParams) -> Any:
    """The DA converter's output voltages and codes against its range."""
    t = log["t_s"]
    fig, (a1, a2) = subplots(2, 1, figsize=(8, 5), sharex=True)
    alpha = vehicle.da.volts_per_code
    for side, c in (("left", "C0"), ("right", "C1")):
        a1.step(t, log[f"da_voltage_{side}_v"], where="post", color=c, lw=1, label=side)
        a2.step(t, log[f"da_code_{side}"], where="post", color=c, lw=1, label=side)
    for a, lim in (
        (a1, (vehicle.da.min_v, vehicle.da.code_max * alpha)),
        (a2, (vehicle.da.code_min, vehicle.da.code_max)),
    ):
        for v in lim:
            a.axhline(v, color="r", ls=":", lw=1)
        a.grid(alpha=0.3)
    a1.set(ylabel="DA output [V]")
    a2.set(ylabel="DA code", xlabel="t [s]")
    a1.legend(loc="best", fontsize=8)
    return fig


def _both_sides_figure(log: SimLog, column: str, bound: float, bound_label: str, ylabel: str) -> Any:
    """``column`` (with ``{side}``) for both wheels against ±``bound``."""
    fig, ax = subplots(figsize=(8, 3.5))
    draw_both_sides(ax, log, column, bound, bound_label, ylabel)
    return fig


def draw_both_sides(ax: Any, log: SimLog, column: str, bound: float, bound_label: str, ylabel: str) -> None:
    """Draw on an axes a signal of both wheels against time, between two bound lines at plus and minus ``bound``.

    Used for the armature currents against the amplifier's limit (``currents.png`` and the page's current panel).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    log : SimLog
        The run's log (``t_s`` and the two columns of ``column``).
    column : str
        The log column's name with ``{side}`` where the wheel goes (``"current_{side}_a"``).
    bound : float
        Where the bound lines are drawn, in the column's unit (a current limit: A).
    bound_label : str
        The bound lines' legend entry.
    ylabel : str
        The y axis's label, with the unit (``"armature current [A]"``).
    """
    t = log["t_s"]
    for side, c in (("left", "C0"), ("right", "C1")):
        ax.plot(t, log[column.format(side=side)], color=c, lw=1, label=side)
    ax.axhline(bound, color="r", ls=":", lw=1, label=bound_label)
    ax.axhline(-bound, color="r", ls=":", lw=1)
    ax.set(xlabel="t [s]", ylabel=ylabel)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)


def _wheel_accel_figure(log: SimLog, vehicle: VehicleParams, bound_m_s2: float | None) -> Any:
    """Each wheel's mean rim acceleration over each sample against the gate's bound (:func:`draw_wheel_accel`)."""
    fig, ax = subplots(figsize=(8, 3.5))
    draw_wheel_accel(ax, log, vehicle, bound_m_s2)
    return fig


def draw_wheel_accel(ax: Any, log: SimLog, vehicle: VehicleParams, bound_m_s2: float | None) -> None:
    """Draw on an axes each wheel's rim acceleration against time and the gate's bound on it.

    The acceleration drawn is the mean over each sample, the speed's change over the sample period, as the gate's
    ``wheel_accel_m_s2`` limit judges it; the instantaneous acceleration is faint behind it, and eq 5's a_lim (the
    straight-line acceleration at the current limit) is drawn for reference. Acceleration in m/s², time in s.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    log : SimLog
        The run's log (columns ``t_s``, ``wheel_speed_<side>_m_s``, ``wheel_accel_<side>_m_s2``).
    vehicle : VehicleParams
        The controller's vehicle, for eq 5's a_lim and the default bound.
    bound_m_s2 : float or None
        The gate's bound on the per-sample wheel acceleration, m/s² (None: the default gate's,
        :func:`~agvctl.feasibility.torque_accel_limit_m_s2`).
    """
    t = log["t_s"]
    bound = torque_accel_limit_m_s2(vehicle) if bound_m_s2 is None else bound_m_s2
    for side, c in (("left", "C0"), ("right", "C1")):
        ax.plot(t, log[f"wheel_accel_{side}_m_s2"], color=c, lw=0.6, alpha=0.3)
        speed = log[f"wheel_speed_{side}_m_s"]
        per_sample = np.diff(speed) / np.diff(t) if len(t) > 1 else np.zeros(0)
        ax.step(t[1:], per_sample, where="pre", color=c, lw=1, label=f"{side} (per sample; faint: instantaneous)")
    ax.axhline(bound, color="r", ls="--", lw=1, label=f"gate bound {bound:.3g}")
    ax.axhline(-bound, color="r", ls="--", lw=1)
    a_lim = vehicle.derived.accel_limit_m_s2
    ax.axhline(a_lim, color="k", ls=":", lw=0.8, label="a_lim (eq 5)")
    ax.axhline(-a_lim, color="k", ls=":", lw=0.8)
    ax.set(xlabel="t [s]", ylabel="wheel acceleration [m/s²]")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)


def _solve_time_figure(log: SimLog) -> Any:
    """The pose controller's step times: their histogram, median and 99th percentile."""
    fig, ax = subplots(figsize=(6, 3.5))
    ms = log["solve_time_s"][:-1] * 1e3
    ax.hist(ms, bins=50, color="C0")
    p50, p99 = np.percentile(ms, [50, 99])
    ax.axvline(p50, color="k", ls="--", lw=1, label=f"median {p50:.2f} ms")
    ax.axvline(p99, color="r", ls="--", lw=1, label=f"p99 {p99:.2f} ms")
    ax.set(xlabel="pose-controller step time [ms]", ylabel="samples")
    ax.legend(loc="best", fontsize=8)
    return fig


def _path_error_figure(log: SimLog) -> Any:
    """Cross-track error and along-track lag against time: off the path versus behind (or ahead of) the clock."""
    t = log["t_s"]
    fig, (a1, a2) = subplots(2, 1, figsize=(8, 5), sharex=True)
    draw_errors(a1, log)
    a2.plot(t, log["along_track_lag_m"] * MM_PER_M, "C0")
    a2.axhline(0.0, color="k", lw=0.6)
    a2.set(xlabel="t [s]", ylabel="along-track lag [mm]\n(> 0: behind)")
    a2.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def draw_errors(ax: Any, log: SimLog, bounds: Mapping[str, float] | None = None) -> None:
    """Draw on an axes the run's cross-track and position errors against time, with their bounds where given.

    The cross-track error is the distance to the path, how far off the path the vehicle is; the position error is
    the distance to the reference's point at that time, which lateness adds to. Both are drawn in mm, as the reports
    print them.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        The axes to draw on.
    log : SimLog
        The run's log (columns ``t_s``, ``cross_track_error_m``, ``position_error_m``).
    bounds : mapping of str to float or None
        The gate's bounds by limit name; ``cross_track_error_max_m`` and ``tracking_error_max_m`` (m), where
        present, are drawn as dashed lines (None: no bounds).
    """
    t = log["t_s"]
    ax.plot(t, log["cross_track_error_m"] * MM_PER_M, "C3", label="cross-track (distance to the path)")
    ax.plot(t, log["position_error_m"] * MM_PER_M, "0.6", lw=0.8, label="position error (to the reference point)")
    for limit, color in (("cross_track_error_max_m", "C3"), ("tracking_error_max_m", "0.4")):
        if bounds and limit in bounds:
            ax.axhline(bounds[limit] * MM_PER_M, color=color, ls="--", lw=1, label=f"{limit} {bounds[limit]:.3g} m")
    ax.set(ylabel="error [mm]")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)


def _estimate_figure(log: SimLog) -> Any:
    """Estimate minus truth in x, y (mm) and θ (°) inside ±3σ, and the NEES against its 95 % chi-square bounds."""
    from scipy.stats import chi2

    t = log["t_s"]
    fig, axes = subplots(4, 1, figsize=(8, 8), sharex=True)
    rows = (("x", "x_m", 1e3, "mm"), ("y", "y_m", 1e3, "mm"), ("theta", "theta_rad", 180 / math.pi, "°"))
    for a, (name, col, scale, unit) in zip(axes, rows, strict=False):
        err = log[f"est_{col}"] - log[col]
        if name == "theta":
            err = wrap_angle(err)
        sigma = log[f"est_sigma_{col}" if name != "theta" else "est_sigma_theta_rad"]
        a.plot(t, err * scale, "C0", lw=1, label="estimate − truth")
        a.fill_between(t, -3 * sigma * scale, 3 * sigma * scale, color="C0", alpha=0.15, label="±3σ")
        a.set(ylabel=f"{name} error [{unit}]")
        a.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    lo, hi = chi2.ppf([0.025, 0.975], 3)
    axes[3].semilogy(t, np.maximum(log["nees"], 1e-3), "C2", lw=0.8, label="NEES")
    for v in (lo, hi):
        axes[3].axhline(v, color="r", ls=":", lw=1)
    axes[3].set(xlabel="t [s]", ylabel="NEES (3 dof)")
    axes[3].grid(alpha=0.3)
    return fig
