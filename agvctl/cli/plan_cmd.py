"""``agvctl plan``: a path file → a time-optimal reference within the wheel limits (summary, CSV, plot)."""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from typing import Any

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import Output, check_outputs, vehicle_input, writing
from agvctl.fileio import atomic_open, write_csv
from agvctl.params import load_vehicle
from agvctl.planning import CSV_COLUMNS, HeadroomWarning, PhysicalLimitWarning, Reference, load_path, plan
from agvctl.planning.headroom import limits_report


def register(sub: Any) -> None:
    p = sub.add_parser(
        "plan",
        help=command_summary("plan"),
        description="Plan a time-optimal, jerk-limited reference from a path file ([[segments]] or "
        "[[waypoints]]), within the wheel limits. The reference drives through curvature changes "
        "on smooth joins and stops only at reversals, turns in place and the end "
        '(join = "stop" in the file: wherever the curvature or the direction of travel changes).',
    )
    p.add_argument("file", metavar="FILE", help="path file (TOML), e.g. trajectories/square.toml")
    add_vehicle_options(p)
    p.add_argument(
        "--json",
        action="store_true",
        help='print {"name", "duration_s", "path_length_m", "peak_wheel_speed_m_s", '
        '"peak_wheel_accel_m_s2", "peak_wheel_jerk_m_s3", "drawn_path_deviation_m", "drawn_path_tolerance_m", '
        '"final_pose"}',
    )
    p.add_argument(
        "--out",
        metavar="REF.csv",
        default=None,
        help=f"write the reference on the control grid as CSV ({', '.join(CSV_COLUMNS)})",
    )
    p.add_argument(
        "--plot",
        metavar="REF.png",
        default=None,
        help="draw the path, its curvature against arc length, and the wheel speeds and "
        "accelerations against their limits",
    )
    p.add_argument(
        "--force", action="store_true", help="accept limits above what the vehicle can physically do (with a warning)"
    )
    p.set_defaults(func=run)


def format_summary(summary: dict[str, Any]) -> str:
    """The human-readable form of :meth:`Reference.summary`."""
    pose = summary["final_pose"]
    return "\n".join(
        [
            f"path: {summary['name']}",
            f"  duration              {summary['duration_s']:10.3f} s",
            f"  path length           {summary['path_length_m']:10.3f} m",
            f"  peak wheel speed      {summary['peak_wheel_speed_m_s']:10.4f} m/s",
            f"  peak wheel accel      {summary['peak_wheel_accel_m_s2']:10.4f} m/s²",
            f"  peak wheel jerk       {summary['peak_wheel_jerk_m_s3']:10.4f} m/s³",
            f"  off the drawn path    {summary['drawn_path_deviation_m'] * 1e3:10.2f} mm (largest; tolerance "
            f"{_mm(summary['drawn_path_tolerance_m'])}, limits.drawn_path_tolerance_m)",
            f"  final pose            x {pose['x_m']:.4f} m, y {pose['y_m']:.4f} m, θ {pose['theta_rad']:.4f} rad",
        ]
    )


def _mm(value_m: float | None) -> str:
    return "none" if value_m is None else f"{value_m * 1e3:g} mm"


def _write_bytes(path: str, data: bytes) -> None:
    with atomic_open(path, "wb") as fh:
        fh.write(data)


def run(args: argparse.Namespace) -> int:
    vehicle = load_vehicle(args.vehicle, args.overrides)
    spec = load_path(args.file)
    outputs = [Output(flag, Path(name)) for flag, name in (("--out", args.out), ("--plot", args.plot)) if name]
    check_outputs(outputs, [args.file, vehicle_input(args.vehicle)])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PhysicalLimitWarning)
        warnings.simplefilter("always", HeadroomWarning)
        ref: Reference = plan(spec, vehicle, force=args.force)
    for w in caught:
        print(f"agvctl: warning: {w.message}", file=sys.stderr)
    summary = ref.summary()
    png = None
    if args.plot:  # render everything before writing anything
        from agvctl.plots.path import render_reference_png

        png = render_reference_png(ref)
    if args.out:
        columns = ref.grid.columns(CSV_COLUMNS)
        with writing("--out", args.out):
            write_csv(args.out, columns)
    if png is not None:
        with writing("--plot", args.plot):
            _write_bytes(args.plot, png)
    print(json.dumps(summary, indent=2) if args.json else format_summary(summary))
    if not args.json:
        print("\n".join(limits_report(ref, spec.limits, vehicle)))
    return 0
