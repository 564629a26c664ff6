"""``agvctl check``: run experiments (nominal and Monte Carlo), enforce their limits, report.

Everything is loaded and validated first — every experiment file, every Monte Carlo sample's vehicle — so bad
input stops the check before anything runs. The runs then fan out over local processes or a Dask cluster; each
returns only its metrics and limit verdicts. Samples are drawn in the parent from the experiment's seed, so the
same seed gives the same samples and the same physical results on any executor (the computation-time metrics,
``solve_time_p99_ms`` and ``deadline_misses``, are measured and so vary from run to run).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from agvctl.checks.limits import LimitResult, evaluate_limits, format_limit_message
from agvctl.config import to_dict
from agvctl.errors import ConfigError
from agvctl.sim.experiment import Experiment, load_experiment, run_experiment
from agvctl.sim.metrics import closed_loop_metrics

__all__ = [
    "CheckReport",
    "ExperimentReport",
    "Executor",
    "LimitVerdict",
    "RunOutcome",
    "RunTask",
    "check_experiments",
    "monte_carlo_samples",
]

Executor = Literal["local", "dask"]
Overrides = tuple[tuple[str, float], ...]

TIMING_METRICS = ("solve_time_p50_ms", "solve_time_p99_ms", "deadline_misses")
"""Metrics measured on the wall clock: they vary between runs and executors."""


@dataclass(frozen=True)
class RunTask:
    """One closed-loop run: an experiment file, and for a Monte Carlo sample its plant overrides."""

    experiment_path: str
    sample: int | None
    overrides: Overrides = ()


@dataclass(frozen=True)
class RunOutcome:
    """What a run sends back: metrics and limit verdicts (no log)."""

    task: RunTask
    metrics: dict[str, float]
    limits: tuple[LimitResult, ...]
    wall_time_s: float


@dataclass(frozen=True)
class LimitVerdict:
    """One limit of one experiment over all its runs: the worst run decides."""

    limit: str
    bound: float
    passed: bool
    value: float
    """The worst value over the runs."""
    worst_time_s: float | None
    first_time_s: float | None
    sample: int | None
    """The Monte Carlo sample that gave the worst value (None: the nominal run)."""
    parameters: dict[str, float]
    """That sample's plant parameters (the dotted keys that were varied)."""
    runs: int
    failed_runs: int
    default: bool = False

    @property
    def message(self) -> str:
        text = format_limit_message(
            self.limit, self.value, self.bound, self.passed, self.worst_time_s, self.first_time_s
        )
        if self.passed:
            return text
        if self.sample is not None:
            params = ", ".join(f"{k} = {v:.6g}" for k, v in self.parameters.items())
            text += f"; sample {self.sample} of {self.runs} ({self.failed_runs} failed): {params}"
        return text

    def as_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["message"] = self.message
        return d


@dataclass
class ExperimentReport:
    """One experiment's verdicts, with the raw outcomes of its runs."""

    name: str
    path: str
    verdicts: list[LimitVerdict]
    outcomes: list[RunOutcome]
    wall_time_s: float

    @property
    def passed(self) -> bool:
        return all(v.passed for v in self.verdicts)

    @property
    def monte_carlo(self) -> bool:
        return any(o.task.sample is not None for o in self.outcomes)

    def as_dict(self) -> dict[str, Any]:
        metrics = [{"sample": o.task.sample, **_json_safe(o.metrics)} for o in self.outcomes]
        return {
            "experiment": self.name,
            "path": self.path,
            "passed": self.passed,
            "runs": len(self.outcomes),
            "wall_time_s": self.wall_time_s,
            "limits": [v.as_dict() for v in self.verdicts],
            "metrics": metrics if self.monte_carlo else metrics[0],
        }


@dataclass
class CheckReport:
    """Every experiment's report."""

    experiments: list[ExperimentReport] = field(default_factory=list)
    wall_time_s: float = 0.0

    @property
    def passed(self) -> bool:
        return all(e.passed for e in self.experiments)

    def as_dict(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "wall_time_s": self.wall_time_s,
            "experiments": [e.as_dict() for e in self.experiments],
        }


def _json_safe(d: dict[str, float]) -> dict[str, float | None]:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


# -- Monte Carlo samples ----------------------------------------------------------------------------------------


def _nominal_values(prepared: Experiment, key: str) -> list[tuple[str, float]]:
    """The plant's nominal value(s) of a dotted key; ``motor.X`` with different sides gives both sides."""
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
    if len(parts) == 2 and parts[0] == "motor":
        sides = [
            (f"motor.{s}.{parts[1]}", getattr(prepared.plant_vehicle.motor.side(s), parts[1], None))
            for s in ("left", "right")
        ]
        if all(isinstance(v, float) for _k, v in sides):
            return [(k, float(v)) for k, v in sides]  # type: ignore[arg-type]
    raise ConfigError(prepared.spec.source, f"robustness.spread.{key}", "not a numeric vehicle key")


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


