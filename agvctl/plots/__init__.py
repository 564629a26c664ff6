"""Plots of closed-loop runs, open-loop runs, the wheel-loop design and Monte Carlo checks, as PNG.

Figures are ``matplotlib.figure.Figure`` objects drawn on their own Agg canvas: no pyplot, no global figure
state, and the user's matplotlib backend is left as it is (a notebook keeps its own). matplotlib is imported
only when a plot is drawn.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.angles import wrap_angle
from agvctl.checks.report import CheckReport
from agvctl.controllers.pi.tuning import TuningResult, frequency_response, loop_polynomials
from agvctl.evaluation.limits import LIMITS
from agvctl.fileio import atomic_open
from agvctl.fuzz.report import FUZZ_METRICS, FuzzReport
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.sim.wheel_step import WheelStepResult

__all__ = [
    "CLOSED_LOOP_PLOTS",
    "render_tuning_plots",
    "save_closed_loop_plots",
    "save_fuzz_plot",
    "save_metric_histograms",
    "save_open_loop_plot",
]

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


def _figure(**kwargs: Any) -> Any:
    """A new ``Figure`` on an Agg canvas (``kwargs`` as for ``Figure``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def _subplots(*grid: int, figsize: tuple[float, float], **kwargs: Any) -> tuple[Any, Any]:
    """``(figure, axes)`` like ``pyplot.subplots``, without pyplot."""
    fig = _figure(figsize=figsize)
    return fig, fig.subplots(*grid, **kwargs)


def _save(fig: Any, path: Path) -> None:
    with atomic_open(path, "wb") as fh:
        fig.savefig(fh, format="png", dpi=90)


def save_closed_loop_plots(log: SimLog, vehicle: VehicleParams, out_dir: str | Path, title: str = "") -> list[Path]:
    """Write the closed-loop figures of :data:`CLOSED_LOOP_PLOTS` into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    figures: list[tuple[str, Callable[[], Any]]] = [
        ("path.png", lambda: _path_figure(log)),
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
        (
            "wheel_accel.png",
            lambda: _both_sides_figure(
                log,
                "wheel_accel_{side}_m_s2",
                vehicle.derived.accel_limit_m_s2,
                "a_lim (eq 5)",
                "wheel acceleration [m/s²]",
            ),
        ),
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
        _save(fig, out / name)
        written.append(out / name)
    return written


def _path_figure(log: SimLog) -> Any:
    """The vehicle's path (and its estimate, where it differs) against the reference."""
    fig, ax = _subplots(figsize=(6.5, 6))
    ax.plot(log["ref_x_m"], log["ref_y_m"], "k--", lw=1, label="reference")
    ax.plot(log["x_m"], log["y_m"], "C0", lw=1.5, label="vehicle (true)")
    if not np.allclose(log["est_x_m"], log["x_m"]):
        ax.plot(log["est_x_m"], log["est_y_m"], "C2", lw=1, alpha=0.8, label="estimate")
    ax.plot(log["x_m"][0], log["y_m"][0], "o", color="C0")
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="path")
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    return fig


def _tracking_error_figure(log: SimLog) -> Any:
    """Position and heading error against the time-indexed reference."""
    t = log["t_s"]
    fig, (a1, a2) = _subplots(2, 1, figsize=(8, 5), sharex=True)
    a1.plot(t, log["position_error_m"] * 100, "C3")
    a1.set(ylabel="position error [cm]")
    a2.plot(t, np.degrees(log["heading_error_rad"]), "C4")
    a2.set(xlabel="t [s]", ylabel="heading error [°]")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    return fig


