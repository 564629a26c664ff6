"""``agvctl fuzz``: random scenarios through the closed loop, with one or more pose controllers, against limits.

:func:`fuzz` draws every scenario in this process (:mod:`agvctl.fuzz.generate`; scenario i of seed s from
(s, i) alone), turns each into its path and experiment files (one per controller) and sends them to the executor
of ``agvctl check`` (:func:`agvctl.checks.executors.open_executor`: this process, spawned local processes or a
Dask cluster). A worker writes the files into a temporary directory, loads them with
:func:`~agvctl.scenario.experiment.load_experiment` — exactly what ``agvctl run`` does with the written-out file — runs
the closed loop and returns the metrics and the verdicts of the gate ``agvctl check`` applies: the default gate
(:func:`~agvctl.evaluation.limits.default_limits`) with the configuration's limits in place of their defaults. A run
that raises, or whose log or metrics hold a non-finite value, is an error with its one-line reason (an ``<error>`` in
the JUnit XML, exit code 3 from ``agvctl fuzz``, as for ``agvctl check``), never an exception out of the fuzzer;
so is a run its worker could not return. Results do not depend on the number of jobs or the executor (the
measured solve times excepted).

The report and its statistics are :class:`~agvctl.fuzz.report.FuzzReport`::

    spec = load_fuzz_config("experiments/fuzz/ci.toml")
    report = fuzz(spec, jobs=2)
    report.statistics()["mpc"]["cross_track_error_max_m"]["p90"]
"""

from __future__ import annotations

import math
import numbers
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from agvctl.checks.executors import ExecutorKind, execute, open_executor, resolved_jobs
from agvctl.config import document_fields
from agvctl.errors import ConfigError, caused_by_interrupt, exception_line
from agvctl.evaluation.limits import LimitResult, all_passed, judge_run
from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.report import FuzzOutcome, FuzzReport, FuzzTask
from agvctl.fuzz.spec import FuzzSpec, check_against_vehicle
from agvctl.log import SimLog
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment, run_experiment
from agvctl.sim.loop import SENSOR_NAN_COLUMNS

MAX_SCENARIOS = 1_000_000
"""The most scenarios one fuzz runs, as a file's ``scenarios`` key allows."""
MAX_SCENARIO_INDEX = 10**9
"""Scenario indices are below this (a scenario's name holds its index)."""

__all__ = ["FuzzRun", "fuzz", "fuzz_tasks", "run_fuzz", "run_fuzz_task", "run_fuzz_tasks"]

_MAY_BE_INFINITE = frozenset({"time_to_2cm_s", "completion_time_s"})
"""Metrics for which infinity is a value (never within 2 cm), not a numerical failure."""


def _one_line(text: str, limit: int = 300) -> str:
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 1] + "…"


def _lost_run(task: FuzzTask, exc: Exception) -> FuzzOutcome:
    """The outcome of a run whose worker raised instead of returning one (it died, or could not send it back)."""
    return FuzzOutcome(task.scenario, task.controller, False, {}, (), exception_line(exc), (), 0.0, 0.0)


def _non_finite(log: SimLog, metrics: dict[str, float]) -> str | None:
    """Why the run is numerically broken (non-finite log columns or metrics), or None. The sensor columns are NaN
    where there is no reading (no gyro, no fix arriving this sample) and do not count."""
    bad = [name for name in log if name not in SENSOR_NAN_COLUMNS and not np.all(np.isfinite(log[name]))]
    if bad:
        broken = ~np.all(np.isfinite(np.column_stack([log[name] for name in bad])), axis=1)
        at = float(log["t_s"][int(np.argmax(broken))])
        names = ", ".join(bad[:5]) + (", …" if len(bad) > 5 else "")
        return f"non-finite values in the log ({names}) from t = {at:.2f} s"
    metric_bad = [k for k, v in metrics.items() if not math.isfinite(v) and k not in _MAY_BE_INFINITE]
    if metric_bad:
        return f"non-finite metrics: {', '.join(metric_bad)}"
    return None


