"""``agvctl identify mass``: M and h from three scale readings (eq 63), I from the dimensions (eq 64)."""

from __future__ import annotations

import argparse
import json
from typing import Any

from agvctl.calibration import apply_mass, identify_mass, simulated_scale_readings
from agvctl.calibration.mass import SCALE_NOISE_KG
from agvctl.cli.identify_common import add_common_options, check_common, command_line, table, vehicles, write_vehicle
from agvctl.errors import ConfigError

__all__ = ["register", "run"]


def register(isub: Any) -> None:
    """Add ``mass`` to the ``identify`` subparsers."""
    m = isub.add_parser(
        "mass",
        help="total mass and centre of mass from three scale readings (eq 63), I (eq 64)",
        description="M and h from the scale readings under the left, right and castor wheels "
        "(eq 63); I about the point of rotation from the frame and battery dimensions (eq 64).",
    )
    m.add_argument("--left", type=float, metavar="KG", help="scale reading under the left wheel")
    m.add_argument("--right", type=float, metavar="KG", help="scale reading under the right wheel")
    m.add_argument("--castor", type=float, metavar="KG", help="scale reading under the castor")
    m.add_argument(
        "--scale-stderr-kg",
        type=float,
        default=None,
        metavar="KG",
        help=f"one reading's standard error (default: 0, or {SCALE_NOISE_KG:g} x --noise with --simulate)",
    )
    add_common_options(m, "simulate the readings from the vehicle's M and h (with --set: the truth's)")
    m.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Identify the mass properties, print them (table or ``--json``), write ``--out``."""
    check_common(args)
    believed, truth = vehicles(args)
    if args.simulate:
        readings = simulated_scale_readings(truth or believed, noise_scale=args.noise, seed=args.seed)
        sigma = args.scale_stderr_kg if args.scale_stderr_kg is not None else args.noise * SCALE_NOISE_KG
        how = [f"mass: simulated scale readings (noise {args.noise:g} x {SCALE_NOISE_KG:g} kg, seed {args.seed})"]
    else:
        missing = [n for n in ("left", "right", "castor") if getattr(args, n) is None]
        if missing:
            raise ConfigError(
                "identify mass",
                "",
                "give --left, --right and --castor (kg), or --simulate; "
                f"missing {', '.join('--' + n for n in missing)}",
            )
        readings = (args.left, args.right, args.castor)
        sigma = args.scale_stderr_kg or 0.0
        how = [f"mass: scale readings left {args.left:g} kg, right {args.right:g} kg, castor {args.castor:g} kg"]
    try:
        fit = identify_mass(believed, *readings, scale_stderr_kg=sigma, truth=truth)
    except ValueError as exc:
        raise ConfigError("identify mass", "", str(exc)) from None
    how += [f"  {command_line()}", "  M = M_l + M_r + M_c; h = M_c/M d_wc (eq 63); I from the dimensions (eq 64)"]
    if args.out:
        write_vehicle(args.out, apply_mass(believed, fit), how)
    if args.json:
        print(json.dumps(fit.as_dict(), indent=2))
        return 0
    lines = [f"scale readings (kg): left {readings[0]:.4g}, right {readings[1]:.4g}, castor {readings[2]:.4g}"]
    b = believed.body
    lines += table(
        [
            ("M, total mass (kg)", b.mass_kg, fit.mass_kg, fit.mass_kg.truth),
            (
                "h, centre of mass behind the axle (m, eq 63)",
                b.com_behind_axle_m,
                fit.com_behind_axle_m,
                fit.com_behind_axle_m.truth,
            ),
            (
                "I, about the point of rotation (kg m², eq 64)",
                believed.derived.inertia_rotation_point_kg_m2,
                fit.inertia_kg_m2,
                fit.inertia_kg_m2.truth,
            ),
        ],
        args.simulate,
    )
    if args.out:
        lines.append(f"wrote {args.out}")
    print("\n".join(lines))
    return 0
