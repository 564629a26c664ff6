"""``agvctl check``: run experiments (nominal and Monte Carlo), enforce their limits, report.

Everything is loaded and validated first — every experiment file, every Monte Carlo sample's vehicle — so bad
input stops the check before anything runs. The runs then go to one ``concurrent.futures`` executor — a worker
thread, local worker processes or a Dask cluster's — and each returns only its metrics and limit verdicts (the
report types are in :mod:`agvctl.checks.report`). A run that raises — in the product's code or in a user's
controller — is recorded as that run's error (one line) and every other run still goes; so is a run its worker
could not return (a worker process that died). Samples are drawn in the parent from the experiment's seed, so the
same seed gives the same samples and the same physical results on any executor (the computation-time metrics,
``solve_time_p99_ms`` and ``deadline_misses``, are measured and so vary from run to run).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.checks.executors import (
    MAX_JOBS,
    ExecutorKind,
    InlineExecutor,
    execute,
    open_executor,
    resolved_jobs,
)
from agvctl.checks.report import CheckReport, ExperimentReport, Overrides, RunOutcome, RunTask, worst_run_verdicts
from agvctl.config import check_key, document_fields, to_dict
from agvctl.errors import ConfigError, caused_by_interrupt, exception_line
from agvctl.evaluation.limits import LimitResult, judge_run
from agvctl.params import SIDES, VehicleParams
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = [  # the executors are agvctl.checks.executors's, and still importable from here
    "MAX_JOBS",
    "CheckWork",
    "ExecutorKind",
    "InlineExecutor",
    "RunRender",
    "check_experiments",
    "execute",
    "load_check",
    "monte_carlo_samples",
    "open_executor",
    "resolved_jobs",
    "run_task",
]

RunRender = Callable[[Experiment, ClosedLoopResult, Sequence[LimitResult]], dict[str, bytes]]
"""Draws a run's figures where the run is (its log never travels): the experiment as run (a Monte Carlo sample's
plant), its result and its limit verdicts in, PNG bytes by name out. A module-level function (it is pickled)."""


# -- Monte Carlo samples ----------------------------------------------------------------------------------------


def _nominal_values(prepared: Experiment, key: str) -> list[tuple[str, float]]:
    """The plant's nominal value(s) of a dotted key; ``motor.X`` or ``wheels.X`` with different sides gives both
    sides, and one side's key (``wheels.left.radius_m``) that side's value also when the sides share it."""
    data = to_dict(prepared.plant_vehicle)
    node: Any = data
    for part in key.split("."):
        if not isinstance(node, dict) or part not in node:
            node = None
            break
        node = node[part]
    if isinstance(node, (int, float)) and not isinstance(node, bool):
        return [(key, float(node))]
    parts = key.split(".")
    plant = prepared.plant_vehicle
    pairs = (("motor", plant.motor), ("wheels", plant.wheels))
    by_side: dict[tuple[str, str], object] = {(table, s): pair.side(s) for table, pair in pairs for s in SIDES}
    if len(parts) == 3 and (parts[0], parts[1]) in by_side:
        value = getattr(by_side[parts[0], parts[1]], parts[2], None)
        if isinstance(value, float):
            return [(key, value)]
    if len(parts) == 2 and parts[0] in ("motor", "wheels"):
        sides = [(f"{parts[0]}.{s}.{parts[1]}", getattr(by_side[parts[0], s], parts[1], None)) for s in SIDES]
        if all(isinstance(v, float) for _k, v in sides):
            return [(k, float(v)) for k, v in sides]  # type: ignore[arg-type]
    where = f"robustness.spread.{key}"
    try:
        check_key(VehicleParams, key, prepared.spec.source)
    except ConfigError as exc:
        raise ConfigError(prepared.spec.source, where, exc.problem) from None
    raise ConfigError(prepared.spec.source, where, "not a numeric vehicle key")


def monte_carlo_samples(prepared: Experiment) -> list[Overrides]:
    """The plant overrides of every Monte Carlo sample, drawn from the experiment's seed and validated.

    Keys are drawn in sorted order, one number per key and sample, so adding a sample keeps the others.

    Parameters
    ----------
    prepared : Experiment
        The loaded experiment: its ``[robustness]`` table and its plant's nominal values.

    Returns
    -------
    list of Overrides
        Per sample, ``(dotted vehicle key, value)`` pairs; empty without ``[robustness]``.

    Raises
    ------
    ConfigError
        A key that names no numeric vehicle value, or a sample that gives an invalid vehicle (say Coulomb friction
        above stiction), named with its index.
    """
    exp = prepared.spec
    rob = exp.robustness
    if rob is None:
        return []
    rng = np.random.default_rng(rob.seed)
    keys = sorted(rob.spread)
    nominal = {k: _nominal_values(prepared, k) for k in keys}
    draws = np.empty((rob.samples, len(keys)))
    for j, key in enumerate(keys):
        spread = rob.spread[key]
        if spread.kind == "uniform":
            draws[:, j] = rng.uniform(-spread.relative, spread.relative, size=rob.samples)
        else:
            draws[:, j] = rng.normal(0.0, spread.relative, size=rob.samples)
    samples: list[Overrides] = []
    int_keys = {"da.bits"}
    for i in range(rob.samples):
        pairs: list[tuple[str, float]] = []
        for j, key in enumerate(keys):
            for target, value in nominal[key]:
                v = value * (1.0 + draws[i, j])
                pairs.append((target, float(round(v)) if target in int_keys else v))
        try:
            prepared.plant_vehicle.with_overrides(pairs, source="sample")
        except ConfigError as exc:
            raise ConfigError(
                exp.source, f"robustness (sample {i})", f"gives an invalid vehicle: {exc.key}: {exc.problem}"
            ) from None
        samples.append(tuple(pairs))
    return samples


# -- running ----------------------------------------------------------------------------------------------------


_PREPARED_KEEP = 16
"""Experiments a worker keeps loaded between runs (each with the fingerprint of the files it was loaded from)."""
_prepared_by_path: dict[str, tuple[tuple[tuple[str, str], ...], Experiment]] = {}


def _fingerprint(files: Sequence[Path]) -> tuple[tuple[str, str], ...]:
    """Each file with the SHA-256 of its content (``"-"`` for one that is gone or not a regular file)."""
    out = []
    for f in files:
        try:
            digest = hashlib.sha256(f.read_bytes()).hexdigest() if f.is_file() else "-"
        except OSError:
            digest = "-"
        out.append((str(f), digest))
    return tuple(out)


def _prepared(path: str) -> Experiment:
    """The experiment at ``path``, loaded again whenever the content of a file it reads (the experiment, its
    path, vehicles and settings files) differs from when it was loaded: a file edited between two checks in one
    process is checked as it is now."""
    kept = _prepared_by_path.get(path)
    if kept is not None and _fingerprint([Path(f) for f, _ in kept[0]]) == kept[0]:
        return kept[1]
    exp = load_experiment(path)
    _prepared_by_path.pop(path, None)
    while len(_prepared_by_path) >= _PREPARED_KEEP:
        del _prepared_by_path[next(iter(_prepared_by_path))]
    _prepared_by_path[path] = (_fingerprint(list(exp.input_files)), exp)
    return exp


def run_task(task: RunTask, render: RunRender | None = None) -> RunOutcome:
    """Run one task in this process. Used by every executor; module-level so it pickles.

    Parameters
    ----------
    task : RunTask
        The run.
    render : RunRender or None
        Draws the run's figures into the outcome (None: none).

    Returns
    -------
    RunOutcome
        Its metrics and verdicts; for a run that raised, the exception as its ``error`` (this never raises for a
        run that fails).
    """
    t0 = time.perf_counter()
    try:
        return _run(task, t0, render)
    except Exception as exc:  # a run that raised is that run's result, reported with its experiment
        if caused_by_interrupt(exc):  # an interrupt that surfaced as another error stops the command
            raise
        return run_error(task, exc, time.perf_counter() - t0)


def _run_drawn(task: RunTask, render: RunRender) -> RunOutcome:
    """:func:`run_task`, drawing the figures of a nominal run only."""
    return run_task(task, render if task.sample is None else None)


def run_error(task: RunTask, exc: BaseException, wall_time_s: float = 0.0) -> RunOutcome:
    """The outcome of a run that could not be completed because of ``exc``."""
    return RunOutcome(task, {}, (), wall_time_s, error=exception_line(exc))


def _run(task: RunTask, t0: float, render: RunRender | None) -> RunOutcome:
    """The task's run and its verdicts (its plant and sensor noise those of its Monte Carlo sample, if any)."""
    base = _prepared(task.experiment_path)
    prepared = base
    if task.overrides:
        plant = base.plant_vehicle.with_overrides(list(task.overrides), source=f"sample {task.sample}")
        prepared = dataclasses.replace(base, plant_vehicle=plant)
    if task.sample is not None:  # each sample its own sensor noise: [plant] sensor_seed + 1 + the sample's index
        spec = prepared.spec
        plant_spec = dataclasses.replace(spec.plant, sensor_seed=spec.plant.sensor_seed + 1 + task.sample)
        prepared = dataclasses.replace(prepared, spec=dataclasses.replace(spec, plant=plant_spec))
    result = run_experiment(prepared)
    verdict = judge_run(result, prepared.spec.limits, prepared.controller_vehicle, prepared.spec.requirements)
    figures = render(prepared, result, verdict.limits) if render is not None else {}
    return RunOutcome(task, verdict.metrics, verdict.limits, time.perf_counter() - t0, figures=figures)


