"""What a pose-controller search writes: the settings file (with how it was obtained), the report, the figures."""

from __future__ import annotations

import io
import warnings
from typing import Any

from agvctl.config import dump_toml
from agvctl.errors import ConfigError
from agvctl.tuning.objective import ObjectiveValue
from agvctl.tuning.study import PoseTuningResult

__all__ = ["IMPORTANCE_MIN_TRIALS", "importances", "result_dict", "settings_text", "summary_text", "tuning_figures"]

IMPORTANCE_MIN_TRIALS = 20
"""Finished trials below which the importances are reported as rough: fANOVA fits a random forest to the trials,
and over a handful of them the shares follow the few values drawn more than the objective."""


def importances(result: PoseTuningResult) -> dict[str, float]:
    """Each searched setting's share of the objective's variance over the finished trials (Optuna's fANOVA).

    Parameters
    ----------
    result : PoseTuningResult
        From :func:`~agvctl.tuning.study.tune_pose`.

    Returns
    -------
    dict of str to float
        The shares by setting, largest first; empty with fewer than two finished trials.
    """
    import optuna

    finished = [t for t in result.study.trials if t.state.name == "COMPLETE"]
    if len(finished) < 2:
        return {}
    try:
        return {k: float(v) for k, v in optuna.importance.get_param_importances(result.study).items()}
    except (RuntimeError, ValueError):  # e.g. every finished trial drew the same values
        return {}


def _row(label: str, v: ObjectiveValue) -> str:
    mm = [1e3 * x for x in (v.cross_track_p50_m, v.cross_track_p90_m, v.cross_track_max_m, v.cross_track_rms_m)]
    return (
        f"  {label:<9}{v.value:>9.3f}{f'{v.passed}/{v.runs}':>10}{mm[0]:>8.1f}{mm[1]:>8.1f}{mm[2]:>8.1f}"
        f"{mm[3]:>8.1f}{v.time_ratio:>8.3f}"
    )


def _verdict(result: PoseTuningResult) -> str:
    v = result.validation
    if v.kept:
        return f"kept the tuned settings: J {v.defaults.value:.3f} → {v.tuned.value:.3f} on validation"
    why = "fewer gate passes" if v.tuned.passed < v.defaults.passed else "no lower objective"
    return f"nothing better than the defaults on validation ({why}): wrote the defaults"


def summary_text(result: PoseTuningResult) -> str:
    """The readable report: the search, defaults against tuned on the validation scenarios, the verdict, and how
    much each setting mattered.

    Parameters
    ----------
    result : PoseTuningResult
        From :func:`~agvctl.tuning.study.tune_pose`.

    Returns
    -------
    str
        The report, lines of text.
    """
    c = result.trial_counts()
    v = result.validation
    spec = result.spec
    lines = [
        f"tune {result.controller} on {spec.name}: {len(result.study.trials)} trials ({c['complete']} finished, "
        f"{c['pruned']} pruned) over {spec.scenarios} scenarios of seed {spec.seed} in {result.wall_time_s:.0f} s",
        f"  space: {result.space.describe()}",
        f"  objective: {result.weights.describe()}",
        f"validation: {v.scenarios} scenarios of seed {v.seed}",
        f"  {'':<9}{'J':>9}{'passed':>10}{'p50 mm':>8}{'p90 mm':>8}{'max mm':>8}{'rms mm':>8}{'time':>8}",
        _row("defaults", v.defaults),
        _row("tuned", v.tuned),
        _verdict(result),
        "  best: " + ", ".join(f"{k} = {val:.4g}" for k, val in result.best_values.items()),
    ]
    shares = importances(result)
    if shares:
        lines.append("  importance: " + ", ".join(f"{k} {100 * s:.0f} %" for k, s in shares.items()))
        if c["complete"] < IMPORTANCE_MIN_TRIALS:
            lines.append(
                f"  (from {c['complete']} finished trials: too few to rank the settings; {IMPORTANCE_MIN_TRIALS} or "
                "more advised)"
            )
    return "\n".join(lines)


