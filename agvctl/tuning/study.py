"""The search: Optuna's seeded TPE over a pose controller's settings, each trial run on the training scenarios of a
fuzz distribution, the best validated on held-out scenarios of another seed against the defaults.

A trial draws the settings (:mod:`~agvctl.tuning.space`) and runs the training scenarios in :data:`CHUNKS` equal
parts; after each it reports the objective so far (:mod:`~agvctl.tuning.objective`), and Optuna's median pruner
stops a trial that is worse than the median of the earlier trials at that point. The first trial of a new study is
the defaults (where they lie in the space), so the search starts from them. Trials run one after another, their
runs on one executor kept open for the whole search (local processes or Dask, as ``agvctl fuzz``): with the same
seed the same settings are drawn and the same best found whatever the number of jobs. A study in an SQLite file
resumes where it stopped: the trials already there count towards ``trials``.

The result is never worse than the defaults on the validation scenarios: the tuned settings are kept only if they
pass the gate on as many validation runs and lower the objective there; otherwise the result says so and its
settings are the defaults.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agvctl.checks.executors import ExecutorKind, open_executor, resolved_jobs
from agvctl.config import build
from agvctl.errors import ConfigError
from agvctl.fuzz.generate import Scenario, generate_scenario, scenario_files
from agvctl.fuzz.report import FuzzOutcome, FuzzTask
from agvctl.fuzz.run import run_fuzz_tasks
from agvctl.fuzz.spec import FuzzSpec, check_against_vehicle
from agvctl.params import load_vehicle
from agvctl.scenario.pose_settings import merged_settings
from agvctl.scenario.spec import ControllerSpec
from agvctl.tuning.objective import ObjectiveValue, ObjectiveWeights, evaluate_objective
from agvctl.tuning.space import SearchSpace, search_space, settings_table

__all__ = ["CHUNKS", "PoseTuningResult", "Validation", "tune_pose"]

CHUNKS = 4
"""The parts a trial's training scenarios run in; the pruner looks after each."""


@dataclass(frozen=True)
class Validation:
    """The defaults and the tuned settings on the held-out scenarios.

    Parameters
    ----------
    seed : int
        The validation scenarios' seed (not the training seed).
    scenarios : int
        How many.
    defaults, tuned : ObjectiveValue
        The objective and its figures with the defaults and with the best trial's settings.
    kept : bool
        Whether the tuned settings are kept: as many gate passes as the defaults and a lower objective.
    """

    seed: int
    scenarios: int
    defaults: ObjectiveValue
    tuned: ObjectiveValue
    kept: bool


@dataclass(frozen=True)
class PoseTuningResult:
    """What :func:`tune_pose` found.

    Parameters
    ----------
    spec : FuzzSpec
        The training distribution (its seed and scenario count are the training set's).
    space : SearchSpace
        The settings searched.
    weights : ObjectiveWeights
        The objective's weights.
    study : optuna.study.Study
        The Optuna study, every trial in it (resumed ones included).
    best_values : dict
        The best trial's settings, by (dotted) name.
    settings : dict
        The ``[controller]`` keys to write: the fuzz file's settings file for the controller (``[pose_settings]``,
        if any) with the best trial's over them if kept, else that file's alone (the defaults).
    validation : Validation
        Defaults against tuned on the held-out scenarios.
    wall_time_s : float
        The search and the validation, s.
    """

    spec: FuzzSpec
    space: SearchSpace
    weights: ObjectiveWeights
    study: Any
    best_values: dict[str, float]
    settings: dict[str, Any]
    validation: Validation
    wall_time_s: float

    @property
    def controller(self) -> str:
        """The pose controller tuned."""
        return self.space.controller

    def trial_counts(self) -> dict[str, int]:
        """How many trials finished, were pruned, or failed."""
        states = [t.state.name for t in self.study.trials]
        return {s.lower(): states.count(s) for s in ("COMPLETE", "PRUNED", "FAIL")}


