"""The command line's table of subcommands: ``agvctl --help`` lists them all without importing any of them (nor the
numerical libraries), and each subcommand, once chosen, is the parser its module registers under that name."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from agvctl.cli import build_parser, main
from agvctl.cli.commands import COMMANDS

ROOT = Path(__file__).resolve().parent.parent

LIST_COMMANDS = """
import sys
from agvctl.cli import main
code = main(["--help"])
loaded = [m for m in sys.modules if m.endswith("_cmd") or m.split(".")[0] in ("numpy", "scipy", "casadi", "matplotlib")]
print("LOADED", code, *loaded)
"""


def test_the_list_of_commands_imports_no_command_and_no_numerical_library():
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    res = subprocess.run([sys.executable, "-c", LIST_COMMANDS], capture_output=True, text=True, env=env, check=True)
    for name, entry in COMMANDS.items():
        assert name in res.stdout and entry.summary.split()[0] in res.stdout
    assert res.stdout.splitlines()[-1] == "LOADED 0", res.stdout.splitlines()[-1]


def _subcommands(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:  # type: ignore[type-arg]
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))


@pytest.mark.parametrize("name", COMMANDS)
def test_a_chosen_command_is_its_module_parser_listed_with_the_table_summary(name, capsys):
    sub = _subcommands(build_parser(name))
    assert list(sub.choices) == list(COMMANDS)
    assert {a.dest: a.help for a in sub._choices_actions} == {n: c.summary for n, c in COMMANDS.items()}
    unchosen = build_parser(None)
    assert len(sub.choices[name]._actions) > len(_subcommands(unchosen).choices[name]._actions)  # its own arguments
    assert main([name, "--help"]) == 0
    assert capsys.readouterr().out.startswith(f"usage: agvctl {name} ")
