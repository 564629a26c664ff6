"""``agvctl falsify``: search a fuzz file's envelope for the scenario with the smallest requirement margin.

The search's journal (``search.journal``, Optuna's journal storage) is written into the output folder as the search
goes, so a search stopped by an interrupt or a crash resumes from it with the same command. When the search ends the
folder is replaced whole (it must be empty, missing or an agvctl output) by: ``report.json``, ``search.png``, the
journal, the worst scenario's files in ``worst/`` and, when one was found, every falsifying scenario's in
``falsified/`` (each a path file and an experiment file ``agvctl check`` runs). ``--html FILE`` writes one
self-contained page of the search beside them (:func:`~agvctl.falsify.page.falsify_html`).

Exit 0 when no run falsified a limit or requirement, 1 when one did (its files written as a regression experiment),
2 on bad input (one line naming the file and key; nothing is run), 3 when a run crashed (its files written too).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from agvctl.checks.runner import resolved_jobs
from agvctl.cli.commands import command_summary
from agvctl.cli.outputs import Output, check_outputs, files_in, vehicle_input, writing
from agvctl.cli.progress import Progress
from agvctl.cli.staging import MARKER, check_replaceable, staged_outputs
from agvctl.errors import ConfigError
from agvctl.falsify import (
    SAMPLERS,
    FalsifyResult,
    check_falsify,
    falsify,
    falsify_html,
    report_dict,
    search_figure,
    summary_text,
)
from agvctl.fileio import make_folders
from agvctl.fuzz.spec import load_fuzz_config

__all__ = ["JOURNAL", "register", "run"]

JOURNAL = "search.journal"
"""The search's journal in the output folder."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "falsify",
        help=command_summary("falsify"),
        description="Search a fuzz configuration's envelope (paths, plants, starts, sensor noise) with a seeded "
        "optimiser for the scenario with the smallest requirement margin; write the worst scenario as an experiment "
        "file, its margins, a plot of the search and the parameters that drive it. Resumes from the journal in its "
        "output folder. Exit 0 when nothing is falsified, 1 when a limit or requirement is (the scenario written as "
        "a regression experiment), 2 on bad input, 3 when a run crashed.",
    )
    p.add_argument("config", metavar="FUZZ.toml")
    budget = p.add_mutually_exclusive_group()
    budget.add_argument("--budget", type=int, default=None, metavar="N", help="runs in all (default 100)")
    budget.add_argument("--budget-s", type=float, default=None, metavar="S", help="wall time, s, instead of runs")
    p.add_argument("--seed", type=int, default=None, help="the search's seed (default: the file's)")
    p.add_argument("--controller", metavar="REF", help="the pose controller (default: the file's first)")
    p.add_argument(
        "--requirement", metavar="NAME", help="search this one limit or requirement's margin (default: the smallest)"
    )
    p.add_argument("--batch", type=int, default=4, metavar="N", help="trials proposed together (default 4)")
    p.add_argument("--sampler", choices=SAMPLERS, default="tpe", help="the optimiser (default tpe)")
    p.add_argument("--keep-going", action="store_true", help="search the whole budget after a falsification")
    p.add_argument("--baseline", action="store_true", help="also run as many random scenarios, for the plot")
    p.add_argument(
        "--out", metavar="DIR", help="output folder, resumed from, then replaced whole (default: out/falsify/<name>)"
    )
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="local worker processes (default: all cores)")
    p.add_argument("--executor", choices=("local", "dask"), default="local", help="where the runs go (default local)")
    p.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    p.add_argument(
        "--html",
        metavar="FILE",
        help="write one self-contained HTML page: the verdict, the smallest margins, the search, the worst scenario",
    )
    p.add_argument("--no-plot", action="store_true", help="skip search.png")
    p.set_defaults(func=run)


