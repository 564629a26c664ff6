"""The table of the ``agvctl`` subcommands: each name, the module that implements it and its one-line summary.

The table is all ``agvctl --help`` needs, so the command line imports only the chosen command's module (and the
numerical libraries it uses), never every command's. Each module's ``register(subparsers)`` reads its summary here.
"""

from __future__ import annotations

from typing import NamedTuple

__all__ = ["COMMANDS", "Command", "command_summary"]


class Command(NamedTuple):
    """One subcommand: the module with its ``register(subparsers)`` and ``run(args)``, and its summary line."""

    module: str
    summary: str


COMMANDS: dict[str, Command] = {
    "run": Command("agvctl.cli.run_cmd", "run a closed-loop experiment (reference → MPC → PI → DA/amplifier → plant)"),
    "check": Command(
        "agvctl.cli.check_cmd", "run experiments and enforce their [limits] (CI gate: exit 1 on a violation)"
    ),
    "fuzz": Command(
        "agvctl.cli.fuzz_cmd", "random scenarios (paths, plants, starts) through the closed loop, against limits"
    ),
    "falsify": Command(
        "agvctl.cli.falsify_cmd", "search a fuzz envelope for the scenario closest to failing its requirements"
    ),
    "params": Command("agvctl.cli.params_cmd", "show the vehicle's parameters and derived constants"),
    "simulate": Command("agvctl.cli.simulate_cmd", "open-loop response to constant DA volts or a DA profile"),
    "plan": Command("agvctl.cli.plan_cmd", "plan a reference from a path file (trajectories/*.toml)"),
    "tune": Command(
        "agvctl.cli.tune_cmd",
        "design the PI wheel-speed loops (or, with --pose, search a pose controller's settings)",
    ),
    "codegen": Command(
        "agvctl.cli.codegen_cmd",
        "write an experiment's controllers as dependency-free C99: the PI loops, the MPC's QP solver, a law's cascade",
    ),
    "identify": Command(
        "agvctl.cli.identify_cmd", "identify vehicle constants: mass, friction, wheel geometry (appendix A.1)"
    ),
    "examples": Command("agvctl.cli.examples_cmd", "copy the shipped example experiments and path files into a folder"),
}
"""Every subcommand by name, in the order ``agvctl --help`` lists them."""


def command_summary(name: str) -> str:
    """The one-line summary of the subcommand ``name`` (its ``help`` in ``agvctl --help``).

    Parameters
    ----------
    name : str
        A key of :data:`COMMANDS`.

    Returns
    -------
    str
        Its summary line.
    """
    return COMMANDS[name].summary