def run_fuzz_task(task: FuzzTask) -> FuzzOutcome:
    """Run one scenario with one controller in this process: write its files, load, run, judge. Module-level so it
    pickles.

    Parameters
    ----------
    task : FuzzTask
        The run.

    Returns
    -------
    FuzzOutcome
        Its metrics and verdicts; a crash or a non-finite value is reported in it (this never raises for a failing
        run).
    """
    t0 = time.perf_counter()
    metrics: dict[str, float] = {}
    limits: tuple[LimitResult, ...] = ()
    error: str | None = None
    simulated_s = 0.0
    with warnings.catch_warnings(record=True) as caught, tempfile.TemporaryDirectory(prefix="agvctl-fuzz-") as tmp:
        warnings.simplefilter("always")
        try:
            for name, text in task.files:
                Path(tmp, name).write_text(text, encoding="utf-8")
            experiment = load_experiment(Path(tmp, task.files[-1][0]))
            result = run_experiment(experiment)
            simulated_s = result.n_samples * result.sample_period_s
            verdict = judge_run(
                result, experiment.spec.limits, experiment.controller_vehicle, experiment.spec.requirements
            )
            metrics, limits = verdict.metrics, verdict.limits
            error = _non_finite(result.log, metrics)
        except Exception as exc:  # any crash of a run is a finding, reported with its scenario
            if caused_by_interrupt(exc):  # an interrupt that surfaced as another error stops the command
                raise
            error = exception_line(exc)
    notes = tuple(sorted({_one_line(f"{w.category.__name__}: {w.message}") for w in caught}))
    passed = error is None and all_passed(list(limits))
    return FuzzOutcome(
        task.scenario,
        task.controller,
        passed,
        metrics,
        limits,
        error,
        notes,
        time.perf_counter() - t0,
        simulated_s,
    )


def run_fuzz_tasks(
    pool: Executor, tasks: Sequence[FuzzTask], progress: Callable[[int, int], None] | None = None
) -> list[FuzzOutcome]:
    """Run ``tasks`` on an executor of :func:`~agvctl.checks.executors.open_executor`, outcomes in the order of
    ``tasks``; a run its worker could not return is an outcome with its error, as in :func:`fuzz`.

    Parameters
    ----------
    pool : Executor
        An open executor (kept open across calls, so a search pays its workers' start-up once).
    tasks : sequence of FuzzTask
        The runs, e.g. from :func:`fuzz_tasks` or :func:`~agvctl.fuzz.generate.scenario_files`.
    progress : callable, optional
        Called as ``progress(done, len(tasks))`` after each run.

    Returns
    -------
    list of FuzzOutcome
        One per task.
    """
    return execute(pool, run_fuzz_task, tasks, progress, on_error=_lost_run)


@document_fields
@dataclass(frozen=True)
class FuzzRun:
    """The work of a fuzz configuration: its scenarios' tasks, (scenario, controller) in order."""

    spec: FuzzSpec
    """The configuration."""
    tasks: list[FuzzTask]
    """One task per scenario and controller."""


def _check_indices(scenarios: Sequence[int]) -> None:
    """A non-empty sequence of at most :data:`MAX_SCENARIOS` integers, each >= 0 and below
    :data:`MAX_SCENARIO_INDEX`."""
    if isinstance(scenarios, (str, bytes)) or not isinstance(scenarios, Sequence):
        raise ConfigError("fuzz", "scenarios", f"expected a sequence of scenario indices (got {scenarios!r})")
    if not scenarios:
        raise ConfigError("fuzz", "scenarios", "give at least one scenario index (got none)")
    if len(scenarios) > MAX_SCENARIOS:
        raise ConfigError("fuzz", "scenarios", f"at most {MAX_SCENARIOS} (got {len(scenarios)})")
    for i in scenarios:
        if isinstance(i, bool) or not isinstance(i, numbers.Integral):
            raise ConfigError("fuzz", "scenarios", f"indices must be integers (got {i!r})")
        if not 0 <= i < MAX_SCENARIO_INDEX:
            raise ConfigError("fuzz", "scenarios", f"indices must be >= 0 and < {MAX_SCENARIO_INDEX} (got {i})")