def _texts(result: FalsifyResult, out_dir: Path) -> dict[Path, str]:
    texts = {out_dir / "report.json": json.dumps(report_dict(result), indent=2) + "\n"}
    if result.worst is not None:
        texts.update({out_dir / "worst" / n: t for n, t in result.files(result.worst).items()})
    for r in result.falsifying:
        texts.update({out_dir / "falsified" / n: t for n, t in result.files(r).items()})
    return texts


def _journal_folder(out_dir: Path, inputs: list[Path]) -> Path:
    """The output folder, made if missing, to hold the journal while the search goes: its marker lists no files, since
    the search adds to the journal as it goes (the end of the run lists them again)."""
    check_replaceable("--out", out_dir, inputs)
    with writing("--out", out_dir):
        if not out_dir.exists():
            make_folders(out_dir)
        (out_dir / MARKER).write_text(
            "an output folder of agvctl falsify: the next run into it resumes or replaces it\n", encoding="utf-8"
        )
    return out_dir / JOURNAL


def run(args: argparse.Namespace) -> int:
    if args.scheduler and args.executor != "dask":
        raise ConfigError("--scheduler", "", "only with --executor dask")
    spec = load_fuzz_config(args.config)
    out_dir = Path(args.out) if args.out else Path("out") / "falsify" / spec.name
    resolved_jobs(args.jobs, args.executor)
    inputs = [Path(args.config), vehicle_input(spec.vehicle)]
    names = ["report.json", JOURNAL, *([] if args.no_plot else ["search.png"])]
    outputs = files_in("--out", out_dir, names) + ([Output("--html", Path(args.html))] if args.html else [])
    check_outputs(outputs, inputs, [("--out", out_dir)])
    budget_runs = args.budget if args.budget is not None or args.budget_s is not None else 100
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    options: dict[str, Any] = {
        "budget_runs": budget_runs,
        "budget_s": args.budget_s,
        "seed": args.seed,
        "controller": args.controller,
        "requirement": args.requirement,
        "batch": args.batch,
        "sampler": args.sampler,
        "baseline": args.baseline,
        "jobs": jobs,
        "executor": args.executor,
        "scheduler": args.scheduler,
    }
    check_falsify(spec, **options, storage=None, progress=None)  # before the folder is touched
    journal = _journal_folder(out_dir, inputs)
    print(
        f"falsify {spec.name}: {'a Dask cluster' if args.executor == 'dask' else f'{jobs} local jobs'}",
        file=sys.stderr,
        flush=True,
    )
    with Progress("falsify", unit="runs" if budget_runs is not None else "s") as progress:
        result = falsify(spec, **options, stop_at_first=not args.keep_going, storage=journal, progress=progress)
    texts = _texts(result, out_dir)
    texts[out_dir / JOURNAL] = journal.read_text(encoding="utf-8")
    with staged_outputs("falsify") as staging:  # the folder replaced whole, once every file is written
        staged = staging.directory("--out", out_dir)
        for path, text in texts.items():
            staging.write_text("--out", path, text)
        if args.html:
            staging.write_text("--html", args.html, falsify_html(result, out_dir=out_dir))
        if not args.no_plot:
            with writing("--out", out_dir / "search.png"):
                (staged / "search.png").write_bytes(search_figure(result))
    print(summary_text(result))
    written = [out_dir / "report.json", *([] if args.no_plot else [out_dir / "search.png"])]
    print(f"wrote {', '.join(map(str, [*written, *([args.html] if args.html else [])]))}")
    if result.worst is not None:
        worst = next(n for n in result.files(result.worst) if not n.endswith(".path.toml"))
        print(f"worst scenario: agvctl check {out_dir / 'worst' / worst}")
    if result.falsified:
        first = next(n for n in result.files(result.falsifying[0]) if not n.endswith(".path.toml"))
        print(f"regression experiment: agvctl check {out_dir / 'falsified' / first}")
    if any(r.error is not None for r in result.runs):
        return 3
    return 1 if result.falsified else 0
