"""Options shared by the subcommands (a module of its own, so the subcommands never import the CLI's entry)."""

from __future__ import annotations

import argparse

__all__ = ["add_vehicle_options"]


def add_vehicle_options(parser: argparse.ArgumentParser, default: str = "the report's IAU AGV") -> None:
    """``--vehicle FILE`` and repeatable ``--set KEY=VALUE``, shared by every command that takes a vehicle.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser.
    default : str
        The vehicle without ``--vehicle``, as the help names it.
    """
    parser.add_argument("--vehicle", metavar="FILE", default=None, help=f"vehicle TOML (default: {default})")
    parser.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override one vehicle value by its dotted key, e.g. wheels.right.radius_m=0.101 (repeatable)",
    )