def result_dict(result: PoseTuningResult) -> dict[str, Any]:
    """The report as plain data, for ``report.json``.

    Parameters
    ----------
    result : PoseTuningResult
        From :func:`~agvctl.tuning.study.tune_pose`.

    Returns
    -------
    dict
        The search, the best settings, the validation and the importances.
    """
    v = result.validation
    return {
        "fuzz": result.spec.name,
        "controller": result.controller,
        "training": {"seed": result.spec.seed, "scenarios": result.spec.scenarios},
        "trials": result.trial_counts(),
        "space": [p.describe() for p in result.space.params],
        "objective": result.weights.describe(),
        "best": result.best_values,
        "validation": {
            "seed": v.seed,
            "scenarios": v.scenarios,
            "defaults": v.defaults.as_dict(),
            "tuned": v.tuned.as_dict(),
            "kept": v.kept,
        },
        "importance": importances(result),
        "settings": result.settings,
        "wall_time_s": result.wall_time_s,
    }


def settings_text(result: PoseTuningResult, command: str = "") -> str:
    """The settings file: ``pose`` and the tuned keys (none if the defaults won), behind a header saying how they
    were obtained, for ``[controller] pose_settings = "FILE"`` or a fuzz file's ``[pose_settings]``.

    Parameters
    ----------
    result : PoseTuningResult
        From :func:`~agvctl.tuning.study.tune_pose`.
    command : str
        The command that ran the search, for the header (none if empty).

    Returns
    -------
    str
        The file's TOML text.

    Raises
    ------
    ConfigError
        ``settings_text: <argument>: <problem>`` for arguments of the wrong type.
    """
    if not isinstance(result, PoseTuningResult):
        raise ConfigError("settings_text", "result", f"expected a PoseTuningResult (got {result!r:.60})")
    if not isinstance(command, str):
        raise ConfigError("settings_text", "command", f"expected a string (got {command!r:.60})")
    v = result.validation
    c = result.trial_counts()
    header = [
        f"Settings of the {result.controller!r} pose controller, searched by agvctl tune --pose",
        *([f"command: {command}"] if command else []),
        f"fuzz distribution: {result.spec.source} ({result.spec.name})",
        f"space: {result.space.describe()}",
        f"trials: {len(result.study.trials)} ({c['complete']} finished, {c['pruned']} pruned), seeded TPE "
        f"(seed {result.spec.seed}), training on {result.spec.scenarios} scenarios of seed {result.spec.seed}",
        f"objective: {result.weights.describe()}",
        f"validation on {v.scenarios} scenarios of seed {v.seed}:",
        f"  defaults {v.defaults.describe()}",
        f"  tuned    {v.tuned.describe()}",
        _verdict(result),
        'use: [controller] pose_settings = "<this file>"',
    ]
    return dump_toml({"pose": result.controller, **result.settings}, header="\n".join(header))


def tuning_figures(result: PoseTuningResult) -> dict[str, bytes]:
    """The search's figures, drawn by Optuna's matplotlib plots.

    Parameters
    ----------
    result : PoseTuningResult
        From :func:`~agvctl.tuning.study.tune_pose`.

    Returns
    -------
    dict of str to bytes
        ``history.png`` (the objective of each trial and the best so far, on a log axis, so that one diverged
        trial does not flatten the others) and, with two or more finished trials, ``importance.png`` (each
        setting's share), as PNG bytes.
    """
    import matplotlib
    import matplotlib.pyplot as plt
    import optuna

    out: dict[str, bytes] = {}
    # Optuna's plots set matplotlib's global style (ggplot): restored on leaving, the user's style is left alone
    with warnings.catch_warnings(), matplotlib.rc_context():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        plots: list[tuple[str, Any]] = [("history.png", optuna.visualization.matplotlib.plot_optimization_history)]
        if importances(result):
            plots.append(("importance.png", optuna.visualization.matplotlib.plot_param_importances))
        for name, plot in plots:
            ax = plot(result.study)
            values = [t.value for t in result.study.trials if t.value is not None]
            if name == "history.png" and values and min(values) > 0:
                ax.set_yscale("log")  # a diverged trial's J would flatten the rest
            fig: Any = ax.figure
            fig.set_size_inches(8, 4.5)
            fig.tight_layout()
            buffer = io.BytesIO()
            fig.savefig(buffer, format="png", dpi=80)
            plt.close(fig)
            out[name] = buffer.getvalue()
    return out
