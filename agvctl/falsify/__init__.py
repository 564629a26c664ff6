"""Falsification: a search over a fuzz file's envelope for the scenario with the smallest requirement margin.

* :mod:`~agvctl.falsify.search` — the search: Optuna proposes the scenario generator's values, each scenario runs
  as ``agvctl fuzz`` runs it, the run's smallest normalised margin is minimised.
* :mod:`~agvctl.falsify.proposals` — where its scenarios come from: an Optuna trial's values, the samplers, the
  local moves around the runs closest to failing.
* :mod:`~agvctl.falsify.result` — what it found: each run, the whole search, the margin it minimises.
* :mod:`~agvctl.falsify.output` — what a search reports: the JSON, the readable summary, the figure.
* :mod:`~agvctl.falsify.page` — its HTML page (``agvctl falsify --html``), through :mod:`agvctl.htmlreport`.
"""

from agvctl.falsify.output import report_dict, search_figure, summary_text
from agvctl.falsify.page import falsify_html, write_falsify_html
from agvctl.falsify.search import (
    SAMPLERS,
    FalsifyResult,
    SearchRun,
    TrialDraws,
    check_falsify,
    falsify,
    searched_margin,
)

__all__ = [
    "SAMPLERS",
    "FalsifyResult",
    "SearchRun",
    "TrialDraws",
    "check_falsify",
    "falsify",
    "falsify_html",
    "report_dict",
    "search_figure",
    "searched_margin",
    "summary_text",
    "write_falsify_html",
]
