"""Tuning a pose controller on the scenarios it will meet: a search of its settings over a fuzz distribution.

* :mod:`~agvctl.tuning.space` — which settings, over which ranges (a fuzz file's ``[search.<controller>]``).
* :mod:`~agvctl.tuning.objective` — what the settings are judged by: the gate first, then cross-track, then time.
* :mod:`~agvctl.tuning.study` — the search (Optuna's seeded TPE, pruning) and the validation on held-out scenarios.
* :mod:`~agvctl.tuning.output` — the settings file, the report and the figures.

From Python::

    spec = load_fuzz_config("experiments/fuzz/heavy.toml")
    result = tune_pose(spec, trials=60, jobs=2, storage="study.db")
    print(summary_text(result))
    Path("tuned.toml").write_text(settings_text(result))

Optuna is the optional ``tune`` extra: ``pip install 'agvctl[tune]'``.
"""

from agvctl.tuning.objective import ObjectiveValue, ObjectiveWeights, evaluate_objective
from agvctl.tuning.output import result_dict, settings_text, summary_text, tuning_figures
from agvctl.tuning.space import DEFAULT_SPACES, SearchParam, SearchSpace, search_space
from agvctl.tuning.study import PoseTuningResult, Validation, tune_pose

__all__ = [
    "DEFAULT_SPACES",
    "ObjectiveValue",
    "ObjectiveWeights",
    "PoseTuningResult",
    "SearchParam",
    "SearchSpace",
    "Validation",
    "evaluate_objective",
    "result_dict",
    "search_space",
    "settings_text",
    "summary_text",
    "tune_pose",
    "tuning_figures",
]
