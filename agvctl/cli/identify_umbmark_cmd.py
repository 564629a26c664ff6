"""``agvctl identify umbmark``: wheel-radius ratio and wheel base by Borenstein & Feng's UMBmark, from measured
end positions or squares driven on the simulator."""

from __future__ import annotations

import argparse
import json
import math
from typing import Any

from agvctl.calibration import (
    UMBMARK_LOG_COLUMNS,
    UmbmarkConfig,
    read_umbmark_log,
    simulate_umbmark,
    umbmark_correction,
)
from agvctl.calibration.umbmark import POSITION_NOISE_M, UmbmarkCorrection
from agvctl.calibration.umbmark.experiment import MAX_RUNS_PER_DIRECTION, MAX_SIDE_LENGTH_M
from agvctl.cli.identify_common import add_common_options, check_common, command_line, table, vehicles, write_vehicle
from agvctl.errors import ConfigError
from agvctl.params import VehicleParams, load_vehicle

__all__ = ["DEMO_UMBMARK_RATIO", "DEMO_UMBMARK_SEPARATION_FACTOR", "register", "run"]

DEMO_UMBMARK_RATIO, DEMO_UMBMARK_SEPARATION_FACTOR = 1.005, 1.01
"""The simulated truth of ``identify umbmark --simulate`` without ``--set``: r_r/r_l = 1.005, b 1 % larger."""


