"""The search: an optimiser proposes scenarios of a fuzz file's envelope, each is run as ``agvctl fuzz`` runs it, and
the run's smallest normalised margin is minimised.

A scenario is drawn by the fuzz generator itself (:func:`~agvctl.fuzz.generate.draw_scenario`), its values taken
from an Optuna trial instead of a random generator (:class:`TrialDraws`): the path's number and kinds of segments
(categorical and integer parameters, the segments' lengths, radii and angles present only where their segment
is), the plant's values, the start offset and heading, the sensors' noise seed and the estimators. Random fuzzing and
the search share that one definition of the envelope.

The trials go in batches of ``batch``: ask ``batch`` trials (Optuna's TPE with a constant liar, so a batch spreads
out; after a random start, three in four are local moves around the runs closest to failing,
``agvctl.falsify.proposals``),
run them on the executor of ``agvctl fuzz`` (this process, local processes or Dask), tell their values in order.
The sampler of each batch is seeded from the search's seed and the number of runs done, so the same seed and batch
give the same scenarios and margins whatever the number of jobs or the executor, and a search resumed
from its journal goes on exactly as one that never stopped.

The objective is the run's smallest normalised margin (:func:`~agvctl.evaluation.verdicts.smallest_normalised_margin`)
over its limits and requirements, the measured solve times excepted (:data:`~agvctl.checks.report.TIMING_METRICS`:
they differ between two runs of one scenario). A run below zero falsifies a requirement; a run that crashes is a
finding too. By default the search stops after the batch that found one.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from agvctl.checks.executors import ExecutorKind, open_executor, resolved_jobs
from agvctl.errors import ConfigError
from agvctl.evaluation.limits import LIMITS, LimitResult
from agvctl.falsify.proposals import SAMPLERS, TrialDraws, local_moves, optuna_module, sampler_for
from agvctl.falsify.result import FalsifyResult, SearchRun, searched_margin
from agvctl.fuzz.generate import Scenario, draw_scenario, generate_scenario, scenario_files
from agvctl.fuzz.report import FuzzOutcome, FuzzTask
from agvctl.fuzz.run import run_fuzz_tasks
from agvctl.fuzz.spec import FuzzSpec, check_against_vehicle, override_fuzz_config
from agvctl.params import VehicleParams, load_vehicle

__all__ = ["SAMPLERS", "FalsifyResult", "SearchRun", "TrialDraws", "check_falsify", "falsify", "searched_margin"]

IMPORTANCE_MIN_RUNS = 20
"""Finished runs below which no importances are given: over fewer, the lowest tenth is one or two runs."""

MAX_REDRAWS = 100
"""Proposals in a row whose plant values together make an invalid vehicle before the search gives up."""


def _envelope_digest(spec: FuzzSpec, controller: str) -> str:
    """What makes a run's scenario and verdicts: changed, a journal's runs are another search's."""
    parts = (spec.paths, spec.start, sorted(spec.plant.items()), spec.controller, spec.estimators, spec.limits)
    text = repr((parts, spec.requirements, spec.settle_s, spec.vehicle, spec.pose_settings.get(controller), controller))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _open_study(optuna: Any, storage: Path | None, setup: dict[str, Any]) -> tuple[Any, Any]:
    """The study the sampler works on (in memory) and its journal (None without ``storage``), the journal's
    finished trials copied into the study in order: a resumed search has the same trials, numbered alike."""
    study = optuna.create_study(direction="minimize")
    if storage is None:
        return study, None
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    try:
        backend = JournalStorage(JournalFileBackend(str(storage)))
    except OSError as exc:
        raise ConfigError(str(storage), "", f"cannot open the search journal: {exc.strerror}") from None
    journal = optuna.create_study(study_name="falsify", storage=backend, direction="minimize", load_if_exists=True)
    held = {k: journal.user_attrs.get(k) for k in setup}
    if journal.trials and held != setup:
        changed = ", ".join(k for k in setup if held[k] != setup[k])
        raise ConfigError(str(storage), "", f"holds a search of another setup ({changed}); use another --out")
    for k, v in setup.items():
        journal.set_user_attr(k, v)
    study.add_trials([t for t in journal.trials if t.state.is_finished()])
    return study, journal


