"""``agvctl examples DIR``: copy the shipped example files (experiments and the path files they name) into a folder,
to run and change them outside a checkout."""

from __future__ import annotations

import argparse
from typing import Any

from agvctl.cli.commands import command_summary
from agvctl.examples import EXAMPLE_FOLDERS, copy_examples

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "examples",
        help=command_summary("examples"),
        description="Copy the example experiments (with their fuzz, robustness and CI files) and the path files "
        f"they name into DIR, as {' and '.join(f'DIR/{f}/' for f in EXAMPLE_FOLDERS)}; then, e.g., "
        "agvctl run DIR/experiments/figure8.toml. DIR must not exist or be empty.",
    )
    p.add_argument("dir", metavar="DIR", help="the folder to copy them into (new, or empty)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    written = copy_examples(args.dir)
    figure8 = f"{args.dir}/experiments/figure8.toml"
    print(f"wrote {len(written)} example files into {args.dir}: run one with agvctl run {figure8}")
    return 0
