"""Where a search's scenarios come from: an Optuna trial's values (:class:`TrialDraws`), the samplers, and the local
moves around the runs closest to failing (:func:`local_moves`)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from agvctl.checks.report import TIMING_METRICS
from agvctl.errors import ConfigError

__all__ = ["LOCAL_AFTER", "LOCAL_CENTRES", "LOCAL_SHARE", "LOCAL_STEP", "LOCAL_VERDICTS", "SAMPLERS", "TrialDraws"]

SAMPLERS = ("tpe", "random", "cmaes")
"""The optimisers: Optuna's TPE (the default), random search over the same parameters, and CMA-ES (needs the
``cmaes`` package; the categorical parameters are then drawn at random)."""
LOCAL_SHARE = 0.75
"""The share of a batch (rounded down) proposed near the smallest margins so far rather than by TPE: three of a
batch of four, so TPE's model (about 50 ms a proposal over this space) is fitted once a batch."""
LOCAL_AFTER = 20
"""Finished runs before the local moves start: until then TPE's random start alone."""
LOCAL_CENTRES = 3
"""The runs with the smallest margins of a verdict the local moves start from."""
LOCAL_VERDICTS = 3
"""The verdicts whose smallest margins so far are least that the local moves start from."""
LOCAL_STEP = 0.15
"""A local move's step: the normal step's standard deviation as a share of a number's range, and the chance
that a choice is redrawn."""


class TrialDraws:
    """:class:`~agvctl.fuzz.generate.Draws` from an Optuna trial: each value one parameter of the trial, by its name.

    A range of one value and a single option are that value (no parameter); a chance strictly between 0 and 1 is a
    categorical parameter (both outcomes are in the envelope: the search may pick either).

    Parameters
    ----------
    trial : optuna.trial.Trial
        The trial.
    """

    def __init__(self, trial: Any) -> None:
        self.trial = trial

    def uniform(self, name: str, low: float, high: float) -> float:
        """``trial.suggest_float(name, low, high)``."""
        return float(low) if low == high else float(self.trial.suggest_float(name, float(low), float(high)))

    def integer(self, name: str, low: int, high: int) -> int:
        """``trial.suggest_int(name, low, high)``."""
        return int(low) if low == high else int(self.trial.suggest_int(name, int(low), int(high)))

    def choice(self, name: str, options: Sequence[str]) -> str:
        """``trial.suggest_categorical(name, options)`` (each option once)."""
        unique = list(dict.fromkeys(str(o) for o in options))
        return unique[0] if len(unique) == 1 else str(self.trial.suggest_categorical(name, unique))

    def chance(self, name: str, probability: float) -> bool:
        """Never for 0, always for 1, else ``trial.suggest_categorical(name, [False, True])``."""
        if probability <= 0.0 or probability >= 1.0:
            return probability >= 1.0
        return bool(self.trial.suggest_categorical(name, [False, True]))


def optuna_module() -> Any:
    try:
        import optuna
    except ImportError:
        raise ConfigError("falsify", "optuna", "the search needs Optuna: pip install 'agvctl[tune]'") from None
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    return optuna


def sampler_for(optuna: Any, name: str, seed: int, runs_done: int) -> Any:
    """The sampler of the batch after ``runs_done`` runs, seeded from (seed, runs_done) alone."""
    batch_seed = int(np.random.SeedSequence([seed, runs_done]).generate_state(1)[0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if name == "random":
            return optuna.samplers.RandomSampler(seed=batch_seed)
        if name == "cmaes":
            try:
                import cmaes  # noqa: F401
            except ImportError:
                raise ConfigError("--sampler", "cmaes", "needs the cmaes package: pip install cmaes") from None
            return optuna.samplers.CmaEsSampler(seed=batch_seed, warn_independent_sampling=False)
        return optuna.samplers.TPESampler(
            seed=batch_seed, multivariate=True, group=True, constant_liar=True, n_startup_trials=LOCAL_AFTER
        )


def _verdict_margins(trial: Any, requirement: str | None) -> dict[str, float]:
    """A finished run's searched verdicts' normalised margins, by name (a non-finite one is left out)."""
    out = {}
    for v in trial.user_attrs.get("verdicts", ()):
        m = v["normalised_margin"]
        searched = v["name"] == requirement if requirement is not None else v["name"] not in TIMING_METRICS
        if searched and m is not None and math.isfinite(m):
            out[str(v["name"])] = float(m)
    return out


def _centres(complete: list[Any], requirement: str | None) -> list[list[Any]]:
    """For each of the :data:`LOCAL_VERDICTS` verdicts with the smallest margins so far, its
    :data:`LOCAL_CENTRES` runs with the smallest margins of that verdict (the runs with the smallest margin of
    all are the first verdict's)."""
    margins = [(t, _verdict_margins(t, requirement)) for t in complete]
    best: dict[str, float] = {}
    for _t, ms in margins:
        for name, m in ms.items():
            best[name] = min(m, best.get(name, math.inf))
    verdicts = sorted(best, key=lambda name: (best[name], name))[:LOCAL_VERDICTS]
    return [
        [t for t, ms in sorted(((t, ms) for t, ms in margins if v in ms), key=lambda p: (p[1][v], p[0].number))][
            :LOCAL_CENTRES
        ]
        for v in verdicts
    ]


def local_moves(
    optuna: Any, study: Any, sampler: str, seed: int, runs_done: int, n: int, requirement: str | None
) -> list[dict[str, Any]]:
    """Proposals near the smallest margins so far, for a share :data:`LOCAL_SHARE` of a batch (TPE only, after
    :data:`LOCAL_AFTER` runs), asked through a random sampler: a value a move does not fix (a segment a move to a
    larger count adds) is drawn at random, and no model is fitted for a proposal whose values are given.
    Each starts from a run drawn at random among the :data:`LOCAL_CENTRES` with the
    smallest margins of one verdict, itself drawn among the :data:`LOCAL_VERDICTS` whose margins have come
    closest to failing: the smallest margin of a run hides how close its other verdicts come, and one of those may
    be the one that can fail. Every other move is a step: each number moved by a normal step of :data:`LOCAL_STEP`
    of its range and clipped to it, each choice redrawn with probability :data:`LOCAL_STEP`; the others go towards
    the faces: each number moved a uniform fraction of the way to its nearer bound, the choices kept (the
    envelope's corners are where margins are least). Seeded from (seed, runs done)."""
    complete = study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.COMPLETE,))
    if sampler != "tpe" or len(complete) < LOCAL_AFTER:
        return []
    groups = _centres(complete, requirement)
    if not groups:
        return []
    rng = np.random.default_rng([seed, runs_done, 1])
    moves = []
    for k in range(int(LOCAL_SHARE * n)):
        group = groups[int(rng.integers(len(groups)))]
        centre = group[int(rng.integers(len(group)))]
        towards_faces = k % 2 == 1
        params: dict[str, Any] = {}
        for name, dist in centre.distributions.items():
            value = centre.params[name]
            if isinstance(dist, optuna.distributions.CategoricalDistribution):
                redraw = not towards_faces and rng.random() < LOCAL_STEP
                params[name] = dist.choices[int(rng.integers(len(dist.choices)))] if redraw else value
                continue
            if towards_faces:
                face = dist.low if value - dist.low < dist.high - value else dist.high
                moved = value + rng.random() * (face - value)
            else:
                moved = value + rng.normal(0.0, LOCAL_STEP * (dist.high - dist.low))
            moved = float(np.clip(moved, dist.low, dist.high))
            params[name] = int(round(moved)) if isinstance(dist, optuna.distributions.IntDistribution) else moved
        moves.append(params)
    return moves