def _record(study: Any, journal: Any, recorded: int) -> int:
    """Append the study's trials from number ``recorded`` on to the journal (the batch just told), one entry each:
    a journal write per finished trial, not per parameter, and a batch an interrupt stopped is proposed again on
    resuming. Returns the trials recorded in all."""
    trials = study.get_trials(deepcopy=False)
    if journal is not None:
        journal.add_trials(trials[recorded:])
    return len(trials)


def _verdict_dict(r: LimitResult) -> dict[str, Any]:
    return {
        "name": r.limit,
        "kind": r.kind,
        "margin": r.margin,
        "normalised_margin": r.normalised_margin,
        "passed": r.passed,
        "message": r.message,
    }


def _scenario_attrs(s: Scenario) -> dict[str, Any]:
    return dataclasses.asdict(s)


def _run_from_trial(t: Any, requirement: str | None) -> SearchRun:
    a = t.user_attrs
    scenario = Scenario(**a["scenario"])
    margin = math.nan if a["margin"] is None else float(a["margin"])
    verdicts = tuple({**v, "normalised_margin": _float(v["normalised_margin"])} for v in a["verdicts"])
    wall_s = float(a["wall_time_s"])
    return SearchRun(a["run"], dict(t.params), scenario, margin, verdicts, a["error"], wall_s, requirement)


def _float(value: float | None) -> float:
    return math.nan if value is None else float(value)


