"""``agvctl identify {mass,friction,umbmark}``: the report's appendix A.1 procedures on measurements or on the
simulator, the result written back as a vehicle TOML (``--out``).

With ``--simulate`` the vehicle (``--vehicle``) is what the controllers believe and ``--set`` changes only the
simulated truth (the plant); without ``--set``, friction and UMBmark simulate a demonstration truth that differs
from the vehicle (printed). With ``--log`` or scale readings, ``--set`` changes the vehicle as everywhere else.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from datetime import UTC, datetime
from typing import Any

from agvctl.calibration import (
    FRICTION_LOG_COLUMNS,
    UMBMARK_LOG_COLUMNS,
    Estimate,
    FrictionExperiment,
    UmbmarkConfig,
    apply_friction,
    apply_mass,
    fit_friction,
    identify_mass,
    read_friction_log,
    read_umbmark_log,
    simulate_friction_experiment,
    simulate_umbmark,
    simulated_scale_readings,
    umbmark_correction,
)
from agvctl.calibration.friction import SIDES, SPEED_NOISE_RAD_S
from agvctl.calibration.mass import SCALE_NOISE_KG
from agvctl.calibration.umbmark import POSITION_NOISE_M
from agvctl.cli.options import add_vehicle_options
from agvctl.config import dump_toml, to_dict
from agvctl.errors import ConfigError
from agvctl.fileio import write_text
from agvctl.params import VehicleParams, load_vehicle

DEMO_FRICTION_TRUTH = (
    "motor.left.viscous_friction_n_m_s_rad=1.5e-4",
    "motor.left.coulomb_friction_n_m=0.060",
    "motor.left.stiction_n_m=0.070",
    "motor.right.viscous_friction_n_m_s_rad=2.5e-4",
    "motor.right.coulomb_friction_n_m=0.070",
    "motor.right.stiction_n_m=0.075",
)
"""The simulated truth of ``identify friction --simulate`` without ``--set``: both sides different."""

DEMO_UMBMARK_RATIO, DEMO_UMBMARK_SEPARATION_FACTOR = 1.005, 1.01
"""The simulated truth of ``identify umbmark --simulate`` without ``--set``: r_r/r_l = 1.005, b 1 % larger."""


_DESCRIPTION = """\
The report's appendix A.1 procedures on measurements or on the simulator; --out writes the result as a vehicle TOML.

