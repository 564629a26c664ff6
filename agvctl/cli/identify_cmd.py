"""``agvctl identify {mass,friction,umbmark}``: the report's appendix A.1 procedures on measurements or on the
simulator, the result written back as a vehicle TOML (``--out``).

With ``--simulate`` the vehicle (``--vehicle``) is what the controllers believe and ``--set`` changes only the
simulated truth (the plant); without ``--set``, friction and UMBmark simulate a demonstration truth that differs
from the vehicle (printed). With ``--log`` or scale readings, ``--set`` changes the vehicle as everywhere else.

One module per procedure (:mod:`~agvctl.cli.identify_mass_cmd`, :mod:`~agvctl.cli.identify_friction_cmd`,
:mod:`~agvctl.cli.identify_umbmark_cmd`), their shared options and table in :mod:`~agvctl.cli.identify_common`.
"""

from __future__ import annotations

import argparse
from typing import Any

import agvctl.cli.identify_friction_cmd as identify_friction_cmd
import agvctl.cli.identify_mass_cmd as identify_mass_cmd
import agvctl.cli.identify_umbmark_cmd as identify_umbmark_cmd
from agvctl.cli.commands import command_summary

__all__ = ["register"]

_DESCRIPTION = """\
The report's appendix A.1 procedures on measurements or on the simulator; --out writes the result as a vehicle TOML.

With --simulate the vehicle (--vehicle) is what the controllers believe and --set changes only the simulated
truth (the plant); without --set, friction and umbmark simulate a demonstration truth that differs from the
vehicle (printed). With --log or scale readings, --set changes the vehicle as everywhere else."""


def register(sub: Any) -> None:
    """Add ``identify`` and its procedures to the top-level subparsers."""
    p = sub.add_parser(
        "identify",
        help=command_summary("identify"),
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    isub = p.add_subparsers(dest="procedure", metavar="PROCEDURE", parser_class=type(p))
    isub.required = True
    for module in (identify_mass_cmd, identify_friction_cmd, identify_umbmark_cmd):
        module.register(isub)