def _optuna() -> Any:
    try:
        import optuna
    except ImportError:
        raise ConfigError("--pose", "optuna", "tuning needs Optuna: pip install 'agvctl[tune]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


class _Runs:
    """The scenarios of one seed, drawn once, and their tasks for given settings."""

    def __init__(self, spec: FuzzSpec, controller: str, seed: int, count: int) -> None:
        self.spec = dataclasses.replace(spec, seed=seed, scenarios=count, controllers=(controller,))
        vehicle = load_vehicle(None if spec.vehicle == "default" else spec.vehicle)
        check_against_vehicle(self.spec, vehicle)
        self.controller = controller
        self.scenarios: list[Scenario] = [generate_scenario(self.spec, vehicle, i) for i in range(count)]

    def tasks(self, settings: Mapping[str, Any], part: Sequence[Scenario] | None = None) -> list[FuzzTask]:
        spec = dataclasses.replace(self.spec, controller=merged_settings(self.spec.controller, settings))
        return [
            FuzzTask(s.index, s.name, self.controller, tuple(scenario_files(spec, s, self.controller).items()))
            for s in (self.scenarios if part is None else part)
        ]


def _default_values(space: SearchSpace, spec: FuzzSpec) -> dict[str, float]:
    """The defaults of the searched settings (the fuzz file's keys over the settings dataclass's), where they lie
    inside their ranges."""
    kind_settings = ControllerSpec.from_file(
        {"pose": space.controller, **merged_settings(spec.pose_settings.get(space.controller, {}), spec.controller)},
        source=spec.source,
        prefix="controller",
    ).pose_settings
    out: dict[str, float] = {}
    for p in space.params:
        value: Any = kind_settings
        for part in p.name.split("."):
            value = getattr(value, part)
        if isinstance(value, (int, float)) and p.low <= value <= p.high:
            out[p.name] = int(value) if p.integer else float(value)
    return out


def _valid(runs: _Runs, settings: Mapping[str, Any]) -> bool:
    """Whether the drawn settings make a valid controller table (e.g. the governor's band in order)."""
    keys = merged_settings(
        merged_settings(runs.spec.pose_settings.get(runs.controller, {}), runs.spec.controller), settings
    )
    try:
        ControllerSpec.from_file({"pose": runs.controller, **keys}, source=runs.spec.source, prefix="controller")
    except ConfigError:
        return False
    return True


def _parts(scenarios: Sequence[Scenario]) -> list[Sequence[Scenario]]:
    n = len(scenarios)
    bounds = [round(i * n / CHUNKS) for i in range(CHUNKS + 1)]
    return [scenarios[a:b] for a, b in zip(bounds, bounds[1:], strict=False) if b > a]


def _objective(
    optuna: Any,
    runs: _Runs,
    space: SearchSpace,
    weights: ObjectiveWeights,
    pool: Executor,
    tick: Callable[[int], None],
) -> Callable[[Any], float]:
    def objective(trial: Any) -> float:
        values = {
            p.name: trial.suggest_int(p.name, int(p.low), int(p.high))
            if p.integer
            else trial.suggest_float(p.name, p.low, p.high, log=p.log)
            for p in space.params
        }
        settings = settings_table(values)
        if not _valid(runs, settings):
            tick(len(runs.scenarios))
            trial.set_user_attr("invalid", True)
            return weights.gate + 10.0 * (weights.cross_track_p90 + weights.cross_track_rms) + weights.time
        outcomes: list[FuzzOutcome] = []
        parts = _parts(runs.scenarios)
        for step, part in enumerate(parts):
            outcomes += run_fuzz_tasks(pool, runs.tasks(settings, part), lambda done, total: tick(1))
            figures = evaluate_objective(outcomes, weights)
            trial.set_user_attr("figures", figures.as_dict())
            if step < len(parts) - 1:
                trial.report(figures.value, step)
                if trial.should_prune():
                    tick(sum(len(p) for p in parts[step + 1 :]))
                    raise optuna.TrialPruned()
        return figures.value

    return objective


def _open_study(optuna: Any, storage: str | Path | None, name: str, setup: dict[str, Any], seed: int) -> Any:
    url = None
    if storage is not None:
        try:
            Path(storage).parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError("--study", str(storage), f"cannot create its folder: {exc.strerror}") from None
        url = f"sqlite:///{Path(storage).resolve()}"
    study = optuna.create_study(
        study_name=name,
        storage=url,
        direction="minimize",
        load_if_exists=True,
        pruner=optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=0),
    )
    held = {k: study.user_attrs.get(k) for k in setup}
    if study.trials and held != setup:
        changed = ", ".join(k for k in setup if held[k] != setup[k])
        raise ConfigError("--study", str(storage), f"holds a study of another setup ({changed}); use another file")
    for k, v in setup.items():
        study.set_user_attr(k, v)
    # a resumed study draws on from where it stopped, not the same settings again
    study.sampler = optuna.samplers.TPESampler(seed=seed + len(study.trials))
    return study


def _checked(
    spec: Any, controller: Any, trials: Any, validation_seed: Any, validation_scenarios: Any, storage: Any
) -> tuple[str, int]:
    """The controller to tune and the validation seed, every argument checked (one-line errors)."""
    if not isinstance(spec, FuzzSpec):
        raise ConfigError("tune_pose", "spec", f"expected a FuzzSpec (got {spec!r:.60})")
    controller = spec.controllers[0] if controller is None else controller
    if not isinstance(controller, str):
        raise ConfigError("tune_pose", "controller", f"expected a pose controller's name (got {controller!r:.60})")
    if storage is not None and not isinstance(storage, (str, Path)):
        raise ConfigError("tune_pose", "storage", f"expected a file path or None (got {storage!r:.60})")
    for flag, value, top in (("--trials", trials, 10000), ("--validation-scenarios", validation_scenarios, 100000)):
        if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= top:
            raise ConfigError(flag, "", f"must be an integer from 1 to {top} (got {value!r})")
    seed = spec.seed + 1 if validation_seed is None else validation_seed
    if isinstance(seed, bool) or not isinstance(seed, int) or seed == spec.seed or seed < 0:
        raise ConfigError("--validation-seed", "", f"must be an integer >= 0, not the training seed {spec.seed}")
    return controller, seed


