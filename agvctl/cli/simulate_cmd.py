"""``agvctl simulate``: the open-loop response of the full model to DA voltages."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import Output, check_outputs, vehicle_input, writing
from agvctl.errors import ConfigError
from agvctl.params import load_vehicle
from agvctl.sim.open_loop import OpenLoopResult, load_input_profile, sample_count, simulate_open_loop


def register(sub: Any) -> None:
    p = sub.add_parser(
        "simulate",
        help=command_summary("simulate"),
        description="Simulate the full nonlinear model from rest at the origin, the DA commands held over each "
        "sample period and passed through the DA converter and the amplifier.",
    )
    p.add_argument("--da-left", type=float, metavar="V", help="constant left DA command (V)")
    p.add_argument("--da-right", type=float, metavar="V", help="constant right DA command (V)")
    p.add_argument("--duration", type=float, metavar="S", required=True, help="simulated time (s)")
    p.add_argument(
        "--input", metavar="PROFILE.csv", help="CSV with columns t_s,da_left_v,da_right_v (held until the next row)"
    )
    add_vehicle_options(p)
    p.add_argument("--json", action="store_true", help="print the final state, peaks and timings as JSON")
    p.add_argument("--out", metavar="LOG.csv", help="write the per-sample log")
    p.add_argument("--plot", metavar="PLOT.png", help="draw the path, motor speeds, DA commands and currents")
    p.set_defaults(func=run)


def summary(result: OpenLoopResult) -> dict[str, Any]:
    """The ``--json`` object: final state, absolute peaks over the run, timings."""
    log = result.log
    final = log.row(-1)
    return {
        "final": {
            "t_s": final["t_s"],
            "x_m": final["x_m"],
            "y_m": final["y_m"],
            "theta_rad": final["theta_rad"],
            "speed_m_s": final["speed_m_s"],
            "yaw_rate_rad_s": final["yaw_rate_rad_s"],
            "omega_motor_left_rad_s": final["omega_motor_left_rad_s"],
            "omega_motor_right_rad_s": final["omega_motor_right_rad_s"],
        },
        "peak": {
            "current_left_a": log.peak_abs("current_peak_left_a"),
            "current_right_a": log.peak_abs("current_peak_right_a"),
            "wheel_accel_left_m_s2": log.peak_abs("wheel_accel_peak_left_m_s2"),
            "wheel_accel_right_m_s2": log.peak_abs("wheel_accel_peak_right_m_s2"),
        },
        "wall_time_s": result.wall_time_s,
        "setup_time_s": result.setup_time_s,
    }


def run(args: argparse.Namespace) -> int:
    vehicle = load_vehicle(args.vehicle, args.overrides)
    outputs = [Output(flag, Path(name)) for flag, name in (("--out", args.out), ("--plot", args.plot)) if name]
    check_outputs(outputs, [vehicle_input(args.vehicle), *([args.input] if args.input else [])])
    ts = vehicle.control.sample_period_s
    n = sample_count(args.duration, ts)
    if args.input:
        if args.da_left is not None or args.da_right is not None:
            raise ConfigError("--input", "", "give either --input or --da-left/--da-right, not both")
        da = load_input_profile(args.input, ts, args.duration)
    else:
        for flag, value in (("--da-left", args.da_left), ("--da-right", args.da_right)):
            if value is None:
                raise ConfigError(flag, "", "required unless --input is given")
            if not math.isfinite(value):
                raise ConfigError(flag, "", f"must be a finite voltage (got {value})")
        da = np.tile([args.da_left, args.da_right], (n, 1))
    result = simulate_open_loop(vehicle, da)
    if args.out:
        with writing("--out", args.out):
            result.log.to_csv(args.out)
    if args.plot:
        from agvctl.plots import save_open_loop_plot  # matplotlib only when asked for

        with writing("--plot", args.plot):
            save_open_loop_plot(result.log, vehicle, args.plot, title=f"{vehicle.name}: open loop")
    data = summary(result)
    if args.json:
        print(json.dumps(data, indent=2))
        return 0
    f, pk = data["final"], data["peak"]
    print(f"{vehicle.name}: {n} samples of {ts * 1e3:g} ms, open loop")
    print(f"  final pose       x = {f['x_m']:.4f} m   y = {f['y_m']:.4f} m   θ = {math.degrees(f['theta_rad']):.2f}°")
    print(f"  final speed      U = {f['speed_m_s']:.4f} m/s   ω = {f['yaw_rate_rad_s']:.4f} rad/s")
    ml, mr = f["omega_motor_left_rad_s"], f["omega_motor_right_rad_s"]
    print(f"  motor speeds     left {ml:.2f} rad/s   right {mr:.2f} rad/s")
    limit = vehicle.amplifier.current_limit_a
    il, ir = pk["current_left_a"], pk["current_right_a"]
    print(f"  peak current     left {il:.3f} A   right {ir:.3f} A   (limit {limit:g} A)")
    a_lim = vehicle.derived.accel_limit_m_s2
    al, ar = pk["wheel_accel_left_m_s2"], pk["wheel_accel_right_m_s2"]
    print(f"  peak wheel accel left {al:.3f} m/s²   right {ar:.3f} m/s²   (a_lim {a_lim:.3f})")
    wall, setup = data["wall_time_s"], data["setup_time_s"]
    rtf = args.duration / max(wall, 1e-9)
    print(f"  wall time        {wall * 1e3:.1f} ms simulating ({rtf:,.0f}x real time), {setup * 1e3:.0f} ms setup")
    if args.out:
        print(f"  log              {args.out}")
    if args.plot:
        print(f"  plot             {args.plot}")
    return 0