def _wheel_speed_figure(log: SimLog) -> Any:
    """Each wheel's reference, setpoint and measured speed."""
    t = log["t_s"]
    fig, axes = _subplots(2, 1, figsize=(8, 5), sharex=True)
    for a, side in zip(axes, ("left", "right"), strict=True):
        a.plot(t, log[f"ref_wheel_speed_{side}_m_s"], "k--", lw=1, label="reference")
        a.plot(t, log[f"setpoint_wheel_speed_{side}_m_s"], "C1", lw=1, label="setpoint")
        a.plot(t, log[f"wheel_speed_{side}_m_s"], "C0", lw=1.2, label="measured")
        a.set(ylabel=f"{side} wheel [m/s]")
        a.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[-1].set(xlabel="t [s]")
    return fig


def _da_figure(log: SimLog, vehicle: VehicleParams) -> Any:
    """The DA converter's output voltages and codes against its range."""
    t = log["t_s"]
    fig, (a1, a2) = _subplots(2, 1, figsize=(8, 5), sharex=True)
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
    t = log["t_s"]
    fig, ax = _subplots(figsize=(8, 3.5))
    for side, c in (("left", "C0"), ("right", "C1")):
        ax.plot(t, log[column.format(side=side)], color=c, lw=1, label=side)
    ax.axhline(bound, color="r", ls=":", lw=1, label=bound_label)
    ax.axhline(-bound, color="r", ls=":", lw=1)
    ax.set(xlabel="t [s]", ylabel=ylabel)
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _solve_time_figure(log: SimLog) -> Any:
    """The pose controller's step times: their histogram, median and 99th percentile."""
    fig, ax = _subplots(figsize=(6, 3.5))
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
    fig, (a1, a2) = _subplots(2, 1, figsize=(8, 5), sharex=True)
    a1.plot(t, log["cross_track_error_m"] * 100, "C3", label="cross-track (distance to the path)")
    a1.plot(t, log["position_error_m"] * 100, "0.6", lw=0.8, label="position error (to the reference point)")
    a1.set(ylabel="error [cm]")
    a1.legend(loc="best", fontsize=8)
    a2.plot(t, log["along_track_lag_m"] * 100, "C0")
    a2.axhline(0.0, color="k", lw=0.6)
    a2.set(xlabel="t [s]", ylabel="along-track lag [cm]\n(> 0: behind)")
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def _estimate_figure(log: SimLog) -> Any:
    """Estimate minus truth in x, y (mm) and θ (°) inside ±3σ, and the NEES against its 95 % chi-square bounds."""
    from scipy.stats import chi2

    t = log["t_s"]
    fig, axes = _subplots(4, 1, figsize=(8, 8), sharex=True)
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


