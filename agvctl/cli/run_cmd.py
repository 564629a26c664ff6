"""``agvctl run``: one closed-loop experiment, with its log, summary and plots."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from agvctl.checks.summary import run_summary
from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import check_outputs, files_in, writing
from agvctl.cli.progress import Progress
from agvctl.cli.staging import check_replaceable, staged_outputs
from agvctl.planning.headroom import limits_report
from agvctl.plots import CLOSED_LOOP_PLOTS
from agvctl.reports import CALIBRATED_VEHICLE_FILE, RUN_FILES, write_run_outputs
from agvctl.scenario.experiment import load_experiment, run_experiment


def register(sub: Any) -> None:
    p = sub.add_parser(
        "run",
        help=command_summary("run"),
        description="Run an experiment file: plan its trajectory, track it with the pose controller and the PI "
        "wheel loops through the DA converter and amplifier on the full plant, write the log, a summary and plots.",
    )
    p.add_argument("experiment", metavar="EXPERIMENT.toml")
    add_vehicle_options(p, "the experiment's vehicle")
    p.add_argument("--out", metavar="DIR", help="output directory, replaced whole (default: out/<experiment name>)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG plots")
    p.add_argument("--json", action="store_true", help="print summary.json instead of the report")
    p.set_defaults(func=run)


def _fixed(value: float | None, scale: float) -> str:
    """``value · scale`` with two decimals; ``n/a`` for a value the summary holds as null (a diverged run)."""
    return "n/a" if value is None else f"{value * scale:.2f}"


def format_summary(summary: dict[str, Any]) -> str:
    """The readable report of ``agvctl run``."""
    m = summary["metrics"]
    rms, mx, fin = (m[k] * 1e3 for k in ("tracking_error_rms_m", "tracking_error_max_m", "final_position_error_m"))
    lines = [f"experiment: {summary['experiment']}   {'PASSED' if summary['passed'] else 'LIMITS VIOLATED'}"]
    lines.append(f"  tracking error    rms {rms:.2f} mm   max {mx:.2f} mm   final {fin:.2f} mm")
    lines.append(f"  heading error     max {m['heading_error_max_deg']:.2f}°")
    xr, xt, lag, hd = (
        _fixed(m[k], scale)
        for k, scale in (
            ("cross_track_error_rms_m", 1e3),
            ("cross_track_error_max_m", 1e3),
            ("along_track_lag_max_m", 1e3),
            ("path_heading_error_max_deg", 1.0),
        )
    )
    lines.append(f"  cross-track error rms {xr} mm   max {xt} mm   (off the path)")
    if "reference_drawn_path_deviation_m" in m:
        drawn, plan = (
            _fixed(m["drawn_cross_track_error_max_m"], 1e3),
            _fixed(m["reference_drawn_path_deviation_m"], 1e3),
        )
        lines.append(f"  drawn path        max {drawn} mm off it   (the plan leaves it by {plan} mm)")
    lines.append(f"  along-track lag   max {lag} mm   (behind or ahead of the clock, along the path)")
    lines.append(f"  path heading      max {hd}° from the path's at the nearest point")
    t2 = m["time_to_2cm_s"]
    lines.append(f"  within 2 cm       from t = {t2:.2f} s on" if t2 is not None else "  within 2 cm       never")
    acc, cur = m["peak_wheel_accel_m_s2"], m["peak_motor_current_a"]
    lines.append(f"  peak wheel accel  {acc:.3f} m/s²   peak current {cur:.2f} A")
    lin, lat, ang = (m[f"peak_body_{k}"] for k in ("linear_accel_m_s2", "lateral_accel_m_s2", "angular_accel_rad_s2"))
    lines.append(f"  payload feels     {lin:.3f} m/s² along   {lat:.3f} m/s² across   {ang:.3f} rad/s² turning (peaks)")
    da, cl = m["da_saturation_fraction"] * 100, m["current_limited_fraction"] * 100
    lines.append(f"  DA saturated      {da:.1f} % of samples   current-limited {cl:.1f} % of time")
    p50, p99 = m["solve_time_p50_ms"], m["solve_time_p99_ms"]
    lines.append(
        f"  pose controller   {p50:.3f} ms median, {p99:.3f} ms p99, "
        f"{m['solver_failures']} failures, {m['deadline_misses']} deadline misses"
        + (f", {m['non_finite_commands']} NaN or infinite commands" if m.get("non_finite_commands") else "")
    )
    if m.get("estimate_error_max_m"):  # an estimator other than the truth
        est_rms, est_max = m["estimate_error_rms_m"] * 1e3, m["estimate_error_max_m"] * 1e3
        line = f"  pose estimate     rms {est_rms:.2f} mm   max {est_max:.2f} mm   "
        line += f"heading max {m['heading_estimate_error_max_deg']:.2f}°"
        if m.get("nees_mean") is not None:
            line += f"   NEES mean {m['nees_mean']:.2f} (3 dof)"
        lines.append(line)
        if "fixes_rejected" in m:
            counts = ", ".join(f"{m['fixes_' + k]} {k}" for k in ("rejected", "dropped", "reordered"))
            lines.append(f"  position fixes    {counts} (gate, too old, out of order)")
    for key, c in summary.get("calibration", {}).items():
        err = f"   ({c['error_sigmas']:+.1f}σ)" if c.get("error_sigmas") is not None else ""
        lines.append(
            f"  calibration       {key:<22} {c['believed'] * 1e3:.3f} → {c['estimate'] * 1e3:.3f} ± "
            f"{c['sigma'] * 1e3:.3f} mm   truth {c['truth'] * 1e3:.3f} mm{err}"
        )
    wall, sim = summary["wall_time_s"], summary["simulated_s"]
    where = " in C" if summary.get("loop") == "c" else ""
    lines.append(
        f"  wall time         {wall:.2f} s for {sim:.1f} s simulated ({sim / max(wall, 1e-9):.0f}x real time, "
        f"the loop{where or ' in Python'})"
    )
    for r in summary["limits"]:
        lines.append(f"  {r['kind']:<5}  {r['message']}")
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    experiment = load_experiment(args.experiment, vehicle=args.vehicle, vehicle_overrides=args.overrides)
    name = experiment.spec.name
    out_dir = Path(args.out) if args.out else Path("out") / name
    plots = () if args.no_plot else (*CLOSED_LOOP_PLOTS, "estimate.png")
    names: tuple[str, ...] = (*RUN_FILES, CALIBRATED_VEHICLE_FILE, *plots)
    check_outputs(files_in("--out", out_dir, names), experiment.input_files, [("--out", out_dir)])
    check_replaceable("--out", out_dir, experiment.input_files)
    with Progress(name) as progress:
        result = run_experiment(experiment, progress=progress)
    summary = run_summary(experiment, result)
    with staged_outputs("run") as staging:  # the folder is replaced whole, once every file is written
        staged = staging.directory("--out", out_dir)
        with writing("--out", out_dir):
            written = write_run_outputs(experiment, result, summary, staged, plots=not args.no_plot)
    written = [out_dir / p.relative_to(staged) for p in written]
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(format_summary(summary))
        if experiment.path is not None:
            print("\n".join(limits_report(experiment.reference, experiment.path.limits, experiment.controller_vehicle)))
        print(f"  wrote             {', '.join(str(p) for p in written)}")
    return 0