def register(isub: Any) -> None:
    """Add ``umbmark`` to the ``identify`` subparsers."""
    u_cols = "\n".join(f"  {k:<10} {v}" for k, v in UMBMARK_LOG_COLUMNS.items())
    u = isub.add_parser(
        "umbmark",
        help="wheel-radius ratio and wheel base by Borenstein & Feng's UMBmark",
        description="UMBmark: squares driven cw and ccw on odometry; the return-position errors give the "
        "wheel-diameter ratio and the wheel base (Borenstein & Feng 1996).\n\nLog columns (CSV with a header, one "
        "row per run; start at the origin heading along +x, ccw = left turns):\n" + u_cols,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    u.add_argument("--log", metavar="RUNS.csv", help="measured end positions (columns above)")
    u.add_argument("--side-m", type=float, default=4.0, metavar="L", help="side of the square (default 4 m)")
    u.add_argument("--runs", type=int, default=5, metavar="N", help="--simulate: runs per direction (default 5)")
    u.add_argument(
        "--method",
        choices=("exact", "first_order"),
        default="exact",
        help="exact: refine B&F's first-order alpha, beta on the exact error model (default)",
    )
    add_common_options(u, "drive the squares on the simulator, correct, and drive them again")
    u.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run UMBmark (simulated or ``--log``), print the correction (table or ``--json``), write ``--out``."""
    check_common(args)
    if bool(args.log) == bool(args.simulate):
        raise ConfigError("identify umbmark", "", "give exactly one of --log RUNS.csv and --simulate")
    if not (math.isfinite(args.side_m) and 0 < args.side_m <= MAX_SIDE_LENGTH_M):
        raise ConfigError("--side-m", "", f"must be > 0 and <= {MAX_SIDE_LENGTH_M:g} m (got {args.side_m:g})")
    if not 1 <= args.runs <= MAX_RUNS_PER_DIRECTION:
        raise ConfigError("--runs", "", f"must be >= 1 and <= {MAX_RUNS_PER_DIRECTION} (got {args.runs})")
    nominal = load_vehicle(args.vehicle)
    demo = [
        f"wheels.right.radius_m={nominal.wheels.left.radius_m * DEMO_UMBMARK_RATIO!r}",
        f"wheels.separation_m={nominal.wheels.separation_m * DEMO_UMBMARK_SEPARATION_FACTOR!r}",
    ]
    believed, truth = vehicles(args, demo)
    error_after: float | None
    if args.simulate:
        assert truth is not None
        result = simulate_umbmark(
            truth,
            believed,
            UmbmarkConfig(side_length_m=args.side_m, runs_per_direction=args.runs),
            noise_scale=args.noise,
            seed=args.seed,
            method=args.method,
        )
        corr, corrected, error_after = result.correction, result.corrected_vehicle, result.error_after_m
        how = [
            f"UMBmark: simulated, {args.runs} runs per direction of a {args.side_m:g} m square, end-position "
            f"noise {args.noise:g} x {POSITION_NOISE_M * 1000:g} mm (seed {args.seed})"
        ]
        notes = list(result.notes)
    else:
        cw, ccw = read_umbmark_log(args.log)
        corr = umbmark_correction(cw, ccw, side_length_m=args.side_m, vehicle=believed, method=args.method)
        corrected, error_after = corr.apply(believed), None
        how = [
            f"UMBmark: measured end positions {args.log}, {len(cw)} cw and {len(ccw)} ccw runs of a "
            f"{args.side_m:g} m square"
        ]
        notes = []
    how += [
        f"  {command_line()}",
        f"  alpha = {corr.alpha_rad.estimate:.6g} rad, beta = {corr.beta_rad.estimate:.6g} rad ({args.method}); "
        f"E_d = {corr.diameter_ratio_correction:.8g}; b = 90/(90 - alpha) b_nominal",
        f"  E_max,syst before: {corr.error_m:.4g} m"
        + (f", after: {error_after:.4g} m" if error_after is not None else ""),
    ]
    if args.out:
        write_vehicle(args.out, corrected, how)
    if args.json:
        print(json.dumps(_json_summary(corr, error_after), indent=2))
        return 0
    print(_text_summary(args, demo, believed, corr, error_after, notes))
    return 0


def _json_summary(corr: UmbmarkCorrection, error_after: float | None) -> dict[str, object]:
    return {
        "error_before_m": corr.error_m,
        "error_after_m": error_after,
        "wheel_radius_ratio": corr.wheel_radius_ratio.as_dict(),
        "separation_m": corr.separation_m.as_dict(),
        "radius_left_m": corr.radius_left_m.as_dict(),
        "radius_right_m": corr.radius_right_m.as_dict(),
    }


def _text_summary(
    args: argparse.Namespace,
    demo: list[str],
    believed: VehicleParams,
    corr: UmbmarkCorrection,
    error_after: float | None,
    notes: list[str],
) -> str:
    """The human-readable report: centroids, the before/after table and E_max,syst."""
    lines = []
    if args.simulate:
        lines.append(
            "simulated truth: "
            + (" ".join(args.overrides) if args.overrides else " ".join(demo) + "  (demonstration; --set to change)")
        )
    w = believed.wheels
    lines.append(
        f"centroids (m): cw ({corr.centroid_cw_m[0]:+.4f}, {corr.centroid_cw_m[1]:+.4f}), "
        f"ccw ({corr.centroid_ccw_m[0]:+.4f}, {corr.centroid_ccw_m[1]:+.4f}); "
        f"alpha {math.degrees(corr.alpha_rad.estimate):.4f}°, "
        f"beta {math.degrees(corr.beta_rad.estimate):.4f}°"
    )
    lines += table(
        [
            ("radius_left_m", w.left.radius_m, corr.radius_left_m, corr.radius_left_m.truth),
            ("radius_right_m", w.right.radius_m, corr.radius_right_m, corr.radius_right_m.truth),
            (
                "wheel radius ratio r_r/r_l",
                w.right.radius_m / w.left.radius_m,
                corr.wheel_radius_ratio,
                corr.wheel_radius_ratio.truth,
            ),
            ("separation_m", w.separation_m, corr.separation_m, corr.separation_m.truth),
        ],
        args.simulate,
    )
    after = f"{error_after:.4g} m" if error_after is not None else "(drive the squares again to measure)"
    ratio = f"  ({corr.error_m / error_after:.0f}x smaller)" if error_after else ""
    lines.append(f"  E_max,syst: before {corr.error_m:.4g} m, after {after}{ratio}")
    if args.simulate:
        lines.append(
            "  (truth of the wheel base: b r̄_believed/r̄_true, the value the odometry needs; the mean "
            "radius is not observable by UMBmark and is kept)"
        )
    lines += [f"note: {n}" for n in notes]
    if args.out:
        lines.append(f"wrote {args.out}")
    return "\n".join(lines)
