"""``agvctl codegen``: an experiment's PI wheel loops, its MPC's QP solver, or the whole cascade of a unicycle law, as a
folder of dependency-free C99."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import check_outputs, files_in, writing
from agvctl.cli.staging import check_replaceable, staged_outputs
from agvctl.codegen import generate_code
from agvctl.codegen.qp import QP_FOLDER

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    p = sub.add_parser(
        "codegen",
        help=command_summary("codegen"),
        description="Write the experiment's PI wheel loops (gains, options and vehicle constants baked in) as "
        "dependency-free C99 into DIR: a header with an init/step API, the source, an example caller, a Makefile "
        "and a README naming the experiment and the agvctl version; for the Ramsete law and the LTV unicycle LQR, "
        "the whole cascade (the law, the reference as data and agv_cascade_step: pose and motor speeds in, DA "
        "voltages out); for the LTV MPC, the QP it solves each step as OSQP's generated solver in DIR/mpc_qp with the "
        "QP's step (the error, the QP's data, the solve) and the experiment's reference as its tables (the MPC's "
        "governor, setpoint window, rules, docking and rest are not generated yet). The code is compiled once to "
        "measure its static memory.",
    )
    p.add_argument("experiment", metavar="EXPERIMENT.toml")
    add_vehicle_options(p, "the experiment's vehicle")
    p.add_argument("--out", metavar="DIR", required=True, help="output directory (new, empty, or an agvctl output)")
    p.add_argument(
        "--float",
        action="store_true",
        help="generate the MPC's QP solver in single precision (for a processor without a double-precision unit; "
        "qp_solver = 'osqp_c_float' runs it in the closed loop)",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    out_dir = Path(args.out)
    code = generate_code(args.experiment, vehicle=args.vehicle, vehicle_overrides=args.overrides, single=args.float)
    inputs = code.experiment.input_files
    check_outputs(files_in("--out", out_dir, code.files), inputs, [("--out", out_dir)])
    check_replaceable("--out", out_dir, inputs)
    with staged_outputs("codegen") as staging:  # the folder is replaced whole, once every file is written
        staged = staging.directory("--out", out_dir)
        with writing("--out", out_dir):
            for name, text in code.files.items():
                (staged / name).parent.mkdir(parents=True, exist_ok=True)
                (staged / name).write_text(text, encoding="utf-8")
    what = "controller cascade" if code.cascade.generated else "PI wheel loops"
    print(f"generated the {what} of {code.experiment.spec.name} as C99 in {out_dir}:")
    print(f"  {', '.join(name for name in code.files if '/' not in name)}")
    if code.memory is None:
        print("  static memory: not measured (no C compiler)")
    else:
        m = code.memory
        print(
            f"  static memory: state {m.state_bytes} bytes (caller-owned struct), constants {m.constant_bytes} bytes; "
            "no heap"
        )
    qp = code.qp
    if code.cascade.generated:
        print(f"  agv_cascade_step: pose, motor speeds in, DA voltages out; {code.cascade.note}")
    elif qp.code is None:
        print(f"  the pose controller's step and the MPC's QP solver: not generated ({qp.note})")
    if qp.code is not None:
        memory = "not measured" if qp.static_bytes is None else f"{qp.static_bytes} bytes"
        if qp.table_bytes is not None:
            memory += f" ({qp.table_bytes} of them the reference's tables)"
        print(f"  the MPC's QP solver in {out_dir / QP_FOLDER}: {qp.note}; static memory {memory}; no heap")
        print(f"  the QP's step agv_mpc_step.h over it, the reference as {qp.n_tables} tables (agv_mpc_step_tables.h)")
    print(f"  build the example: make -C {out_dir}")
    return 0
