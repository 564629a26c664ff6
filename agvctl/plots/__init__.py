"""Plots of closed-loop runs, open-loop runs, the wheel-loop design and Monte Carlo checks, as PNG.

Figures are ``matplotlib.figure.Figure`` objects drawn on their own Agg canvas: no pyplot, no global figure
state, and the user's matplotlib backend is left as it is (a notebook keeps its own). matplotlib is imported
only when a plot is drawn.
"""

from __future__ import annotations

import io
import math
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.checks.report import CheckReport
from agvctl.controllers.pi.tuning import TuningResult, frequency_response, loop_polynomials
from agvctl.evaluation.limits import LIMITS
from agvctl.fuzz.report import FUZZ_METRICS, FuzzReport
from agvctl.log import SimLog
from agvctl.params import VehicleParams
from agvctl.plots.closed_loop import CLOSED_LOOP_PLOTS, save_closed_loop_plots
from agvctl.plots.figures import new_figure as _figure
from agvctl.plots.figures import save_png as _save
from agvctl.plots.figures import subplots as _subplots
from agvctl.plots.panel import render_run_panel
from agvctl.sim.wheel_step import WheelStepResult

__all__ = [
    "CLOSED_LOOP_PLOTS",
    "fuzz_figure",
    "render_run_panel",
    "render_tuning_plots",
    "save_closed_loop_plots",
    "save_fuzz_plot",
    "save_metric_histograms",
    "save_open_loop_plot",
]


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
    """One PNG of a fuzz run (:func:`fuzz_figure`)."""
    out = Path(path)
    _save(fuzz_figure(report), out)
    return out


def _minor_label(ax: Any, value: float, _pos: int | None) -> str:
    """A log axis's minor tick label, shown only where the axis spans less than a decade (too few majors)."""
    lo, hi = ax.get_xlim()
    return f"{value:.3g}" if hi < 10.0 * lo else ""


def fuzz_figure(report: FuzzReport) -> Any:
    """The figure of a fuzz run: per metric of :data:`~agvctl.fuzz.report.FUZZ_METRICS`, the cumulative
    distribution over the scenarios for each controller (log scale), with the configured limit; crashed runs
    count as beyond the right edge."""
    from matplotlib.ticker import FuncFormatter

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
        # plain tick labels (0.01, not mathtext's 10⁻²): mathtext looks up fonts matplotlib then reports missing
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
        ax.xaxis.set_minor_formatter(FuncFormatter(partial(_minor_label, ax)))
        ax.grid(alpha=0.3, which="both")
        ax.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"fuzz {report.spec.name}: seed {report.spec.seed}, {len(report.outcomes)} runs")
    fig.tight_layout()
    return fig


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