def _json_number(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def _finished_runs(study: Any, requirement: str | None) -> list[SearchRun]:
    runs = [
        _run_from_trial(t, requirement)
        for t in study.trials
        if "run" in t.user_attrs and t.state.name in ("COMPLETE", "FAIL")
    ]
    return sorted(runs, key=lambda r: r.run)


def _ask(optuna: Any, study: Any, spec: FuzzSpec, vehicle: VehicleParams, index: int) -> tuple[Any, Scenario]:
    """A trial and its scenario; a proposal whose plant values together give an invalid vehicle is told as failed
    and another asked."""
    for _ in range(MAX_REDRAWS):
        trial = study.ask()
        try:
            return trial, draw_scenario(spec, vehicle, TrialDraws(trial), index, prefix="search")
        except ConfigError:
            study.tell(trial, state=optuna.trial.TrialState.FAIL)
    raise ConfigError(spec.source, "plant", f"{MAX_REDRAWS} proposals in a row gave an invalid vehicle")


def _tell(
    study: Any, trial: Any, run: int, scenario: Scenario, outcome: FuzzOutcome, requirement: str | None
) -> SearchRun:
    margin = math.nan if outcome.error is not None else searched_margin(outcome.limits, requirement)
    verdicts = tuple(_verdict_dict(r) for r in outcome.limits)
    attrs = {
        "run": run,
        "scenario": _scenario_attrs(scenario),
        "margin": _json_number(margin) if not math.isinf(margin) else None,
        "verdicts": [
            {**v, "margin": _json_number(v["margin"]), "normalised_margin": _json_number(v["normalised_margin"])}
            for v in verdicts
        ],
        "error": outcome.error,
        "wall_time_s": outcome.wall_time_s,
    }
    for k, v in attrs.items():
        trial.set_user_attr(k, v)
    if outcome.error is not None or not math.isfinite(margin):
        study.tell(trial, state=optuna_module().trial.TrialState.FAIL)
    else:
        study.tell(trial, margin)
    wall_s = outcome.wall_time_s
    return SearchRun(run, dict(trial.params), scenario, margin, verdicts, outcome.error, wall_s, requirement)


def _importances(optuna: Any, study: Any) -> dict[str, float]:
    """PED-ANOVA's importances over the parameters every finished run has (a segment's own values exist only
    where the path has that segment); empty below :data:`IMPORTANCE_MIN_RUNS` runs."""
    finished = [t for t in study.trials if t.state.name == "COMPLETE"]
    if len(finished) < IMPORTANCE_MIN_RUNS:
        return {}
    common = sorted(set.intersection(*(set(t.params) for t in finished)))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "some regimes have less than 2 trials": the shares are rough then
            evaluator = optuna.importance.PedAnovaImportanceEvaluator()
            found = optuna.importance.get_param_importances(study, evaluator=evaluator, params=common)
        return {k: float(v) for k, v in found.items()}
    except (RuntimeError, ValueError):  # e.g. every finished trial drew the same values
        return {}


def _checked(
    budget_runs: Any, budget_s: Any, batch: Any, sampler: Any, baseline: Any, storage: Any
) -> tuple[int | None, float | None]:
    if budget_runs is None and budget_s is None:
        raise ConfigError("--budget", "", "give a budget in runs (--budget N) or in seconds (--budget-s S)")
    if budget_runs is not None and (
        isinstance(budget_runs, bool) or not isinstance(budget_runs, int) or not 1 <= budget_runs <= 100_000
    ):
        raise ConfigError("--budget", "", f"must be an integer from 1 to 100000 (got {budget_runs!r})")
    if budget_s is not None and (
        isinstance(budget_s, bool) or not isinstance(budget_s, (int, float)) or not 0 < budget_s <= 1e7
    ):
        raise ConfigError("--budget-s", "", f"must be a number of seconds above 0 (got {budget_s!r})")
    if isinstance(batch, bool) or not isinstance(batch, int) or not 1 <= batch <= 1024:
        raise ConfigError("--batch", "", f"must be an integer from 1 to 1024 (got {batch!r})")
    if sampler not in SAMPLERS:
        raise ConfigError("--sampler", "", f"must be one of {', '.join(SAMPLERS)} (got {sampler!r})")
    if not isinstance(baseline, bool):
        raise ConfigError("falsify", "baseline", f"expected True or False (got {baseline!r})")
    if storage is not None and not isinstance(storage, (str, Path)):
        raise ConfigError("falsify", "storage", f"expected a file path or None (got {storage!r:.60})")
    return budget_runs, None if budget_s is None else float(budget_s)


def check_falsify(
    spec: FuzzSpec,
    *,
    budget_runs: int | None,
    budget_s: float | None,
    seed: int | None,
    controller: str | None,
    requirement: str | None,
    batch: int,
    sampler: str,
    baseline: bool,
    jobs: int | None,
    executor: ExecutorKind,
    scheduler: str | None,
    storage: str | Path | None,
    progress: Callable[[int, int], None] | None,
) -> tuple[FuzzSpec, int, str, int | None, float | None]:
    """Check the arguments of :func:`falsify` (as it does first), before anything is written or run.

    Parameters
    ----------
    spec : FuzzSpec
        As :func:`falsify`'s.
    budget_runs, budget_s, seed, controller, requirement, batch, sampler, baseline, jobs, executor, scheduler
        As :func:`falsify`'s.
    storage, progress
        As :func:`falsify`'s.

    Returns
    -------
    tuple
        The configuration with the seed and its one controller, the seed, the controller, the budgets.

    Raises
    ------
    ConfigError
        As :func:`falsify`.
    """
    if not isinstance(spec, FuzzSpec):
        raise ConfigError("falsify", "spec", f"expected a FuzzSpec (got {spec!r:.60})")
    budget_runs, budget_s = _checked(budget_runs, budget_s, batch, sampler, baseline, storage)
    seed = spec.seed if seed is None else seed
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError("--seed", "", f"must be an integer >= 0 (got {seed!r})")
    controller = spec.controllers[0] if controller is None else controller
    if not isinstance(controller, str):
        raise ConfigError("--controller", "", f"expected a pose controller's name (got {controller!r:.60})")
    spec = override_fuzz_config(spec, seed=seed, controllers=[controller])
    names = sorted({*LIMITS, *(r.name for r in spec.requirements)})
    if requirement is not None and requirement not in names:
        raise ConfigError("--requirement", "", f"must name a limit or a requirement of the file (got {requirement!r})")
    check_against_vehicle(spec, load_vehicle(None if spec.vehicle == "default" else spec.vehicle))
    resolved_jobs(jobs, executor, scheduler, progress)
    optuna_module()
    return spec, seed, controller, budget_runs, budget_s


def falsify(
    spec: FuzzSpec,
    *,
    budget_runs: int | None = 100,
    budget_s: float | None = None,
    seed: int | None = None,
    controller: str | None = None,
    requirement: str | None = None,
    batch: int = 4,
    sampler: str = "tpe",
    stop_at_first: bool = True,
    baseline: bool = False,
    jobs: int | None = None,
    executor: ExecutorKind = "local",
    scheduler: str | None = None,
    storage: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> FalsifyResult:
    """Search the envelope of ``spec`` for the scenario with the smallest requirement margin (see the module notes).

    Parameters
    ----------
    spec : FuzzSpec
        From :func:`~agvctl.fuzz.spec.load_fuzz_config`: the envelope, the limits and requirements.
    budget_runs : int or None
        Runs in all (a resumed journal's included), 1 to 100000; None: only ``budget_s`` bounds the search.
    budget_s : float or None
        Wall time, s: no batch starts after it (None: no bound). With both budgets the first reached ends it.
    seed : int or None
        The search's seed (default: the configuration's).
    controller : str or None
        The pose controller, a name or a reference ``package.module:Name`` (default: the first of
        ``spec.controllers``).
    requirement : str or None
        Search the margin of this one limit (a ``[limits]`` key) or requirement (a ``[[requirements]]`` name)
        instead of the smallest of all: a weakness the others' smaller margins hide.
    batch : int
        Trials proposed, run and told together, 1 to 1024: the results depend on it, not on ``jobs``. Keep it at
        least ``jobs`` for the workers to be busy.
    sampler : {'tpe', 'random', 'cmaes'}
        The optimiser (:data:`SAMPLERS`).
    stop_at_first : bool
        Stop after the batch in which a run falsified a limit or requirement (or crashed).
    baseline : bool
        Also run as many random scenarios of the configuration's seed (``agvctl fuzz``'s scenarios 0, 1, …) as
        the search ran, for comparison.
    jobs, executor, scheduler
        Where the runs go, as for :func:`~agvctl.fuzz.run.fuzz`.
    storage : str or Path or None
        A journal file (Optuna's journal storage) holding the search, resumed if it exists; None: in memory.
    progress : callable or None
        Called as ``progress(done, total)``: runs of ``budget_runs``, or seconds of ``budget_s`` without it.

    Returns
    -------
    FalsifyResult
        Every run, the worst, the importances and the baseline.

    Raises
    ------
    ConfigError
        One line naming the file (or option) and key: a configuration that does not fit its vehicle, an option out
        of range, a journal of another search, Optuna (or for CMA-ES, cmaes) not installed.

    Notes
    -----
    From a script, call this under ``if __name__ == "__main__":`` (local workers are spawned processes, which
    import the calling script again).
    """
    t0 = time.perf_counter()
    options = {k: v for k, v in locals().items() if k not in ("spec", "stop_at_first", "t0")}
    return _search(t0, spec, stop_at_first, options)


def _propose(
    optuna: Any,
    study: Any,
    spec: FuzzSpec,
    vehicle: VehicleParams,
    sampler: str,
    seed: int,
    done: int,
    n: int,
    requirement: str | None,
) -> list[tuple[Any, Scenario]]:
    """A batch's ``n`` trials and scenarios: the local moves first (asked through a random sampler: a move's
    values are fixed, so no model is fitted for it), then the sampler's proposals."""
    proposer = sampler_for(optuna, sampler, seed, done)
    moves = local_moves(optuna, study, sampler, seed, done, n, requirement)
    asked = []
    for k in range(n):
        if k < len(moves):
            study.sampler = sampler_for(optuna, "random", seed, done)
            study.enqueue_trial(moves[k], skip_if_exists=False)
        else:
            study.sampler = proposer
        asked.append(_ask(optuna, study, spec, vehicle, done + k))
    return asked


def _baseline(
    pool: Any, spec: FuzzSpec, vehicle: VehicleParams, controller: str, n: int, requirement: str | None
) -> tuple[list[float], float]:
    """The margins of random scenarios 0 to n − 1 of the configuration's seed, and their runs' own time, s."""
    tasks = []
    for i in range(n):
        s = generate_scenario(spec, vehicle, i)
        tasks.append(FuzzTask(i, s.name, controller, tuple(scenario_files(spec, s, controller).items())))
    outcomes = run_fuzz_tasks(pool, tasks)
    margins = [-math.inf if o.error is not None else searched_margin(o.limits, requirement) for o in outcomes]
    return margins, sum(o.wall_time_s for o in outcomes)


def _search(t0: float, spec: FuzzSpec, stop_at_first: bool, options: dict[str, Any]) -> FalsifyResult:
    """:func:`falsify` after its arguments are gathered: check them, then propose, run and tell batch by batch."""
    spec, seed, controller, budget_runs, budget_s = check_falsify(spec, **options)
    requirement, batch, sampler, progress = (options[k] for k in ("requirement", "batch", "sampler", "progress"))
    executor, scheduler, storage = options["executor"], options["scheduler"], options["storage"]
    vehicle = load_vehicle(None if spec.vehicle == "default" else spec.vehicle)
    jobs = resolved_jobs(options["jobs"], executor, scheduler, progress)
    optuna = optuna_module()
    setup = {"fuzz": spec.name, "controller": controller, "seed": seed, "batch": batch, "sampler": sampler}
    setup["requirement"] = requirement
    setup["envelope"] = _envelope_digest(spec, controller)
    study, journal = _open_study(optuna, None if storage is None else Path(storage), setup)
    runs = _finished_runs(study, requirement)
    resumed, recorded = len(runs), len(study.trials)
    run_time_s = 0.0

    def more() -> bool:
        if stop_at_first and any(r.falsified for r in runs):
            return False
        if budget_runs is not None and len(runs) >= budget_runs:
            return False
        return budget_s is None or time.perf_counter() - t0 < budget_s

    def tick(done: int) -> None:
        if progress is None:
            return
        if budget_runs is not None:
            progress(min(done, budget_runs), budget_runs)
        else:
            progress(int(min(time.perf_counter() - t0, budget_s or 0.0)), int(budget_s or 0.0))

    def after(start: int) -> Callable[[int, int], None]:
        return lambda done, _total: tick(start + done)

    with open_executor(executor, jobs, scheduler, max(batch, 2), prepare=run_fuzz_tasks.__module__) as pool:
        while more():
            n = batch if budget_runs is None else min(batch, budget_runs - len(runs))
            asked = _propose(optuna, study, spec, vehicle, sampler, seed, len(runs), n, requirement)
            tasks = [
                FuzzTask(s.index, s.name, controller, tuple(scenario_files(spec, s, controller).items()))
                for _t, s in asked
            ]
            outcomes = run_fuzz_tasks(pool, tasks, after(len(runs)))
            for (trial, scenario), outcome in zip(asked, outcomes, strict=True):
                runs.append(_tell(study, trial, scenario.index, scenario, outcome, requirement))
                run_time_s += outcome.wall_time_s
            recorded = _record(study, journal, recorded)
        baseline_margins: list[float] = []
        if options["baseline"] and runs:
            baseline_margins, baseline_s = _baseline(pool, spec, vehicle, controller, len(runs), requirement)
            run_time_s += baseline_s
    importances = _importances(optuna, study)
    return FalsifyResult(
        spec,
        controller,
        seed,
        batch,
        sampler,
        tuple(runs),
        resumed,
        importances,
        tuple(baseline_margins),
        time.perf_counter() - t0,
        run_time_s,
    )
