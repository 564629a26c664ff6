"""``agvctl tune --pose FUZZ.toml``: search a pose controller's settings over a fuzz distribution
(:func:`agvctl.tuning.tune_pose`), validate them on held-out scenarios, write a settings file."""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path

from agvctl.checks.runner import resolved_jobs
from agvctl.cli.outputs import Output, check_outputs, files_in, vehicle_input, writing
from agvctl.cli.progress import Progress
from agvctl.config.references import plain_label
from agvctl.errors import ConfigError
from agvctl.fileio import atomic_open, write_text
from agvctl.fuzz.spec import load_fuzz_config, override_fuzz_config

__all__ = ["add_pose_options", "check_mode", "run_pose"]

STUDY_FILES = ("study.db", "report.json", "history.png", "importance.png")
"""What the study folder holds: the resumable study, the report, the optimisation history, the importances."""


def add_pose_options(p: argparse.ArgumentParser) -> None:
    """The options of ``tune --pose`` (the PI design's options do not apply with it)."""
    g = p.add_argument_group("pose controller (--pose FUZZ.toml)")
    g.add_argument("--pose", metavar="FUZZ.toml", help="search a pose controller's settings over this distribution")
    g.add_argument("--controller", metavar="NAME", help="the pose controller to tune (default: the file's first)")
    g.add_argument("--trials", type=int, default=60, metavar="N", help="trials in all, resumed ones included (60)")
    g.add_argument("--seed", type=int, default=None, help="training seed, instead of the file's")
    g.add_argument("--scenarios", type=int, default=None, metavar="N", help="training scenarios, instead of the file's")
    g.add_argument("--validation-seed", type=int, default=None, metavar="S", help="default: the training seed + 1")
    g.add_argument("--validation-scenarios", type=int, default=200, metavar="N", help="held-out scenarios (200)")
    g.add_argument("--jobs", type=int, default=None, metavar="N", help="local worker processes (default: all cores)")
    g.add_argument("--executor", choices=("local", "dask"), default="local", help="where the runs go (default local)")
    g.add_argument("--scheduler", metavar="ADDR", help="Dask scheduler address, e.g. tcp://10.0.0.5:8786")
    g.add_argument(
        "--study",
        metavar="DIR",
        help="the study folder: study.db (resumed if there), report.json, history.png, importance.png "
        "(default: out/tune/<name>_<controller>)",
    )


def run_pose(args: argparse.Namespace) -> int:
    """Run ``agvctl tune --pose``: 0 when done (whether or not the tuned settings beat the defaults), 2 on bad
    input (nothing written)."""
    from agvctl.tuning import result_dict, settings_text, summary_text, tune_pose, tuning_figures

    if args.scheduler and args.executor != "dask":
        raise ConfigError("--scheduler", "", "only with --executor dask")
    spec = override_fuzz_config(load_fuzz_config(args.pose), seed=args.seed, scenarios=args.scenarios)
    controller = args.controller or spec.controllers[0]
    study_dir = Path(args.study) if args.study else Path("out") / "tune" / f"{spec.name}_{plain_label(controller)}"
    out = Path(args.out) if args.out else study_dir / "settings.toml"
    resolved_jobs(args.jobs, args.executor, args.scheduler)
    outputs = [Output("--out", out), *files_in("--study", study_dir, STUDY_FILES)]
    check_outputs(outputs, [Path(args.pose), vehicle_input(spec.vehicle)], [("--study", study_dir)])
    with Progress("tune", unit="runs") as progress:
        result = tune_pose(
            spec,
            controller=controller,
            trials=args.trials,
            validation_seed=args.validation_seed,
            validation_scenarios=args.validation_scenarios,
            jobs=args.jobs,
            executor=args.executor,
            scheduler=args.scheduler,
            storage=study_dir / "study.db",
            progress=progress,
        )
    command = "agvctl " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else ""
    texts: dict[Path, tuple[str, str]] = {
        out: ("--out", settings_text(result, command)),
        study_dir / "report.json": ("--study", json.dumps(result_dict(result), indent=2) + "\n"),
    }
    figures = tuning_figures(result)
    for path, (flag, text) in texts.items():
        with writing(flag, path):
            write_text(path, text)
    for name, content in figures.items():
        with writing("--study", study_dir / name), atomic_open(study_dir / name, "wb") as fh:
            fh.write(content)
    print(summary_text(result))
    print(f"wrote {out}, {', '.join(str(study_dir / n) for n in ['report.json', *figures])}")
    print(settings_hint(out, Path(args.pose), controller))
    return 0


def settings_hint(settings: Path, fuzz_file: Path, controller: str) -> str:
    """How to use the settings file written: a path relative to the fuzz file in its ``[pose_settings]`` table
    (paths in a file are read from its folder, not from the working directory), and the absolute path for an
    experiment file, wherever that is."""
    where = settings.resolve()
    try:
        from_fuzz_file = Path(os.path.relpath(where, fuzz_file.resolve().parent)).as_posix()
    except ValueError:  # on another drive than the fuzz file (Windows)
        from_fuzz_file = where.as_posix()
    return (
        f'use it: [pose_settings] {controller} = "{from_fuzz_file}" in {fuzz_file} (relative to that file), or '
        f'[controller] pose_settings = "{where.as_posix()}" in an experiment'
    )


def check_mode(args: argparse.Namespace) -> None:
    """Refuse options of the other mode: the search's options without ``--pose``, the PI design's with it."""
    pose_only = ("controller", "seed", "scenarios", "validation_seed", "study", "jobs", "scheduler")
    pi_only = ("json", "plot", "bandwidth", "coulomb_feedforward", "vehicle", "overrides")
    if args.pose is None:
        given = [k for k in pose_only if getattr(args, k) is not None]
        if given:
            raise ConfigError(f"--{given[0].replace('_', '-')}", "", "only with --pose FUZZ.toml")
    else:
        given = [k for k in pi_only if getattr(args, k) not in (None, False, [], "")]
        if given:
            flag = "--set" if given[0] == "overrides" else f"--{given[0].replace('_', '-')}"
            raise ConfigError(flag, "", "belongs to the PI design; not with --pose (the fuzz file names the vehicle)")
