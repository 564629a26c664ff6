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
    """Write a histogram of each metric over the Monte Carlo samples of each experiment of a check.

    One figure per experiment run as Monte Carlo samples and per metric of
    :func:`~agvctl.evaluation.metrics.closed_loop_metrics`: how many completed samples had each value of the
    metric (non-finite values left out), with the experiment's bound on it as a red dashed line where it has a
    limit on that metric, the bins then spanning the samples and the bound (how close the samples came shows, and a
    distant bound leaves the bars visible). The x axis is in the unit of the metric's name. An experiment without
    samples writes nothing, and neither does a metric with no finite value.

    Parameters
    ----------
    report : CheckReport
        The check's report (:func:`~agvctl.checks.runner.check_experiments`).
    out_dir : str or Path
        The folder to write into (it exists); each file is ``<experiment>_<metric>.png``, written atomically.

    Returns
    -------
    list of Path
        The files written, by experiment and then by metric.
    """
    out = Path(out_dir)
    written: list[Path] = []
    for exp in report.experiments:
        if not exp.monte_carlo:
            continue
        limit_of = {v.limit: v.bound for v in exp.verdicts if v.limit in LIMITS}
        completed = [o for o in exp.outcomes if o.error is None]
        for metric in completed[0].metrics if completed else ():
            values = np.array([o.metrics[metric] for o in completed], dtype=float)
            values = values[np.isfinite(values)]
            if values.size == 0:
                continue
            fig, ax = _subplots(figsize=(6, 3.5))
            # fixed margins that hold a title, the metric's name and small counts: a tight layout draws the figure
            # once more to measure it, doubling the cost of a check's many histograms
            fig.subplots_adjust(left=0.11, right=0.97, bottom=0.15, top=0.9)
            bound = limit_of.get(metric, math.nan)
            # the bins span the bound too: bins over the samples alone are slivers beside a distant limit
            span = (min(values.min(), bound), max(values.max(), bound)) if math.isfinite(bound) else None
            ax.hist(values, bins=min(40, max(5, values.size // 5)), range=span, color="C0")
            if math.isfinite(bound):
                ax.axvline(bound, color="r", ls="--", lw=1.2, label=f"limit {bound:.4g}")
                ax.legend(fontsize=8)
            ax.set(xlabel=metric, ylabel="samples", title=f"{exp.name}: {len(completed)} samples")
            path = out / f"{exp.name}_{metric}.png"
            _save(fig, path)
            written.append(path)
    return written


def save_fuzz_plot(report: FuzzReport, path: str | Path) -> Path:
    """Write the figure of a fuzz run (:func:`fuzz_figure`) to a PNG file, atomically.

    Parameters
    ----------
    report : FuzzReport
        The fuzz run's report (:func:`~agvctl.fuzz.run.fuzz`).
    path : str or Path
        The PNG file to write.

    Returns
    -------
    Path
        The file written.
    """
    out = Path(path)
    _save(fuzz_figure(report), out)
    return out


def _minor_label(ax: Any, value: float, _pos: int | None) -> str:
    """A log axis's minor tick label, shown only where the axis spans less than a decade (too few majors)."""
    lo, hi = ax.get_xlim()
    return f"{value:.3g}" if hi < 10.0 * lo else ""


def fuzz_figure(report: FuzzReport) -> Any:
    """The figure of a fuzz run: how each controller's errors are distributed over the random scenarios.

    Four panels, one per metric of the first four of :data:`~agvctl.fuzz.report.FUZZ_METRICS` (largest and RMS
    cross-track error, final position error, RMS tracking error, all in m): for each controller, the share of its
    runs whose value is at most x, against x on a log scale (a zero drawn at the smallest positive value), with the
    fuzz configuration's bound on the metric as a red dashed line. A run that crashed counts as beyond the right
    edge: it is in every share's denominator, so the curve ends below 1 by the share of crashed runs. The title
    names the fuzz configuration, its seed and its number of runs.

    Parameters
    ----------
    report : FuzzReport
        The fuzz run's report (:func:`~agvctl.fuzz.run.fuzz`).

    Returns
    -------
    matplotlib.figure.Figure
        The figure, 11 × 7.5 inches, on an Agg canvas.
    """
    from matplotlib.ticker import FuncFormatter

    metrics = FUZZ_METRICS[:4]
    fig, axes = _subplots(2, 2, figsize=(11, 7.5))
    bounds = dict(report.spec.limits.items())
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
    """The figures of a wheel-loop design, as PNG bytes keyed by file name (what ``agvctl tune --plot`` writes).

    ``bode.png``: the left wheel's sampled open loop L(z) = C(z)·k_chain·G_zoh(z), its gain (dB) and phase (°) against
    the frequency ω (rad/s) up to the Nyquist frequency π/T_s, with the gain margin at Nyquist and the crossover with
    its phase margin. ``nyquist.png``: the same loop's Nyquist curve, L(e^{jωT_s}) for 0 < ω ≤ π/T_s (dashed: its mirror
    image), with the unit circle and the critical point −1. ``step.png``: the wheel-speed step on the nonlinear plant,
    both wheels' motor speeds (rad/s) against the setpoint, the motor voltages (V), and the peak armature current of
    each sample (A) against the amplifier's limit, titled with the step's rise time, overshoot and settling time.

    Parameters
    ----------
    design : TuningResult
        The PI design and its margins (:func:`~agvctl.controllers.pi.tuning.design_pi`).
    step : WheelStepResult
        The step response of the designed loops on the full plant
        (:func:`~agvctl.sim.wheel_step_response`).
    vehicle : VehicleParams
        The vehicle the step ran on (its amplifier's current limit is drawn).
    step_m_s : float
        The step's size as a rim speed, m/s, named in the step figure's title.

    Returns
    -------
    dict of str to bytes
        ``bode.png``, ``nyquist.png`` and ``step.png``, each a PNG file's content at 110 dots per inch.
    """
    ts = design.gains.dt_s
    num, den = loop_polynomials(design.gains, design.plant_left, design.chain_gain)
    return {
        "bode.png": _png(_bode_figure(design, num, den, ts)),
        "nyquist.png": _png(_nyquist_figure(num, den, ts)),
        "step.png": _png(_step_figure(step, vehicle, step_m_s)),
    }


def _png(fig: Any) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _bode_figure(design: TuningResult, num: Any, den: Any, ts: float) -> Any:
    """Gain and phase of the left wheel's open loop up to the Nyquist frequency, with its margins."""
    w_nyq = math.pi / ts
    w = np.geomspace(w_nyq * 1e-4, w_nyq, 2000)
    resp = frequency_response(num, den, ts, w)
    m = design.margins_left
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
    return fig


def _nyquist_figure(num: Any, den: Any, ts: float) -> Any:
    """The left wheel's open loop in the complex plane against −1 and the unit circle."""
    w_nyq = math.pi / ts
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
    return fig


def _step_figure(step: WheelStepResult, vehicle: VehicleParams, step_m_s: float) -> Any:
    """Both wheels' step on the nonlinear plant: motor speeds, voltages and peak currents."""
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
    return fig


def save_open_loop_plot(log: SimLog, vehicle: VehicleParams, path: str | Path, title: str = "") -> Path:
    """Write the figure of an open-loop run to a PNG file (what ``agvctl simulate --plot`` writes).

    On the left the vehicle's path in the plane (x, y in m, equal scale) from its start; on the right, against time
    (s), both motors' speeds (rad/s), the DA converter's output voltages (V) and the armature currents (A) between
    the amplifier's current limits.

    Parameters
    ----------
    log : SimLog
        The run's log (the ``log`` of :class:`~agvctl.sim.OpenLoopResult`).
    vehicle : VehicleParams
        The vehicle simulated (its amplifier's current limit is drawn).
    path : str or Path
        The PNG file to write, atomically.
    title : str
        The figure's title (empty: none).

    Returns
    -------
    Path
        The file written.
    """
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