@document_fields
@dataclass(frozen=True)
class CheckWork:
    """The experiments of a check, loaded and validated, and their runs (one per Monte Carlo sample, or the
    nominal one): what :func:`check_experiments` runs."""

    paths: tuple[str, ...]
    """The experiment files as given."""
    experiments: tuple[Experiment, ...]
    """Each experiment, loaded."""
    tasks: tuple[tuple[RunTask, ...], ...]
    """Each experiment's runs."""

    @property
    def input_files(self) -> list[Path]:
        """Every file the check reads: each experiment file and the files it names."""
        return [f for exp in self.experiments for f in exp.input_files]


def load_check(paths: Sequence[str | Path]) -> CheckWork:
    """Load and validate every experiment and draw its Monte Carlo samples, before anything runs.

    Parameters
    ----------
    paths : sequence of str or Path
        The experiment files, at least one.

    Returns
    -------
    CheckWork
        The experiments and their runs, for :func:`check_experiments`.

    Raises
    ------
    ConfigError
        No experiment at all, a file or key that cannot be used, or a sample that gives an invalid vehicle.
    """
    if isinstance(paths, (str, bytes)) or not isinstance(paths, Sequence):
        raise ConfigError("check_experiments", "paths", f"expected a sequence of experiment files (got {paths!r})")
    if not paths:
        raise ConfigError("check_experiments", "paths", "give at least one experiment file (got none)")
    for i, path in enumerate(paths):
        if not isinstance(path, (str, os.PathLike)):
            raise ConfigError("check_experiments", f"paths[{i}]", f"expected a file name (got {path!r})")
    experiments: list[Experiment] = []
    tasks_of: list[tuple[RunTask, ...]] = []
    for path in paths:
        exp = load_experiment(path)
        key = str(Path(path).resolve())
        samples = monte_carlo_samples(exp)
        tasks = [RunTask(key, i, s) for i, s in enumerate(samples)] if samples else [RunTask(key, None, ())]
        experiments.append(exp)
        tasks_of.append(tuple(tasks))
    return CheckWork(tuple(str(p) for p in paths), tuple(experiments), tuple(tasks_of))


