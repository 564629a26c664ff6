"""Acceptance measurements of ``agvctl falsify`` (not part of the test suite; figures in decision record 0039).

(a) The planted weakness (experiments/falsify/weak_braking.py): on each seed, the runs the search needs to falsify
    the gate within 100 runs, the verdicts the first falsifying scenario fails and those the default MPC fails on it
    (none: the planted weakness alone broke it), and the failures among 100 random scenarios of the same seed
    (``agvctl fuzz``).
(b) The default controller on the acceptance envelope (experiments/fuzz/acceptance.toml): on each seed, the
    smallest margin of 200 searched runs against that of 200 random scenarios of the same seed.

Run: python experiments/falsify_acceptance.py a --jobs 2   (then b)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from agvctl.falsify import falsify, searched_margin
from agvctl.fuzz import fuzz, load_fuzz_config
from agvctl.fuzz.generate import Scenario, scenario_files
from agvctl.fuzz.report import FuzzTask
from agvctl.fuzz.run import run_fuzz_task
from agvctl.fuzz.spec import FuzzSpec, override_fuzz_config

HERE = Path(__file__).parent


def _plain_mpc_failures(spec: FuzzSpec, scenario: Scenario) -> list[str]:
    """The verdicts the default MPC fails on a scenario: none where the planted weakness alone broke the run."""
    task = FuzzTask(scenario.index, scenario.name, "mpc", tuple(scenario_files(spec, scenario, "mpc").items()))
    outcome = run_fuzz_task(task)
    return [r.limit for r in outcome.limits if not r.passed] + ([outcome.error] if outcome.error else [])


def part_a(seeds: list[int], jobs: int, budget: int) -> dict[str, object]:
    spec = load_fuzz_config(HERE / "falsify" / "weak.toml")
    rows = []
    for seed in seeds:
        t0 = time.perf_counter()
        result = falsify(spec, budget_runs=budget, seed=seed, jobs=jobs)
        first = result.falsifying[0].run + 1 if result.falsified else None
        search_s = time.perf_counter() - t0
        report = fuzz(override_fuzz_config(spec, seed=seed, scenarios=budget), jobs=jobs)
        random_failures = sum(not o.passed for o in report.outcomes)
        random_min = min(searched_margin(o.limits) for o in report.outcomes)
        random_failed = sorted({r.limit for o in report.outcomes for r in o.limits if not r.passed})
        found = result.falsifying[0] if result.falsified else None
        rows.append(
            {
                "seed": seed,
                "search_runs_to_falsify": first,
                "search_min_margin": result.worst.margin,
                "search_falsified": None if found is None else (found.error or found.binding),
                "search_failed_verdicts": None
                if found is None
                else [v["name"] for v in found.verdicts if not v["passed"]],
                "plain_mpc_failed_verdicts": None if found is None else _plain_mpc_failures(spec, found.scenario),
                "search_start": None if found is None else found.scenario.initial_pose,
                "random_failures": random_failures,
                "random_falsified": random_failed,
                "random_min_margin": random_min,
                "search_s": search_s,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    found = sum(r["search_runs_to_falsify"] is not None for r in rows)
    print(
        f"(a) falsified within {budget} runs on {found} of {len(rows)} seeds; random failures at the same budget: "
        f"{[r['random_failures'] for r in rows]}"
    )
    return {"rows": rows, "falsified_seeds": found}


def part_b(seeds: list[int], jobs: int, budget: int) -> dict[str, object]:
    spec = load_fuzz_config(HERE / "fuzz" / "acceptance.toml")
    rows = []
    for seed in seeds:
        result = falsify(
            spec, budget_runs=budget, seed=seed, controller="mpc", jobs=jobs, baseline=True, stop_at_first=False
        )
        worst = result.worst
        rows.append(
            {
                "seed": seed,
                "search_min_margin": worst.margin,
                "random_min_margin": min(result.baseline_margins),
                "binding": worst.binding,
                "worst_params": worst.params,
                "importances": dict(list(result.importances.items())[:6]),
                "wall_time_s": result.wall_time_s,
                "run_time_s": result.run_time_s,
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    below = sum(r["search_min_margin"] < r["random_min_margin"] for r in rows)
    print(f"(b) search's smallest margin below random's on {below} of {len(rows)} seeds")
    return {"rows": rows, "below_random_seeds": below}


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("part", choices=("a", "b"))
    parser.add_argument("--seeds", default="1,2,3,4,5")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--budget", type=int, default=None)
    parser.add_argument("--json", default=None, help="write the rows to this file")
    args = parser.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    if args.part == "a":
        out = part_a(seeds, args.jobs, args.budget or 100)
    else:
        out = part_b(seeds, args.jobs, args.budget or 200)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2, default=str) + "\n")
