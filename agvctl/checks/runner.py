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

import contextlib
import dataclasses
import functools
import multiprocessing
import numbers
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar

import numpy as np

from agvctl.checks.report import CheckReport, ExperimentReport, Overrides, RunOutcome, RunTask, worst_run_verdicts
from agvctl.config import check_key, to_dict
from agvctl.errors import ConfigError, exception_line
from agvctl.evaluation.limits import LimitResult, evaluate_limits
from agvctl.evaluation.metrics import closed_loop_metrics
from agvctl.params import SIDES, VehicleParams
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment
from agvctl.sim.loop import ClosedLoopResult

__all__ = [
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

ExecutorKind = Literal["local", "dask"]
RunRender = Callable[[Experiment, ClosedLoopResult, Sequence[LimitResult]], dict[str, bytes]]
"""Draws a run's figures where the run is (its log never travels): the experiment as run (a Monte Carlo sample's
plant), its result and its limit verdicts in, PNG bytes by name out. A module-level function (it is pickled)."""
T = TypeVar("T")
R = TypeVar("R")


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

    A sample that gives an invalid vehicle (say Coulomb friction above stiction) is bad input, named with its
    index. Keys are drawn in sorted order, one number per key and sample, so adding a sample keeps the others.
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


@functools.lru_cache(maxsize=16)
def _prepared(path: str) -> Experiment:
    return load_experiment(path)


def run_task(task: RunTask, render: RunRender | None = None) -> RunOutcome:
    """Run one task (in this process), and with ``render`` draw its figures into the outcome. Used by every
    executor; module-level so it pickles. Never raises for a run that fails: an exception is the outcome's
    ``error``."""
    t0 = time.perf_counter()
    try:
        return _run(task, t0, render)
    except Exception as exc:  # a run that raised is that run's result, reported with its experiment
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
    metrics = closed_loop_metrics(result)
    limits = evaluate_limits(
        prepared.spec.limits, result.log, metrics, prepared.controller_vehicle, result.sample_period_s
    )
    figures = render(prepared, result, limits) if render is not None else {}
    return RunOutcome(task, metrics, tuple(limits), time.perf_counter() - t0, figures=figures)


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


MAX_JOBS = 1024
"""The most worker processes a run may ask for: far beyond any machine's cores, far below what exhausts one."""


def resolved_jobs(
    jobs: int | None, executor: str, scheduler: str | None = None, progress: Callable[..., Any] | None = None
) -> int:
    """The number of local workers (default: every core), with ``jobs``, ``executor``, ``scheduler`` and
    ``progress`` checked: a one-line :class:`ConfigError` naming the option otherwise."""
    if jobs is not None and (isinstance(jobs, bool) or not isinstance(jobs, numbers.Integral)):
        raise ConfigError("--jobs", "", f"expected an integer (got {jobs!r})")
    n = int(jobs) if jobs is not None else (os.cpu_count() or 1)
    if not 1 <= n <= MAX_JOBS:
        raise ConfigError("--jobs", "", f"must be between 1 and {MAX_JOBS} (got {n})")
    if executor not in ("local", "dask"):
        raise ConfigError("--executor", "", f"must be local or dask (got {executor!r})")
    if scheduler is not None and not isinstance(scheduler, str):
        raise ConfigError("--scheduler", "", f"expected an address such as tcp://host:8786 (got {scheduler!r})")
    if progress is not None and not callable(progress):
        raise ConfigError("progress", "", f"expected a function progress(done, total) (got {progress!r})")
    return n


class InlineExecutor(Executor):
    """Each task run in this thread as it is submitted: no worker, so nothing to start and nothing left running
    after an interrupt (the run in progress stops with it)."""

    def submit(self, fn: Callable[..., R], /, *args: Any, **kwargs: Any) -> Future[R]:
        future: Future[R] = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # as a worker's: the task's error, in its future
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def _sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread meanwhile (and delivered when the block ends): worker processes and threads
    started meanwhile inherit the block, so an interrupt (Ctrl-C reaches the whole process group) stops only this
    process, which then stops them."""
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


@contextlib.contextmanager
def _process_pool(jobs: int) -> Iterator[Executor]:
    """``jobs`` spawned worker processes that never see SIGINT, terminated at once when the block is left by an
    exception or an interrupt (a run in progress is abandoned) and shut down otherwise."""
    # one thread per worker for the numerical libraries (as Dask does for its workers): with N workers on N cores
    # their own thread pools would oversubscribe the machine several times over
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update({k: "1" for k, v in saved.items() if v is None})
    try:
        with _sigint_blocked():
            pool = ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn"))
        try:
            yield pool
        except BaseException:
            for process in list(pool._processes.values()):
                process.terminate()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)


@contextlib.contextmanager
def open_executor(kind: ExecutorKind, jobs: int, scheduler: str | None, n_tasks: int) -> Iterator[Executor]:
    """The executor the runs go to, shut down (its workers and any cluster of ours stopped) on leaving.

    ``"local"``: ``jobs`` spawned worker processes, or, for one job or one task, this process itself
    (:class:`InlineExecutor`: no start-up cost; the runs go one after another). ``"dask"``: the
    ``concurrent.futures`` executor of a Dask client of the scheduler at ``scheduler``, or of a local cluster of
    ``jobs`` worker processes. An interrupt (SIGINT) reaches only this process; local workers are stopped with it.
    """
    if kind == "dask":
        try:
            from dask.distributed import Client
        except ImportError:
            raise ConfigError("--executor", "dask", "needs the dask extra: pip install 'agvctl[dask]'") from None
        # no scheduler: a local cluster of `jobs` worker processes
        client = Client(scheduler) if scheduler else Client(n_workers=jobs, threads_per_worker=1, processes=True)
        try:
            with client.get_executor(pure=False) as dask_pool:
                yield dask_pool
        finally:
            client.close()  # our own connection (and, without a scheduler, our own local cluster)
        return
    if jobs <= 1 or n_tasks <= 1:
        with InlineExecutor() as inline:
            yield inline
        return
    with _process_pool(jobs) as pool:
        yield pool


def execute(
    pool: Executor,
    run: Callable[[T], R],
    tasks: Sequence[T],
    progress: Callable[[int, int], None] | None,
    on_error: Callable[[T, Exception], R] | None = None,
) -> list[R]:
    """``run(task)`` of every task on ``pool``, in the order of ``tasks`` whatever order they finish in.

    A task whose future raises (``run`` raised, or its worker died or could not send the result back) gives
    ``on_error(task, exception)`` when that is given; without it the first error stops all. ``run`` must be a
    module-level function (it is pickled for worker processes).
    """
    outcomes: dict[Future[R], R] = {}

    def record(done: int, future: Future[R], task: T) -> None:
        try:
            outcomes[future] = future.result()
        except Exception as exc:
            if on_error is None:
                raise
            outcomes[future] = on_error(task, exc)
        if progress:
            progress(done, len(tasks))

    futures: list[Future[R]] = []
    if isinstance(pool, InlineExecutor):  # each run in its turn, so progress comes run by run
        for done, task in enumerate(tasks, start=1):
            futures.append(pool.submit(run, task))
            record(done, futures[-1], task)
        return [outcomes[f] for f in futures]
    with _sigint_blocked():  # worker processes start on the first submissions, and inherit the block
        futures = [pool.submit(run, task) for task in tasks]
    task_of = dict(zip(futures, tasks, strict=True))
    try:
        for done, future in enumerate(as_completed(futures), start=1):
            record(done, future, task_of[future])
    finally:
        for future in futures:
            future.cancel()  # after an error or an interrupt: the runs not started yet
    return [outcomes[f] for f in futures]


@dataclass(frozen=True)
class CheckWork:
    """The experiments of a check, loaded and validated, and their runs (one per Monte Carlo sample, or the
    nominal one): what :func:`check_experiments` runs."""

    paths: tuple[str, ...]
    experiments: tuple[Experiment, ...]
    tasks: tuple[tuple[RunTask, ...], ...]

    @property
    def input_files(self) -> list[Path]:
        """Every file the check reads: each experiment file and the files it names."""
        return [f for exp in self.experiments for f in exp.input_files]


def load_check(paths: Sequence[str | Path]) -> CheckWork:
    """Load and validate every experiment and draw its Monte Carlo samples, before anything runs.

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
) -> CheckReport:
    """Run every experiment (its Monte Carlo samples too) and check its limits.

    Parameters
    ----------
    paths
        Experiment files, or the :class:`CheckWork` of :func:`load_check` (loaded already).
    jobs
        Local worker processes (default: all cores); with one job, or one run in all, the runs go one after another
        in this process. With ``executor="dask"`` and no scheduler: the local cluster's workers.
    executor
        ``"local"``, or ``"dask"`` to send the runs to the Dask scheduler at ``scheduler``.
    scheduler
        The Dask scheduler's address (``tcp://host:8786``); ``None`` with ``executor="dask"``: a local cluster.
    progress
        Called as ``progress(done, total)`` in this thread after each run.
    render
        Draws each nominal run's figures where it runs (:data:`RunRender`), into :attr:`RunOutcome.figures`; the
        Monte Carlo samples are not drawn.

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

    Local workers are spawned processes, which import the calling script again: from a script, call this under
    ``if __name__ == "__main__":``.
    """
    t0 = time.perf_counter()
    jobs = resolved_jobs(jobs, executor, scheduler, progress)
    if render is not None and not callable(render):
        raise ConfigError("render", "", f"expected a function render(experiment, result, limits) (got {render!r})")
    work = paths if isinstance(paths, CheckWork) else load_check(paths)
    all_tasks = [t for ts in work.tasks for t in ts]
    with open_executor(executor, jobs, scheduler, len(all_tasks)) as pool:
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
