"""How often the default controller keeps a path's body limits, as the payload's accelerometer reads them.

Random gentle scenarios: the acceptance fuzz's paths, plants and starts (``experiments/fuzz/acceptance.toml``), each
path's ``[limits]`` replaced by random body limits (linear and lateral 0.2-0.5 m/s², angular 0.5-1.5 rad/s²) that
the planner plans within. A run keeps them when the accelerometer's peaks (``peak_body_linear_accel_m_s2``,
``peak_body_lateral_accel_m_s2``, ``peak_body_angular_accel_rad_s2``, at the axle's midpoint, 2.5 Hz) are within
them, and passes the default gate when it passes every default limit, the body's included. ``--on-path`` starts
every run on its path on the nominal plant, to separate the start-up corrections and the plant's spread from the
rest; ``--plan-share`` sets the paths' ``limits.body_plan_share`` (1.0: the plan uses the whole limits, as a
controller that ignores them would). It also counts the runs that keep the limits judged away from held wheels
(the signal ``wheel_held`` of :mod:`agvctl.evaluation.payload`: a wheel slower than 1 cm/s or held back by its
loop's current window or the amplifier's limit, and the 0.4 s after), the criterion record 0041 proposes.
Figures in decision record 0041.

Run: python experiments/payload_keep.py --seed 4242 --runs 40 [--on-path] [--controller mpc] [--plan-share 0.7]
                                        [--controller-set body_breakaway_share=1.0]
"""

from __future__ import annotations

import argparse
import tempfile
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from agvctl.evaluation.limits import judge_run
from agvctl.evaluation.payload import HELD_WHEEL_SPEED_M_S, RECOVERY_S, wheel_held
from agvctl.fuzz import generate_scenario, load_fuzz_config
from agvctl.fuzz.generate import scenario_files
from agvctl.fuzz.spec import override_fuzz_config
from agvctl.params import load_vehicle
from agvctl.scenario.experiment import load_experiment, run_experiment

HERE = Path(__file__).parent
PEAKS = {
    "linear": ("peak_body_linear_accel_m_s2", "linear_accel_m_s2"),
    "lateral": ("peak_body_lateral_accel_m_s2", "lateral_accel_m_s2"),
    "angular": ("peak_body_angular_accel_rad_s2", "angular_accel_rad_s2"),
}
READINGS = {
    "linear": "body_linear_accel_m_s2",
    "lateral": "body_lateral_accel_m_s2",
    "angular": "body_angular_accel_rad_s2",
}


def away_from_held_wheels(log: Any, limits: dict[str, float], ts: float) -> tuple[float, float]:
    """(the largest reading over its limit, judged away from held wheels and their recoveries; the share of the
    run's samples left out): the criterion proposed in decision record 0041."""
    left_out = wheel_held(log, ts) > 0
    worst = max(
        np.max(np.abs(np.asarray(log[READINGS[what]])[~left_out]), initial=0.0) / limits[key]
        for what, (_, key) in PEAKS.items()
    )
    return float(worst), float(left_out.mean())


def gentle_runs(
    seed: int,
    runs: int,
    on_path: bool,
    controller: str,
    plan_share: float | None = None,
    controller_options: dict[str, Any] | None = None,
) -> list[dict[str, float]]:
    """Each run's peaks over its body limits, and whether it passed the default gate."""
    spec = override_fuzz_config(load_fuzz_config(HERE / "fuzz" / "acceptance.toml"), seed=seed)
    vehicle, rng, rows = load_vehicle(None), np.random.default_rng(seed), []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        for index in range(runs):
            files = scenario_files(spec, generate_scenario(spec, vehicle, index), controller)
            path_name = next(n for n in files if n.endswith(".path.toml"))
            exp_name = next(n for n in files if n != path_name)
            linear, angular = float(rng.uniform(0.2, 0.5)), float(rng.uniform(0.5, 1.5))
            limits = {"linear_accel_m_s2": linear, "lateral_accel_m_s2": linear, "angular_accel_rad_s2": angular}
            path = tomllib.loads(files[path_name])
            path["limits"] = limits if plan_share is None else {**limits, "body_plan_share": plan_share}
            experiment = tomllib.loads(files[exp_name])
            experiment["controller"] |= controller_options or {}
            if on_path:
                experiment["plant"] = {"sensor_seed": experiment["plant"]["sensor_seed"]}
            (tmp / path_name).write_text(tomli_w.dumps(path), encoding="utf-8")
            (tmp / exp_name).write_text(tomli_w.dumps(experiment), encoding="utf-8")
            loaded = load_experiment(tmp / exp_name)
            result = run_experiment(loaded)
            verdict = judge_run(result, loaded.spec.limits, loaded.controller_vehicle)
            row = {what: verdict.metrics[metric] / limits[key] for what, (metric, key) in PEAKS.items()}
            row["gate"] = float(all(r.passed for r in verdict.limits))
            row["gate_else"] = float(all(r.passed for r in verdict.limits if not r.limit.startswith("peak_body_")))
            row["away"], row["left_out"] = away_from_held_wheels(result.log, limits, result.sample_period_s)
            rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=4242)
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--on-path", action="store_true", help="start on the path, on the nominal plant")
    parser.add_argument("--controller", default="mpc")
    parser.add_argument("--plan-share", type=float, default=None, help="the paths' limits.body_plan_share")
    parser.add_argument(
        "--controller-set", action="append", default=[], metavar="KEY=VALUE", help="a [controller] option (a number)"
    )
    args = parser.parse_args()
    options = {k: float(v) for k, v in (item.split("=", 1) for item in args.controller_set)}
    rows = gentle_runs(args.seed, args.runs, args.on_path, args.controller, args.plan_share, options)
    ratios = np.array([[r[w] for w in PEAKS] for r in rows])
    worst = ratios.max(axis=1)
    print(f"seed {args.seed}, {len(rows)} runs of {args.controller}{' from the path' if args.on_path else ''}:")
    print(f"  kept all three body limits: {int(np.sum(worst <= 1.0))}; within 10 %: {int(np.sum(worst <= 1.1))}")
    for j, what in enumerate(PEAKS):
        print(f"  {what:8s} peak / limit: median {np.median(ratios[:, j]):.2f}, largest {ratios[:, j].max():.2f}")
    print(f"  passed the default gate: {int(sum(r['gate'] for r in rows))}")
    away, left_out = np.array([r["away"] for r in rows]), np.array([r["left_out"] for r in rows])
    print(
        f"  kept away from held wheels (below {HELD_WHEEL_SPEED_M_S * 100:g} cm/s or held back by a limit, and "
        f"{RECOVERY_S:g} s after): {int(np.sum(away <= 1.0))}; samples left out: median "
        f"{np.median(left_out):.0%}, largest {left_out.max():.0%}"
    )
    print(
        "  passed the default gate with the body's limits judged away from held wheels: "
        f"{int(sum(r['gate_else'] and r['away'] <= 1.0 for r in rows))}"
    )


if __name__ == "__main__":
    main()
