"""Signal temporal logic with robustness: the evaluator against its definition, sample by sample."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from agvctl.evaluation import formula as stl
from agvctl.evaluation.formula import FormulaError, comparisons, parse_formula
from agvctl.evaluation.stl import Trace, robustness

FORMULAS = (
    "always x_m <= 0.5",
    "eventually[0.2, 0.6] abs(y_m) >= 0.3",
    "always[0.1, 0.5] (x_m <= 0.4 or y_m >= 0.1)",
    "eventually[0, 1] always x_m <= 0.6",
    "always flag -> x_m <= 0.3",
    "x_m <= 0.7 until[0.2, 0.9] y_m >= 0.5",
    "x_m <= 0.8 until y_m >= 0.9",
    "not always[0.3, inf] x_m >= 0.05 and y_m <= 2",
    "always[0.35, 0.35] x_m <= 0.5",
)


def _definition(f: stl.Formula, x: dict[str, np.ndarray], flag: np.ndarray, t: np.ndarray, k: int) -> float:
    """Space robustness straight from its definition (Donzé and Maler), over every sample of each window."""
    if isinstance(f, stl.Comparison):
        v = abs(x[f.signal][k]) if f.absolute else x[f.signal][k]
        return f.constant - v if f.op == "<=" else v - f.constant
    if isinstance(f, stl.Atom):
        return math.inf if flag[k] else -math.inf
    if isinstance(f, stl.Not):
        return -_definition(f.child, x, flag, t, k)
    if isinstance(f, stl.Junction):
        values = [_definition(c, x, flag, t, k) for c in f.children]
        return min(values) if f.op == "and" else max(values)
    lo, hi = f.window_s
    inside = [j for j in range(len(t)) if lo - 1e-9 <= t[j] - t[k] <= hi + 1e-9]
    if isinstance(f, stl.Temporal):
        values = [_definition(f.child, x, flag, t, j) for j in inside]
        return min(values, default=math.inf) if f.op == "always" else max(values, default=-math.inf)
    return max(
        (
            min(_definition(f.right, x, flag, t, j), min(_definition(f.left, x, flag, t, i) for i in range(k, j + 1)))
            for j in inside
        ),
        default=-math.inf,
    )


@pytest.mark.parametrize("text", FORMULAS)
def test_the_robustness_at_every_sample_is_its_definition_and_its_witness_decides_it(text):
    rng = np.random.default_rng(7)
    formula = parse_formula(text)
    for _ in range(12):
        n = int(rng.integers(1, 25))
        t = np.arange(n) * 0.1
        x = {"x_m": rng.random(n), "y_m": rng.random(n) - 0.2}
        flag = rng.random(n) > 0.5
        r = robustness(formula, Trace(t, lambda name, x=x: x[name], lambda atom, flag=flag: flag))
        leaves = comparisons(formula)
        for k in range(n):
            assert r.value[k] == pytest.approx(_definition(formula, x, flag, t, k), abs=1e-12)
            if r.leaf[k] >= 0:
                c = leaves[r.leaf[k]]
                v = abs(x[c.signal][r.sample[k]]) if c.absolute else x[c.signal][r.sample[k]]
                assert abs(c.constant - v) == pytest.approx(abs(r.value[k]), abs=1e-12)


def test_a_nan_sample_breaks_the_comparison_on_it():
    t = np.arange(4) * 0.1
    x = np.array([0.0, np.nan, 0.0, 0.0])
    r = robustness(parse_formula("always x_m <= 1"), Trace(t, lambda name: x, lambda atom: np.ones(4, bool)))
    assert r.value[0] == -math.inf and r.sample[0] == 1


def test_temporal_operators_reach_as_far_right_as_they_can():
    assert parse_formula("always a -> x_m <= 1") == parse_formula("always (a -> x_m <= 1)")
    assert parse_formula("(always x_m <= 1) and y_m <= 2") != parse_formula("always x_m <= 1 and y_m <= 2")


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("always x_m <=", "expected a number at the end"),
        ("always[1, 0] x_m <= 1", "0 <= lo <= hi"),
        ("abs(x_m)", "expected <= or >= after abs(x_m)"),
        ("x_m <= 1 )", "unexpected ')' at character 10"),
        ("on_segment(1.5)", "expected an integer"),
        ("", "expected a formula"),
    ],
)
def test_a_formula_that_does_not_parse_says_where(text, says):
    with pytest.raises(FormulaError, match=re.escape(says)):
        parse_formula(text)


def test_a_window_with_no_end_takes_the_minimum_and_the_earliest_witness_of_a_window_to_the_last_sample():
    rng = np.random.default_rng(11)
    for _ in range(40):
        n = int(rng.integers(1, 30))
        t = np.arange(n) * 0.1
        x = rng.integers(0, 4, n) * 0.1  # ties
        x[rng.random(n) < 0.1] = np.inf
        trace = Trace(t, lambda name, x=x: x, lambda atom, n=n: np.ones(n, dtype=bool))
        lo = float(rng.integers(0, 4)) * 0.1
        open_ended = robustness(parse_formula(f"always[{lo:.1f}, inf] x_m <= 0.5"), trace)
        to_last = robustness(parse_formula(f"always[{lo:.1f}, {n * 0.1 + 1:.1f}] x_m <= 0.5"), trace)
        assert np.array_equal(open_ended.value, to_last.value)
        assert np.array_equal(open_ended.sample, to_last.sample)
        assert np.array_equal(open_ended.leaf, to_last.leaf)
