"""``agvctl identify friction``: viscous, Coulomb friction and stiction per side (eqs 65-69, corrected as in the
model notes, docs/model-notes.md), from a measured log or the simulated experiment."""

from __future__ import annotations

import argparse
import json
from typing import Any

from agvctl.calibration import (
    FRICTION_LOG_COLUMNS,
    FrictionExperiment,
    apply_friction,
    fit_friction,
    read_friction_log,
    simulate_friction_experiment,
)
from agvctl.calibration.friction import SIDES, SPEED_NOISE_RAD_S
from agvctl.cli.identify_common import (
    add_common_options,
    check_common,
    command_line,
    format_estimate,
    table,
    vehicles,
    write_vehicle,
)
from agvctl.cli.outputs import writing
from agvctl.errors import ConfigError

__all__ = ["DEMO_FRICTION_TRUTH", "register", "run"]

DEMO_FRICTION_TRUTH = (
    "motor.left.viscous_friction_n_m_s_rad=1.5e-4",
    "motor.left.coulomb_friction_n_m=0.060",
    "motor.left.stiction_n_m=0.070",
    "motor.right.viscous_friction_n_m_s_rad=2.5e-4",
    "motor.right.coulomb_friction_n_m=0.070",
    "motor.right.stiction_n_m=0.075",
)
"""The simulated truth of ``identify friction --simulate`` without ``--set``: both sides different."""

_FRICTION_KEYS = (
    ("viscous_friction_n_m_s_rad", "f_m, viscous (N m s/rad)"),
    ("coulomb_friction_n_m", "τ_c, Coulomb (N m)"),
    ("stiction_n_m", "τ_s, stiction/break-away (N m)"),
)


def register(isub: Any) -> None:
    """Add ``friction`` to the ``identify`` subparsers."""
    f_cols = "\n".join(f"  {k:<34} {v}" for k, v in FRICTION_LOG_COLUMNS.items())
    f = isub.add_parser(
        "friction",
        help="viscous, Coulomb friction and stiction per side (eqs 65-69, corrected)",
        description="Viscous and Coulomb friction per side by least squares over constant-speed windows, stiction "
        "from a slow DA ramp (eqs 65-69 as corrected in the docs' model notes).\n\nLog columns (CSV with a "
        "header):\n" + f_cols,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    f.add_argument("--log", metavar="LOG.csv", help="fit a measured log (columns above)")
    f.add_argument(
        "--speeds",
        metavar="W1,W2,...",
        default=None,
        help="--simulate: motor speeds the PI loops hold, rad/s (default 50,100,150,200; both directions)",
    )
    f.add_argument("--save-log", metavar="PATH", help="--simulate: also write the simulated log as CSV")
    add_common_options(f, "run the experiment on the simulator (PI holding N speeds, then the ramps) and fit it")
    f.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Fit the friction (simulated or ``--log``), print it (table or ``--json``), write ``--out``."""
    check_common(args)
    if bool(args.log) == bool(args.simulate):
        raise ConfigError("identify friction", "", "give exactly one of --log LOG.csv and --simulate")
    believed, truth = vehicles(args, list(DEMO_FRICTION_TRUTH))
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
            with writing("--save-log", args.save_log):
                log.write_csv(args.save_log)
        how = [
            f"friction: simulated experiment, speeds {list(experiment.motor_speeds_rad_s)} rad/s both directions, "
            f"speed noise {args.noise:g} x {SPEED_NOISE_RAD_S:g} rad/s (seed {args.seed})"
        ]
    else:
        log = read_friction_log(args.log)
        how = [f"friction: fitted to the log {args.log}"]
    fit = fit_friction(log, believed, truth=truth)
    identified, notes = apply_friction(believed, fit)
    how += [
        f"  {command_line()}",
        "  least squares k_pow k_t u/R - k_e k_t w/R = f_m w + tau_c sign(w) (eqs 66-69, corrected); "
        "tau_s = k_pow k_t u/R at break-away (eq 65, corrected)",
    ]
    for name in SIDES:
        s = fit.side(name)
        f_m, tau_c, tau_s = (
            format_estimate(e).strip() for e in (s.viscous_friction_n_m_s_rad, s.coulomb_friction_n_m, s.stiction_n_m)
        )
        how.append(f"  {name}: f_m {f_m}, tau_c {tau_c}, tau_s {tau_s}")
    how += [f"  note: {n}" for n in (*fit.notes, *notes)]
    if args.out:
        write_vehicle(args.out, identified, how)
    if args.json:
        print(json.dumps(fit.as_dict(), indent=2))
        return 0
    lines = []
    if args.simulate and truth is not None:
        lines.append(
            "simulated truth: "
            + (
                " ".join(args.overrides)
                if args.overrides
                else " ".join(DEMO_FRICTION_TRUTH) + "  (demonstration; --set to change)"
            )
        )
    for name in SIDES:
        s = fit.side(name)
        before = believed.motor.side(name)
        lines.append(f"{name}: {len(s.windows)} constant-speed windows, {len(s.breakaway_da_voltages_v)} ramps")
        lines += table(
            [(label, getattr(before, key), getattr(s, key), getattr(s, key).truth) for key, label in _FRICTION_KEYS],
            args.simulate,
        )
    lines += [f"note: {n}" for n in (*fit.notes, *notes)]
    if args.save_log:
        lines.append(f"wrote {args.save_log}")
    if args.out:
        lines.append(f"wrote {args.out}")
    print("\n".join(lines))
    return 0
