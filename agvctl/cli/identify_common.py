"""What the ``agvctl identify`` procedures share: their common options, the believed and simulated vehicles,
the before/after table, and writing the identified vehicle."""

from __future__ import annotations

import argparse
import math
import shlex
import sys
from datetime import UTC, datetime
from pathlib import Path

from agvctl.calibration import Estimate
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import Output, check_outputs, vehicle_input, writing
from agvctl.config import dump_toml, to_dict
from agvctl.errors import ConfigError
from agvctl.fileio import write_text
from agvctl.params import VehicleParams, load_vehicle

__all__ = [
    "add_common_options",
    "check_common",
    "command_line",
    "format_estimate",
    "table",
    "vehicles",
    "write_vehicle",
]


def add_common_options(p: argparse.ArgumentParser, simulate_help: str) -> None:
    """``--vehicle``/``--set``, ``--simulate``, ``--noise``, ``--seed``, ``--out`` and ``--json``."""
    add_vehicle_options(p)
    p.add_argument("--simulate", action="store_true", help=simulate_help + "; --set changes the truth only")
    p.add_argument(
        "--noise",
        type=float,
        default=0.0,
        metavar="SCALE",
        help="--simulate: measurement noise, 0 = none, 1 = realistic (default 0)",
    )
    p.add_argument("--seed", type=int, default=None, metavar="N", help="--simulate: random seed for the noise")
    p.add_argument("--out", metavar="VEHICLE.toml", help="write the vehicle with the identified values")
    p.add_argument("--json", action="store_true", help="print the result as JSON")


def command_line() -> str:
    """The command as typed, for the header of the written vehicle."""
    return "agvctl " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else "agvctl identify"


def check_common(args: argparse.Namespace) -> None:
    """The common options, before anything runs: ``--noise`` a finite number >= 0, ``--seed`` an integer >= 0
    (numpy's seeds), and the output files (``--out``, ``--save-log``) never an input (``--vehicle``, ``--log``)
    and writable. A one-line :class:`ConfigError` naming the flag otherwise."""
    if not (math.isfinite(args.noise) and args.noise >= 0):
        raise ConfigError("--noise", "", f"must be >= 0 (got {args.noise:g})")
    if args.seed is not None and args.seed < 0:
        raise ConfigError("--seed", "", f"must be >= 0 (got {args.seed})")
    flags = (("--out", args.out), ("--save-log", getattr(args, "save_log", None)))
    outputs = [Output(flag, Path(name)) for flag, name in flags if name]
    log = getattr(args, "log", None)
    check_outputs(outputs, [vehicle_input(args.vehicle), *([log] if log else [])])


def vehicles(args: argparse.Namespace, demo: list[str] | None = None) -> tuple[VehicleParams, VehicleParams | None]:
    """(believed vehicle, simulated truth or None). With ``--simulate``, ``--set`` (else ``demo``) changes only
    the truth."""
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


def format_estimate(e: Estimate) -> str:
    """``estimate ± stderr`` in fixed columns (``?`` for an unknown standard error)."""
    se = f"{e.stderr:.2g}" if math.isfinite(e.stderr) else "?"
    return f"{e.estimate:>13.6g} ± {se:<8}"


def write_vehicle(path: str, vehicle: VehicleParams, how: list[str]) -> None:
    """Write ``vehicle`` as TOML with a header comment saying how it was identified; it must read back."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    header = "\n".join([f"Vehicle '{vehicle.name}' with values identified by agvctl ({stamp}):", *how])
    with writing("--out", path):
        write_text(path, dump_toml(to_dict(vehicle), header=header) + "\n")
    load_vehicle(path)  # it must read back


def table(rows: list[tuple[str, float | None, Estimate, float | None]], simulate: bool) -> list[str]:
    """The before/after table: one row per (label, before, estimate, truth); the truth column only when
    simulating."""
    head = f"  {'':<48} {'before':>14} {'after (estimate ± stderr)':>25}"
    lines = [head + (f" {'truth':>14}" if simulate else "")]
    for label, before, est, truth in rows:
        line = f"  {label:<48} {_fmt(before)} {format_estimate(est)}"
        if simulate:
            line += f" {_fmt(truth)}"
        lines.append(line)
    return lines