def run_task(task: RunTask) -> RunOutcome:
    """Run one task (in this process). Used by every executor; module-level so it pickles."""
    base = _prepared(task.experiment_path)
    prepared = base
    if task.overrides:
        plant = base.plant_vehicle.with_overrides(list(task.overrides), source=f"sample {task.sample}")
        prepared = dataclasses.replace(base, plant_vehicle=plant)
    t0 = time.perf_counter()
    result = run_experiment(prepared)
    metrics = closed_loop_metrics(result)
    limits = evaluate_limits(
        prepared.spec.limits, result.log, metrics, prepared.controller_vehicle, result.sample_period_s
    )
    return RunOutcome(task, metrics, tuple(limits), time.perf_counter() - t0)


def _execute(
    tasks: Sequence[RunTask],
    *,
    jobs: int,
    executor: Executor,
    scheduler: str | None,
    progress: Callable[[int, int], None] | None,
) -> list[RunOutcome]:
    n = len(tasks)
    done = 0
    out: list[RunOutcome] = []
    if executor == "dask":
        try:
            from dask.distributed import Client, as_completed
        except ImportError:
            raise ConfigError("--executor", "dask", "needs the dask extra: pip install 'agvctl[dask]'") from None
        # no scheduler: a local cluster of `jobs` worker processes
        client = Client(scheduler) if scheduler else Client(n_workers=jobs, threads_per_worker=1, processes=True)
        try:
            futures = client.map(run_task, list(tasks), pure=False)
            index = {f.key: i for i, f in enumerate(futures)}
            results: list[RunOutcome | None] = [None] * n
            for fut in as_completed(futures):
                results[index[fut.key]] = fut.result()
                done += 1
                if progress:
                    progress(done, n)
            out = [r for r in results if r is not None]
        finally:
            client.close()  # our own connection (and, without a scheduler, our own local cluster)
        return out
    if jobs <= 1 or n <= 1:
        for task in tasks:
            out.append(run_task(task))
            done += 1
            if progress:
                progress(done, n)
        return out
    import multiprocessing

    # one thread per worker for the numerical libraries (as Dask does for its workers): with N workers on N cores
    # their own thread pools would oversubscribe the machine several times over
    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update({k: "1" for k, v in saved.items() if v is None})
    try:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            for outcome in pool.map(run_task, tasks, chunksize=max(1, n // (4 * jobs))):
                out.append(outcome)
                done += 1
                if progress:
                    progress(done, n)
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
    return out


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def _verdicts(outcomes: Sequence[RunOutcome]) -> list[LimitVerdict]:
    keys = [r.limit for r in outcomes[0].limits]
    verdicts = []
    for idx, key in enumerate(keys):
        per_run = [o.limits[idx] for o in outcomes]
        worst_i = int(np.argmax([r.value for r in per_run]))
        worst = per_run[worst_i]
        failed = [i for i, r in enumerate(per_run) if not r.passed]
        # report the worst run; among failed runs the worst is also the one that exceeded
        task = outcomes[worst_i].task
        params = dict(task.overrides)
        verdicts.append(
            LimitVerdict(
                limit=key,
                bound=worst.bound,
                passed=not failed,
                value=worst.value,
                worst_time_s=worst.worst_time_s,
                first_time_s=worst.first_time_s,
                sample=task.sample,
                parameters=params,
                runs=len(per_run),
                failed_runs=len(failed),
                default=worst.default,
            )
        )
    return verdicts


def check_experiments(
    paths: Sequence[str | Path],
    *,
    jobs: int | None = None,
    executor: Executor = "local",
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> CheckReport:
    """Run every experiment (its Monte Carlo samples too) and check its limits.

    ``jobs`` processes (default: all cores) for the local executor; ``executor="dask"`` sends the runs to the
    Dask scheduler at ``scheduler`` (``tcp://host:8786``). Raises :class:`ConfigError` on bad input before any run.
    Local workers are spawned processes, which import the calling script again: from a script, call this under
    ``if __name__ == "__main__":``.
    """
    t0 = time.perf_counter()
    jobs = jobs if jobs is not None else (os.cpu_count() or 1)
    if jobs < 1:
        raise ConfigError("--jobs", "", f"must be >= 1 (got {jobs})")
    if executor not in ("local", "dask"):
        raise ConfigError("--executor", "", f"must be local or dask (got {executor})")
    experiments: list[Experiment] = []
    tasks_of: list[list[RunTask]] = []
    for path in paths:
        exp = load_experiment(path)
        key = str(Path(path).resolve())
        samples = monte_carlo_samples(exp)
        tasks = [RunTask(key, i, s) for i, s in enumerate(samples)] if samples else [RunTask(key, None, ())]
        experiments.append(exp)
        tasks_of.append(tasks)
    all_tasks = [t for ts in tasks_of for t in ts]
    outcomes = _execute(all_tasks, jobs=jobs, executor=executor, scheduler=scheduler, progress=progress)
    report = CheckReport()
    pos = 0
    for exp, path, tasks in zip(experiments, paths, tasks_of, strict=True):
        mine = outcomes[pos : pos + len(tasks)]
        pos += len(tasks)
        report.experiments.append(
            ExperimentReport(exp.spec.name, str(path), _verdicts(mine), list(mine), sum(o.wall_time_s for o in mine))
        )
    report.wall_time_s = time.perf_counter() - t0
    return report