def check_experiments(
    paths: Sequence[str | Path] | CheckWork,
    *,
    jobs: int | None = None,
    executor: ExecutorKind = "local",
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    render: RunRender | None = None,
    t0: float | None = None,
) -> CheckReport:
    """Run every experiment (its Monte Carlo samples too) and check its limits.

    Parameters
    ----------
    paths : sequence of str or Path, or CheckWork
        Experiment files, or the :class:`CheckWork` of :func:`load_check` (loaded already).
    jobs : int or None
        Local worker processes (default: all cores); with one job, or one run in all, the runs go one after another
        in this process. With ``executor="dask"`` and no scheduler: the local cluster's workers.
    executor : {'local', 'dask'}
        ``"local"``, or ``"dask"`` to send the runs to the Dask scheduler at ``scheduler``.
    scheduler : str or None
        The Dask scheduler's address (``tcp://host:8786``); ``None`` with ``executor="dask"``: a local cluster.
    progress : callable or None
        Called as ``progress(done, total)`` in this thread after each run.
    render : RunRender or None
        Draws each nominal run's figures where it runs (:data:`RunRender`), into :attr:`RunOutcome.figures`; the
        Monte Carlo samples are not drawn.
    t0 : float or None
        A :func:`time.perf_counter` reading, s: the report's wall time starts there (None: now), so that a caller
        that loaded the :class:`CheckWork` first counts its loading too.

    Returns
    -------
    CheckReport
        Every experiment's verdicts and runs. A run that raised (say a user's pose controller) is recorded with its
        error, one line (:attr:`RunOutcome.error`); its experiment then fails (``completed`` False) and every other
        run is still run and reported.

    Raises
    ------
    ConfigError
        On bad input, before any run: no experiment at all, a file or key that cannot be used, an invalid Monte
        Carlo sample, an option out of its range (as for :func:`~agvctl.fuzz.run.fuzz`), or a ``render`` that is
        not a function.

    Notes
    -----
    Local workers are spawned processes, which import the calling script again: from a script, call this under
    ``if __name__ == "__main__":``.
    """
    t0 = time.perf_counter() if t0 is None else t0
    jobs = resolved_jobs(jobs, executor, scheduler, progress)
    if render is not None and not callable(render):
        raise ConfigError("render", "", f"expected a function render(experiment, result, limits) (got {render!r})")
    work = paths if isinstance(paths, CheckWork) else load_check(paths)
    all_tasks = [t for ts in work.tasks for t in ts]
    with open_executor(executor, jobs, scheduler, len(all_tasks), prepare=run_task.__module__) as pool:
        run = run_task if render is None else functools.partial(_run_drawn, render=render)
        outcomes = execute(pool, run, all_tasks, progress, on_error=run_error)
    report = CheckReport()
    pos = 0
    for exp, path, tasks in zip(work.experiments, work.paths, work.tasks, strict=True):
        mine = outcomes[pos : pos + len(tasks)]
        pos += len(tasks)
        wall_time_s = sum(o.wall_time_s for o in mine)
        verdicts = worst_run_verdicts(mine)
        report.experiments.append(ExperimentReport(exp.spec.name, path, verdicts, mine, wall_time_s, exp))
    report.wall_time_s = time.perf_counter() - t0
    return report
