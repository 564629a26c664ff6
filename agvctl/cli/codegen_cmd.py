"""``agvctl codegen``: an experiment's PI wheel loops as a folder of dependency-free C99."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import check_outputs, files_in, writing
from agvctl.cli.staging import check_replaceable, staged_outputs
from agvctl.codegen import generate_code
from agvctl.codegen.generate import GENERATED_FILES

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "codegen",
        help=command_summary("codegen"),
        description="Write the experiment's PI wheel loops (gains, options and vehicle constants baked in) as "
        "dependency-free C99 into DIR: a header with an init/step API, the source, an example caller, a Makefile "
        "and a README naming the experiment and the agvctl version. The code is compiled once to measure its "
        "static memory. The pose controller is not generated yet.",
    )
    p.add_argument("experiment", metavar="EXPERIMENT.toml")
    add_vehicle_options(p, "the experiment's vehicle")
    p.add_argument("--out", metavar="DIR", required=True, help="output directory (new, empty, or an agvctl output)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    code = generate_code(args.experiment, vehicle=args.vehicle, vehicle_overrides=args.overrides)
    inputs = code.experiment.input_files
    check_outputs(files_in("--out", out_dir, GENERATED_FILES), inputs, [("--out", out_dir)])
    check_replaceable("--out", out_dir, inputs)
    with staged_outputs("codegen") as staging:  # the folder is replaced whole, once every file is written
        staged = staging.directory("--out", out_dir)
        with writing("--out", out_dir):
            for name, text in code.files.items():
                (staged / name).write_text(text, encoding="utf-8")
    print(f"generated the PI wheel loops of {code.experiment.spec.name} as C99 in {out_dir}:")
    print(f"  {', '.join(code.files)}")
    if code.memory is None:
        print("  static memory: not measured (no C compiler)")
    else:
        m = code.memory
        print(
            f"  static memory: state {m.state_bytes} bytes (caller-owned struct), constants {m.constant_bytes} bytes; "
            "no heap"
        )
    print(f"  build the example: make -C {out_dir}")
    return 0
