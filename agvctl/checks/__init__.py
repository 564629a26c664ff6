"""Checks: an experiment's limits evaluated on its run, for `agvctl run` and the `agvctl check` CI gate."""

from agvctl.evaluation.limits import LimitResult, all_passed, evaluate_limits

__all__ = ["LimitResult", "all_passed", "evaluate_limits"]