With --simulate the vehicle (--vehicle) is what the controllers believe and --set changes only the simulated
truth (the plant); without --set, friction and umbmark simulate a demonstration truth that differs from the
vehicle (printed). With --log or scale readings, --set changes the vehicle as everywhere else."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "identify",
        help="identify vehicle constants: mass, friction, wheel geometry (appendix A.1)",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    isub = p.add_subparsers(dest="procedure", metavar="PROCEDURE", parser_class=type(p))
    isub.required = True

    m = isub.add_parser("mass", help="total mass and centre of mass from three scale readings (eq 63), I (eq 64)",
                        description="M and h from the scale readings under the left, right and castor wheels "
                        "(eq 63); I about the point of rotation from the frame and battery dimensions (eq 64).")
    m.add_argument("--left", type=float, metavar="KG", help="scale reading under the left wheel")
    m.add_argument("--right", type=float, metavar="KG", help="scale reading under the right wheel")
    m.add_argument("--castor", type=float, metavar="KG", help="scale reading under the castor")
    m.add_argument("--scale-stderr-kg", type=float, default=None, metavar="KG",
                   help=f"one reading's standard error (default: 0, or {SCALE_NOISE_KG:g} x --noise with --simulate)")
    _common(m, "simulate the readings from the vehicle's M and h (with --set: the truth's)")
    m.set_defaults(func=run_mass)

    f_cols = "\n".join(f"  {k:<34} {v}" for k, v in FRICTION_LOG_COLUMNS.items())
    f = isub.add_parser(
        "friction",
        help="viscous, Coulomb friction and stiction per side (eqs 65-69, corrected)",
        description="Viscous and Coulomb friction per side by least squares over constant-speed windows, stiction "
        "from a slow DA ramp (eqs 65-69 as corrected in the ERRATA).\n\nLog columns (CSV with a header):\n" + f_cols,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    f.add_argument("--log", metavar="LOG.csv", help="fit a measured log (columns above)")
    f.add_argument("--speeds", metavar="W1,W2,...", default=None,
                   help="--simulate: motor speeds the PI loops hold, rad/s (default 50,100,150,200; both directions)")
    f.add_argument("--save-log", metavar="PATH", help="--simulate: also write the simulated log as CSV")
    _common(f, "run the experiment on the simulator (PI holding N speeds, then the ramps) and fit it")
    f.set_defaults(func=run_friction)

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
    u.add_argument("--method", choices=("exact", "first_order"), default="exact",
                   help="exact: refine B&F's first-order alpha, beta on the exact error model (default)")
    _common(u, "drive the squares on the simulator, correct, and drive them again")
    u.set_defaults(func=run_umbmark)


def _common(p: argparse.ArgumentParser, simulate_help: str) -> None:
    add_vehicle_options(p)
    p.add_argument("--simulate", action="store_true", help=simulate_help + "; --set changes the truth only")
    p.add_argument("--noise", type=float, default=0.0, metavar="SCALE",
                   help="--simulate: measurement noise, 0 = none, 1 = realistic (default 0)")
    p.add_argument("--seed", type=int, default=None, metavar="N", help="--simulate: random seed for the noise")
    p.add_argument("--out", metavar="VEHICLE.toml", help="write the vehicle with the identified values")
    p.add_argument("--json", action="store_true", help="print the result as JSON")


# ----------------------------------------------------------------------------------------------------------------


def _command_line() -> str:
    return "agvctl " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else "agvctl identify"


def _check_noise(args: argparse.Namespace) -> None:
    if not (math.isfinite(args.noise) and args.noise >= 0):
        raise ConfigError("--noise", "", f"must be >= 0 (got {args.noise:g})")


def _vehicles(args: argparse.Namespace, demo: list[str] | None = None) -> tuple[VehicleParams, VehicleParams | None]:
    """(believed vehicle, simulated truth or None)."""
    if not args.simulate:
        return load_vehicle(args.vehicle, args.overrides), None
    believed = load_vehicle(args.vehicle)
    sets = list(args.overrides) if args.overrides else list(demo or [])
    truth = believed.with_overrides(sets, source="--set") if sets else believed
    return believed, truth


def _fmt(value: float | None, width: int = 14) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return f"{'-':>{width}}"
    return f"{value:>{width}.6g}"


def _est(e: Estimate) -> str:
    se = f"{e.stderr:.2g}" if math.isfinite(e.stderr) else "?"
    return f"{e.estimate:>13.6g} ± {se:<8}"


def _write_vehicle(path: str, vehicle: VehicleParams, how: list[str]) -> None:
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    header = "\n".join([f"Vehicle '{vehicle.name}' with values identified by agvctl ({stamp}):", *how])
    write_text(path, dump_toml(to_dict(vehicle), header=header) + "\n")
    load_vehicle(path)  # it must read back


def _table(rows: list[tuple[str, float | None, Estimate, float | None]], simulate: bool) -> list[str]:
    head = f"  {'':<48} {'before':>14} {'after (estimate ± stderr)':>25}"
    lines = [head + (f" {'truth':>14}" if simulate else "")]
    for label, before, est, truth in rows:
        line = f"  {label:<48} {_fmt(before)} {_est(est)}"
        if simulate:
            line += f" {_fmt(truth)}"
        lines.append(line)
    return lines


# ----------------------------------------------------------------------------------------------------------------
# mass


def run_mass(args: argparse.Namespace) -> int:
    _check_noise(args)
    believed, truth = _vehicles(args)
    if args.simulate:
        readings = simulated_scale_readings(truth or believed, noise_scale=args.noise, seed=args.seed)
        sigma = args.scale_stderr_kg if args.scale_stderr_kg is not None else args.noise * SCALE_NOISE_KG
        how = [f"mass: simulated scale readings (noise {args.noise:g} x {SCALE_NOISE_KG:g} kg, seed {args.seed})"]
    else:
        missing = [n for n in ("left", "right", "castor") if getattr(args, n) is None]
        if missing:
            raise ConfigError("identify mass", "", "give --left, --right and --castor (kg), or --simulate; "
                              f"missing {', '.join('--' + n for n in missing)}")
        readings = (args.left, args.right, args.castor)
        sigma = args.scale_stderr_kg or 0.0
        how = [f"mass: scale readings left {args.left:g} kg, right {args.right:g} kg, castor {args.castor:g} kg"]
    try:
        fit = identify_mass(believed, *readings, scale_stderr_kg=sigma, truth=truth)
    except ValueError as exc:
        raise ConfigError("identify mass", "", str(exc)) from None
    how += [f"  {_command_line()}", "  M = M_l + M_r + M_c; h = M_c/M d_wc (eq 63); I from the dimensions (eq 64)"]
    if args.out:
        _write_vehicle(args.out, apply_mass(believed, fit), how)
    if args.json:
        print(json.dumps(fit.as_dict(), indent=2))
        return 0
    lines = [f"scale readings (kg): left {readings[0]:.4g}, right {readings[1]:.4g}, castor {readings[2]:.4g}"]
    b = believed.body
    lines += _table([
        ("M, total mass (kg)", b.mass_kg, fit.mass_kg, fit.mass_kg.truth),
        ("h, centre of mass behind the axle (m, eq 63)", b.com_behind_axle_m, fit.com_behind_axle_m,
         fit.com_behind_axle_m.truth),
        ("I, about the point of rotation (kg m², eq 64)", believed.derived.inertia_rotation_point_kg_m2,
         fit.inertia_kg_m2, fit.inertia_kg_m2.truth),
    ], args.simulate)
    if args.out:
        lines.append(f"wrote {args.out}")
    print("\n".join(lines))
    return 0


# ----------------------------------------------------------------------------------------------------------------
# friction

_FRICTION_KEYS = (
    ("viscous_friction_n_m_s_rad", "f_m, viscous (N m s/rad)"),
    ("coulomb_friction_n_m", "τ_c, Coulomb (N m)"),
    ("stiction_n_m", "τ_s, stiction/break-away (N m)"),
)


def run_friction(args: argparse.Namespace) -> int:
    _check_noise(args)
    if bool(args.log) == bool(args.simulate):
        raise ConfigError("identify friction", "", "give exactly one of --log LOG.csv and --simulate")
    believed, truth = _vehicles(args, list(DEMO_FRICTION_TRUTH))
    if args.simulate:
        experiment = FrictionExperiment()
        if args.speeds:
            try:
                speeds = tuple(float(s) for s in args.speeds.split(","))
                experiment = FrictionExperiment(motor_speeds_rad_s=speeds)
            except ValueError as exc:
                raise ConfigError("--speeds", "", f"expected positive motor speeds in rad/s: {exc}") from None
        assert truth is not None
        log = simulate_friction_experiment(truth, believed, experiment, noise_scale=args.noise, seed=args.seed)
        if args.save_log:
            log.write_csv(args.save_log)
        how = [f"friction: simulated experiment, speeds {list(experiment.motor_speeds_rad_s)} rad/s both directions, "
               f"speed noise {args.noise:g} x {SPEED_NOISE_RAD_S:g} rad/s (seed {args.seed})"]
    else:
        log = read_friction_log(args.log)
        how = [f"friction: fitted to the log {args.log}"]
    fit = fit_friction(log, believed, truth=truth)
    identified, notes = apply_friction(believed, fit)
    how += [f"  {_command_line()}",
            "  least squares k_pow k_t u/R - k_e k_t w/R = f_m w + tau_c sign(w) (eqs 66-69, ERRATA); "
            "tau_s = k_pow k_t u/R at break-away (eq 65, ERRATA)"]
    for name in SIDES:
        s = fit.side(name)
        how.append(f"  {name}: f_m {_est(s.viscous_friction_n_m_s_rad).strip()}, tau_c "
                   f"{_est(s.coulomb_friction_n_m).strip()}, tau_s {_est(s.stiction_n_m).strip()}")
    how += [f"  note: {n}" for n in (*fit.notes, *notes)]
    if args.out:
        _write_vehicle(args.out, identified, how)
    if args.json:
        print(json.dumps(fit.as_dict(), indent=2))
        return 0
    lines = []
    if args.simulate and truth is not None:
        lines.append("simulated truth: " + (" ".join(args.overrides) if args.overrides else
                                            " ".join(DEMO_FRICTION_TRUTH) + "  (demonstration; --set to change)"))
    for name in SIDES:
        s = fit.side(name)
        before = believed.motor.side(name)
        lines.append(f"{name}: {len(s.windows)} constant-speed windows, {len(s.breakaway_da_voltages_v)} ramps")
        lines += _table([
            (label, getattr(before, key), getattr(s, key), getattr(s, key).truth) for key, label in _FRICTION_KEYS
        ], args.simulate)
    lines += [f"note: {n}" for n in (*fit.notes, *notes)]
    if args.save_log:
        lines.append(f"wrote {args.save_log}")
    if args.out:
        lines.append(f"wrote {args.out}")
    print("\n".join(lines))
    return 0


# ----------------------------------------------------------------------------------------------------------------
# UMBmark


def run_umbmark(args: argparse.Namespace) -> int:
    _check_noise(args)
    if bool(args.log) == bool(args.simulate):
        raise ConfigError("identify umbmark", "", "give exactly one of --log RUNS.csv and --simulate")
    if not (math.isfinite(args.side_m) and args.side_m > 0):
        raise ConfigError("--side-m", "", f"must be > 0 (got {args.side_m:g})")
    if args.runs < 1:
        raise ConfigError("--runs", "", f"must be >= 1 (got {args.runs})")
    nominal = load_vehicle(args.vehicle)
    demo = [
        f"wheels.radius_right_m={nominal.wheels.radius_left_m * DEMO_UMBMARK_RATIO!r}",
        f"wheels.separation_m={nominal.wheels.separation_m * DEMO_UMBMARK_SEPARATION_FACTOR!r}",
    ]
    believed, truth = _vehicles(args, demo)
    error_after: float | None
    if args.simulate:
        assert truth is not None
        result = simulate_umbmark(truth, believed, UmbmarkConfig(side_length_m=args.side_m,
                                                                 runs_per_direction=args.runs),
                                  noise_scale=args.noise, seed=args.seed, method=args.method)
        corr, corrected, error_after = result.correction, result.corrected_vehicle, result.error_after_m
        how = [f"UMBmark: simulated, {args.runs} runs per direction of a {args.side_m:g} m square, end-position "
               f"noise {args.noise:g} x {POSITION_NOISE_M * 1000:g} mm (seed {args.seed})"]
        notes = list(result.notes)
    else:
        cw, ccw = read_umbmark_log(args.log)
        corr = umbmark_correction(cw, ccw, side_length_m=args.side_m, vehicle=believed, method=args.method)
        corrected, error_after = corr.apply(believed), None
        how = [f"UMBmark: measured end positions {args.log}, {len(cw)} cw and {len(ccw)} ccw runs of a "
               f"{args.side_m:g} m square"]
        notes = []
    how += [
        f"  {_command_line()}",
        f"  alpha = {corr.alpha_rad.estimate:.6g} rad, beta = {corr.beta_rad.estimate:.6g} rad ({args.method}); "
        f"E_d = {corr.diameter_ratio_correction:.8g}; b = 90/(90 - alpha) b_nominal",
        f"  E_max,syst before: {corr.error_m:.4g} m" + (f", after: {error_after:.4g} m" if error_after is not None
                                                         else ""),
    ]
    if args.out:
        _write_vehicle(args.out, corrected, how)
    if args.json:
        print(json.dumps({
            "error_before_m": corr.error_m,
            "error_after_m": error_after,
            "wheel_radius_ratio": corr.wheel_radius_ratio.as_dict(),
            "separation_m": corr.separation_m.as_dict(),
            "radius_left_m": corr.radius_left_m.as_dict(),
            "radius_right_m": corr.radius_right_m.as_dict(),
        }, indent=2))
        return 0
    lines = []
    if args.simulate:
        lines.append("simulated truth: " + (" ".join(args.overrides) if args.overrides else
                                            " ".join(demo) + "  (demonstration; --set to change)"))
    w = believed.wheels
    lines.append(f"centroids (m): cw ({corr.centroid_cw_m[0]:+.4f}, {corr.centroid_cw_m[1]:+.4f}), "
                 f"ccw ({corr.centroid_ccw_m[0]:+.4f}, {corr.centroid_ccw_m[1]:+.4f}); "
                 f"alpha {math.degrees(corr.alpha_rad.estimate):.4f}°, "
                 f"beta {math.degrees(corr.beta_rad.estimate):.4f}°")
    lines += _table([
        ("radius_left_m", w.radius_left_m, corr.radius_left_m, corr.radius_left_m.truth),
        ("radius_right_m", w.radius_right_m, corr.radius_right_m, corr.radius_right_m.truth),
        ("wheel radius ratio r_r/r_l", w.radius_right_m / w.radius_left_m, corr.wheel_radius_ratio,
         corr.wheel_radius_ratio.truth),
        ("separation_m", w.separation_m, corr.separation_m, corr.separation_m.truth),
    ], args.simulate)
    after = f"{error_after:.4g} m" if error_after is not None else "(drive the squares again to measure)"
    ratio = f"  ({corr.error_m / error_after:.0f}x smaller)" if error_after else ""
    lines.append(f"  E_max,syst: before {corr.error_m:.4g} m, after {after}{ratio}")
    if args.simulate:
        lines.append("  (truth of the wheel base: b r̄_believed/r̄_true, the value the odometry needs; the mean "
                     "radius is not observable by UMBmark and is kept)")
    lines += [f"note: {n}" for n in notes]
    if args.out:
        lines.append(f"wrote {args.out}")
    print("\n".join(lines))
    return 0