def fuzz_tasks(spec: FuzzSpec, scenarios: Sequence[int] | None = None) -> FuzzRun:
    """Draw the scenarios and make one task per scenario and controller, before anything runs.

    Parameters
    ----------
    spec : FuzzSpec
        The configuration.
    scenarios : sequence of int or None
        Only these scenario indices (None: ``range(spec.scenarios)``).

    Returns
    -------
    FuzzRun
        The tasks, for :func:`run_fuzz`.

    Raises
    ------
    ConfigError
        No scenario at all, a negative index, or a configuration that does not fit its vehicle, in one line.
    """
    if not isinstance(spec, FuzzSpec):
        raise ConfigError("fuzz", "spec", f"expected a FuzzSpec (got {spec!r})")
    if scenarios is not None:
        _check_indices(scenarios)
    vehicle = load_vehicle(None if spec.vehicle == "default" else spec.vehicle)
    check_against_vehicle(spec, vehicle)
    indices = range(spec.scenarios) if scenarios is None else scenarios
    tasks: list[FuzzTask] = []
    for i in indices:
        scenario = generate_scenario(spec, vehicle, int(i))
        for controller in spec.controllers:
            files = tuple(scenario_files(spec, scenario, controller).items())
            tasks.append(FuzzTask(int(i), scenario.name, controller, files))
    return FuzzRun(spec, tasks)


def fuzz(
    spec: FuzzSpec,
    *,
    jobs: int | None = None,
    executor: ExecutorKind = "local",
    scheduler: str | None = None,
    scenarios: Sequence[int] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FuzzReport:
    """Run every scenario of ``spec`` with each of its pose controllers and judge it against its limits.

    Parameters
    ----------
    spec : FuzzSpec
        From :func:`~agvctl.fuzz.spec.load_fuzz_config`.
    jobs : int or None
        Local worker processes (default: all cores); one job runs in this process. With
        ``executor="dask"`` and no scheduler: the local Dask cluster's workers.
    executor : {'local', 'dask'}
        ``"local"``, or ``"dask"`` to send the runs to the Dask scheduler at ``scheduler``.
    scheduler : str or None
        The Dask scheduler's address (``tcp://host:8786``); ``None`` with ``executor="dask"``: a local cluster.
    scenarios : sequence of int or None
        Only these scenario indices (None: ``range(spec.scenarios)``); each is the same as in a full run.
    progress : callable or None
        Called as ``progress(done, total)`` in this thread after each run.

    Returns
    -------
    FuzzReport
        Every run's outcome; a run that raised or broke down numerically has its one-line ``error``.

    Raises
    ------
    ConfigError
        On bad input, before any run: a configuration that does not fit its vehicle, scenario indices that are
        not a non-empty sequence of integers >= 0, or an option out of its range (``jobs`` 1 to
        :data:`~agvctl.checks.executors.MAX_JOBS`, ``executor``, a ``scheduler`` that is not an address, a
        ``progress`` that is not callable).

    Notes
    -----
    From a script, call this under ``if __name__ == "__main__":`` (local workers are spawned processes, which
    import the calling script again).
    """
    t0 = time.perf_counter()
    work = fuzz_tasks(spec, scenarios)
    return run_fuzz(work, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress, t0=t0)


def run_fuzz(
    work: FuzzRun,
    *,
    jobs: int | None = None,
    executor: ExecutorKind = "local",
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    t0: float | None = None,
) -> FuzzReport:
    """Run the tasks of :func:`fuzz_tasks`, drawn already so that their files can be checked first: :func:`fuzz`'s
    second half.

    Parameters
    ----------
    work : FuzzRun
        The tasks.
    jobs : int or None
        As :func:`fuzz`'s.
    executor : {'local', 'dask'}
        As :func:`fuzz`'s.
    scheduler : str or None
        As :func:`fuzz`'s.
    progress : callable or None
        As :func:`fuzz`'s.
    t0 : float or None
        A :func:`time.perf_counter` reading, s: the report's wall time starts there (None: now).

    Returns
    -------
    FuzzReport
        Every run's outcome.

    Raises
    ------
    ConfigError
        An option out of its range.
    """
    t0 = time.perf_counter() if t0 is None else t0
    jobs = resolved_jobs(jobs, executor, scheduler, progress)
    spec = work.spec
    with open_executor(executor, jobs, scheduler, len(work.tasks), prepare=run_fuzz_task.__module__) as pool:
        outcomes = run_fuzz_tasks(pool, work.tasks, progress)
    return FuzzReport(spec, work.tasks, outcomes, time.perf_counter() - t0)