class _Ticker:
    """Counts the runs done (a pruned trial's skipped runs too) for ``progress(done, total)``."""

    def __init__(self, total: int, progress: Callable[[int, int], None] | None) -> None:
        self.total, self.done, self.progress = total, 0, progress

    def __call__(self, n: int) -> None:
        self.done += n
        if self.progress is not None:
            self.progress(min(self.done, self.total), self.total)


def tune_pose(
    spec: FuzzSpec,
    *,
    controller: str | None = None,
    trials: int = 60,
    validation_seed: int | None = None,
    validation_scenarios: int = 200,
    jobs: int | None = None,
    executor: ExecutorKind = "local",
    scheduler: str | None = None,
    storage: str | Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> PoseTuningResult:
    """Search a pose controller's settings over the scenario distribution of ``spec`` (see the module notes).

    Parameters
    ----------
    spec : FuzzSpec
        From :func:`~agvctl.fuzz.spec.load_fuzz_config`: the training distribution (``seed``, ``scenarios``), its
        ``[search]`` space and ``[objective]`` weights.
    controller : str, optional
        The pose controller to tune (default: the first of ``spec.controllers``).
    trials : int
        Trials in all (those of a resumed study included), 1 to 10000.
    validation_seed : int, optional
        The held-out scenarios' seed (default: the training seed + 1; never the training seed).
    validation_scenarios : int
        How many held-out scenarios, 1 to 100000.
    jobs, executor, scheduler
        Where the runs go, as for :func:`~agvctl.fuzz.run.fuzz`.
    storage : str or Path, optional
        An SQLite file holding the study, resumed if it exists; None: in memory.
    progress : callable, optional
        Called as ``progress(done, total)`` in runs, the validation's included.

    Returns
    -------
    PoseTuningResult
        The study, the best settings, the validation and the settings to write.

    Raises
    ------
    ConfigError
        One line naming the file (or option) and key: a bad ``[search]`` or ``[objective]`` table, a controller
        without settings, an option out of range, a study file of another setup, Optuna not installed.
    """
    t0 = time.perf_counter()
    optuna = _optuna()
    controller, validation_seed = _checked(spec, controller, trials, validation_seed, validation_scenarios, storage)
    space = search_space(controller, spec.search, source=spec.source)
    weights = build(ObjectiveWeights, spec.objective, source=spec.source, prefix="objective")
    jobs = resolved_jobs(jobs, executor, scheduler, progress)
    training = _Runs(spec, controller, spec.seed, spec.scenarios)
    held_out = _Runs(spec, controller, validation_seed, validation_scenarios)
    setup = {"fuzz": spec.name, "controller": controller, "space": space.describe(), "seed": spec.seed}
    setup |= {"scenarios": spec.scenarios, "objective": weights.describe()}
    study = _open_study(optuna, storage, f"{spec.name}_{controller}", setup, spec.seed)
    todo = max(trials - len(study.trials), 0)
    defaults = _default_values(space, spec)
    if not study.trials and len(defaults) == len(space.params):
        study.enqueue_trial(defaults)
    tick = _Ticker(todo * spec.scenarios + 2 * validation_scenarios, progress)
    with open_executor(executor, jobs, scheduler, max(tick.total, 2), prepare=run_fuzz_tasks.__module__) as pool:
        if todo:
            study.optimize(_objective(optuna, training, space, weights, pool, tick), n_trials=todo)
        best_values = dict(study.best_trial.params)
        best = settings_table(best_values)
        outcomes = run_fuzz_tasks(pool, held_out.tasks({}) + held_out.tasks(best), lambda d, t: tick(1))
    on_defaults = evaluate_objective(outcomes[:validation_scenarios], weights)
    on_tuned = evaluate_objective(outcomes[validation_scenarios:], weights)
    kept = on_tuned.passed >= on_defaults.passed and on_tuned.value < on_defaults.value
    validation = Validation(validation_seed, validation_scenarios, on_defaults, on_tuned, kept)
    base = dict(spec.pose_settings.get(controller, {}))
    settings = merged_settings(base, best) if kept else base
    return PoseTuningResult(
        training.spec, space, weights, study, best_values, settings, validation, time.perf_counter() - t0
    )