def save_metric_histograms(report: CheckReport, out_dir: str | Path) -> list[Path]:
    """For each Monte Carlo experiment, ``<name>_<metric>.png``: the metric over the samples, its limit if any."""
    out = Path(out_dir)
    written: list[Path] = []
    for exp in report.experiments:
        if not exp.monte_carlo:
            continue
        bounds = {v.limit: v.bound for v in exp.verdicts}
        alias = {
            "wheel_speed_m_s": "peak_wheel_speed_m_s",
            "wheel_accel_m_s2": "peak_wheel_accel_m_s2",
            "motor_current_a": "peak_motor_current_a",
        }
        limit_of = {alias.get(k, k): b for k, b in bounds.items()}
        completed = [o for o in exp.outcomes if o.error is None]
        for metric in completed[0].metrics if completed else ():
            values = np.array([o.metrics[metric] for o in completed], dtype=float)
            values = values[np.isfinite(values)]
            if values.size == 0:
                continue
            fig, ax = _subplots(figsize=(6, 3.5))
            ax.hist(values, bins=min(40, max(5, values.size // 5)), color="C0")
            if metric in limit_of:
                ax.axvline(limit_of[metric], color="r", ls="--", lw=1.2, label=f"limit {limit_of[metric]:.4g}")
                ax.legend(fontsize=8)
            ax.set(xlabel=metric, ylabel="samples", title=f"{exp.name}: {len(completed)} samples")
            fig.tight_layout()
            path = out / f"{exp.name}_{metric}.png"
            _save(fig, path)
            written.append(path)
    return written


def save_fuzz_plot(report: FuzzReport, path: str | Path) -> Path:
    """One PNG of a fuzz run: per metric of :data:`~agvctl.fuzz.report.FUZZ_METRICS`, the cumulative
    distribution over the scenarios for each controller (log scale), with the configured limit; crashed runs
    count as beyond the right edge."""
    metrics = FUZZ_METRICS[:4]
    fig, axes = _subplots(2, 2, figsize=(11, 7.5))
    bounds = {LIMITS[key].metric: bound for key, bound in report.spec.limits.items()}
    for ax, metric in zip(np.ravel(axes), metrics, strict=True):
        for i, c in enumerate(report.spec.controllers):
            values = np.array([o.value(metric) for o in report.runs(c)], dtype=float)
            n = values.size
            finite = np.sort(values[np.isfinite(values)])
            if n == 0 or finite.size == 0:
                continue
            floor = max(float(finite[finite > 0].min()) if np.any(finite > 0) else 1e-9, 1e-9)
            shown = np.maximum(finite, floor)
            ax.step(shown, np.arange(1, finite.size + 1) / n, where="post", color=f"C{i}", label=f"{c} ({n} runs)")
        if metric in bounds:
            ax.axvline(bounds[metric], color="r", ls="--", lw=1, label=f"limit {bounds[metric]:g}")
        ax.set(xscale="log", xlabel=metric, ylabel="share of scenarios ≤ x", ylim=(0.0, 1.02))
        ax.grid(alpha=0.3, which="both")
        ax.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"fuzz {report.spec.name}: seed {report.spec.seed}, {len(report.outcomes)} runs")
    fig.tight_layout()
    out = Path(path)
    _save(fig, out)
    return out


def render_tuning_plots(
    design: TuningResult, step: WheelStepResult, vehicle: VehicleParams, step_m_s: float
) -> dict[str, bytes]:
    """Bode, Nyquist and step-response figures as PNG bytes, keyed by file name (matplotlib imported here)."""
    ts = design.gains.dt_s
    w_nyq = math.pi / ts
    w = np.geomspace(w_nyq * 1e-4, w_nyq, 2000)
    num, den = loop_polynomials(design.gains, design.plant_left, design.chain_gain)
    resp = frequency_response(num, den, ts, w)
    m = design.margins_left
    out: dict[str, bytes] = {}

    def png(fig: Any) -> bytes:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=110)
        return buf.getvalue()

    fig, (ax_m, ax_p) = _subplots(2, 1, sharex=True, figsize=(7, 6))
    ax_m.semilogx(w, 20 * np.log10(np.abs(resp)))
    ax_m.axhline(0, color="k", lw=0.6)
    ax_m.axhline(-m.gain_margin_db, color="tab:red", ls=":", label=f"GM {m.gain_margin_db:.2f} dB at Nyquist")
    ax_m.set_ylabel("|L| (dB)")
    ax_m.legend(loc="lower left")
    ax_p.semilogx(w, np.degrees(np.unwrap(np.angle(resp))))
    ax_p.axhline(-180, color="k", lw=0.6)
    ax_p.axvline(
        m.crossover_rad_s,
        color="tab:green",
        ls=":",
        label=f"crossover {m.crossover_rad_s:.2f} rad/s, PM {m.phase_margin_deg:.1f}°",
    )
    ax_p.set_ylabel("∠L (deg)")
    ax_p.set_xlabel("ω (rad/s); the axis ends at the Nyquist frequency π/T_s")
    ax_p.legend(loc="lower left")
    for ax in (ax_m, ax_p):
        ax.axvline(w_nyq, color="0.5", lw=0.8)
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("Wheel loop L(z) = C(z)·k_chain·G_zoh(z), left wheel")
    out["bode.png"] = png(fig)

    fig, ax = _subplots(figsize=(6, 6))
    wl = np.linspace(w_nyq * 1e-3, w_nyq, 4000)
    r = frequency_response(num, den, ts, wl)
    ax.plot(r.real, r.imag, label="L(e^{jωT}), 0 < ω ≤ π/T")
    ax.plot(r.real, -r.imag, ls="--", color="tab:blue", alpha=0.5)
    ax.plot([-1], [0], "r+", ms=12, label="−1")
    circle = np.exp(1j * np.linspace(0, 2 * np.pi, 200))
    ax.plot(circle.real, circle.imag, color="0.6", lw=0.6)
    nyq = r[-1]
    ax.plot([nyq.real], [nyq.imag], "ko", label=f"z = −1: L = {nyq.real:.3f}")
    ax.set_xlim(-2.5, 1.0)
    ax.set_ylim(-2.5, 2.5)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower left")
    ax.set_title("Nyquist, left wheel loop")
    out["nyquist.png"] = png(fig)

    fig, (ax_w, ax_u, ax_i) = _subplots(3, 1, sharex=True, figsize=(7, 8))
    for i, side in enumerate(("left", "right")):
        ax_w.plot(step.t_s, step.omega_motor_rad_s[:, i], marker=".", label=f"ω {side}")
        ax_u.step(step.t_s[:-1], step.motor_voltage_v[:, i], where="post", label=side)
        ax_i.step(step.t_s[:-1], step.current_peak_a[:, i], where="post", label=f"peak |i| {side}")
    ax_w.axhline(step.setpoint_rad_s[0], color="k", ls="--", lw=0.8, label="setpoint")
    ax_w.set_ylabel("motor speed (rad/s)")
    ax_u.set_ylabel("motor voltage (V)")
    ax_i.axhline(vehicle.amplifier.current_limit_a, color="tab:red", ls=":", label="I_max")
    ax_i.set_ylabel("current (A)")
    ax_i.set_xlabel("t (s)")
    for ax in (ax_w, ax_u, ax_i):
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower right")
    s = step.metrics
    fig.suptitle(
        f"{step_m_s:g} m/s wheel-speed step on the nonlinear plant\nrise {s.rise_time_s:.3f} s, "
        f"overshoot {s.overshoot_pct:.2f} %, settling {s.settling_time_s:.3f} s"
    )
    out["step.png"] = png(fig)
    return out


def save_open_loop_plot(log: SimLog, vehicle: VehicleParams, path: str | Path, title: str = "") -> Path:
    """One PNG of an open-loop run: path, motor speeds, DA commands, currents against the limit."""
    t = log["t_s"]
    fig = _figure(figsize=(11, 7))
    grid = fig.add_gridspec(3, 2, width_ratios=(1.0, 1.6))
    ax_path = fig.add_subplot(grid[:, 0])
    ax_path.plot(log["x_m"], log["y_m"], "C0")
    ax_path.plot(log["x_m"][0], log["y_m"][0], "o", color="C0")
    ax_path.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="path")
    ax_path.grid(alpha=0.3)
    axes = [fig.add_subplot(grid[i, 1]) for i in range(3)]
    for side, c in (("left", "C0"), ("right", "C1")):
        axes[0].plot(t, log[f"omega_motor_{side}_rad_s"], color=c, lw=1, label=side)
        axes[1].step(t, log[f"da_voltage_{side}_v"], where="post", color=c, lw=1, label=side)
        axes[2].plot(t, log[f"current_{side}_a"], color=c, lw=1, label=side)
    i_max = vehicle.amplifier.current_limit_a
    for v in (i_max, -i_max):
        axes[2].axhline(v, color="r", ls=":", lw=1)
    for ax, label in zip(axes, ("motor speed [rad/s]", "DA output [V]", "armature current [A]"), strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    axes[2].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    _save(fig, out)
    return out
