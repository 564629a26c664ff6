"""The planned path against the drawn one: on the shipped paths and on random segment and waypoint paths, how far the
planner leaves the drawn path at a few tolerances, what the tolerance costs in path duration and planning time, and
whether the reported distance ever exceeds the tolerance (design record 0038).

Run: ``PYTHONPATH=. python experiments/drawn_path_acceptance.py [--paths 200] [--seed 38] [--write-paths DIR]``.

Each path is planned once without a bound (a tolerance of 1 m, above any deviation the joins make) and once per
tolerance; the reported
``drawn_path_deviation_m`` is checked against the tolerance, and against an independent measure: the reference
sampled every millisecond, each point's distance to the drawn path. ``--write-paths DIR`` writes every path as a
path file (the random ones too) for ``experiments/benchmarks/plan_folder.py``, which times another version of the
planner on the same files.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from agvctl.errors import ConfigError
from agvctl.fuzz.generate import generate_scenario
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.params import load_vehicle
from agvctl.planning import PathSpec, Reference, Waypoint, load_path, plan
from agvctl.planning.spec import DRAWN_PATH_TOLERANCE_M

ROOT = Path(__file__).resolve().parent.parent
TOLERANCES_M = (0.001, 0.002, 0.005, 0.01, 0.02)
UNBOUNDED_M = 1.0


def shipped_paths() -> list[PathSpec]:
    """Every path file under trajectories/ and experiments/ (files that are not path files are skipped)."""
    out = []
    for file in sorted([*ROOT.glob("trajectories/**/*.toml"), *ROOT.glob("experiments/**/*.toml")]):
        try:
            out.append(load_path(file))
        except ConfigError:
            continue
    return out


def random_segment_paths(count: int, seed: int) -> list[PathSpec]:
    """Paths of the acceptance fuzz's generator (2-6 lines, arcs and turns), all with smooth joins."""
    spec = dataclasses.replace(load_fuzz_config(ROOT / "experiments" / "fuzz" / "acceptance.toml"), seed=seed)
    vehicle = load_vehicle()
    out = []
    for i in range(count):
        path = generate_scenario(spec, vehicle, i).path
        out.append(dataclasses.replace(load_path(_written(path)), join="smooth"))
    return out


def _written(data: dict[str, object]) -> Path:
    """The path file of a drawn path's data, in the temporary folder (the loader reads files)."""
    from agvctl.config import dump_toml

    file = Path(tempfile.gettempdir()) / f"drawn-path-acceptance-{data['name']}.toml"
    file.write_text(dump_toml(data), encoding="utf-8")
    return file


def random_waypoint_paths(count: int, seed: int) -> list[PathSpec]:
    """Paths of 3-8 waypoints, each 0.4-3 m on from the last and turned by up to ±120° from the way there, the
    first heading given and each other with probability 0.3; a path the planner refuses as a cusp is drawn again."""
    rng = np.random.default_rng([seed, 1])
    out: list[PathSpec] = []
    while len(out) < count:
        n = int(rng.integers(3, 9))
        x, y, heading = 0.0, 0.0, 0.0
        points = [Waypoint(x_m=0.0, y_m=0.0, theta_deg=0.0)]
        for _ in range(n - 1):
            heading += math.radians(float(rng.uniform(-120.0, 120.0)))
            step = float(rng.uniform(0.4, 3.0))
            x, y = round(x + step * math.cos(heading), 3), round(y + step * math.sin(heading), 3)
            given = rng.random() < 0.3
            theta = round(math.degrees(heading) + float(rng.uniform(-20.0, 20.0)), 1) if given else None
            points.append(Waypoint(x_m=x, y_m=y, theta_deg=theta))
        spec = PathSpec(waypoints=tuple(points), name=f"waypoints-{len(out)}")
        try:
            plan(spec)
        except ConfigError:
            continue
        out.append(spec)
    return out


def write_paths(folder: Path, specs: list[PathSpec]) -> None:
    """Each path as a path file of the default tolerance (numbered, in the order given)."""
    from agvctl.config import dump_toml

    folder.mkdir(parents=True, exist_ok=True)
    for i, spec in enumerate(specs):
        data: dict[str, object] = {"name": spec.name, "join": spec.join}
        limits = {k: v for k, v in dataclasses.asdict(spec.limits).items() if v is not None}
        limits.pop("drawn_path_tolerance_m")
        if limits:
            data["limits"] = limits
        if spec.waypoints:
            data["waypoints"] = [
                {k: v for k, v in dataclasses.asdict(w).items() if v is not None} for w in spec.waypoints
            ]
        else:
            start = dataclasses.asdict(spec.start)
            if any(start.values()):
                data["start"] = start
            data["segments"] = [
                {k: v for k, v in dataclasses.asdict(s).items() if v is not None} for s in spec.segments
            ]
        (folder / f"{i:03d}.toml").write_text(dump_toml(data), encoding="utf-8")


def dense_deviation_m(reference: Reference) -> float:
    """The largest distance to the drawn path of the reference sampled every millisecond."""
    assert reference.drawn_path is not None
    t = np.arange(0.0, reference.duration_s, 1e-3)
    s = reference.sample(t)
    return float(np.nanmax(reference.drawn_path.distance_m(s.x_m, s.y_m)))


def with_tolerance(spec: PathSpec, tolerance_m: float) -> PathSpec:
    return dataclasses.replace(spec, limits=dataclasses.replace(spec.limits, drawn_path_tolerance_m=tolerance_m))


def measure(group: str, specs: list[PathSpec], dense: bool) -> bool:
    vehicle = load_vehicle()
    rows = {}
    ok = True
    for tol in (UNBOUNDED_M, *TOLERANCES_M):
        duration, planning, worst_ratio, worst_dense, over, refused, deviations = 0.0, 0.0, 0.0, 0.0, 0, 0, []
        for spec in specs:
            start = time.perf_counter()
            try:
                ref = plan(with_tolerance(spec, tol), vehicle)
            except ConfigError as exc:
                refused += 1
                print(f"  refused at {tol * 1e3:g} mm: {exc}", file=sys.stderr)
                continue
            planning += time.perf_counter() - start
            duration += ref.duration_s
            deviations.append(ref.drawn_path_deviation_m)
            worst_ratio = max(worst_ratio, ref.drawn_path_deviation_m / tol)
            over += ref.drawn_path_deviation_m > tol
            if dense and tol != UNBOUNDED_M:
                d = dense_deviation_m(ref)
                worst_dense = max(worst_dense, d / tol)
        rows[tol] = (duration, planning, worst_ratio, worst_dense, over, refused, deviations)
        ok = ok and over == 0 and refused == 0
    base_duration, base_planning = rows[UNBOUNDED_M][0], rows[UNBOUNDED_M][1]
    devs = np.array(rows[UNBOUNDED_M][6])
    print(
        f"\n{group}: {len(specs)} paths; unbounded deviation: median {np.median(devs) * 1e3:.2f} mm, "
        f"p90 {np.percentile(devs, 90) * 1e3:.2f} mm, max {devs.max() * 1e3:.2f} mm, "
        f"{np.count_nonzero(devs > 0)} off it at all"
    )
    print(
        "  tolerance   duration (sum)   vs unbounded   planning (sum)  vs unbounded  "
        "max dev/tol  dense/tol  over  refused"
    )
    for tol, (duration, planning, ratio, dense_ratio, over, refused, _) in rows.items():
        label = "unbounded" if tol == UNBOUNDED_M else f"{tol * 1e3:g} mm"
        default = " (default)" if tol == DRAWN_PATH_TOLERANCE_M else ""
        print(
            f"  {label + default:19s} {duration:9.2f} s   {100 * (duration / base_duration - 1):+7.2f} %  "
            f"{planning:10.2f} s  {100 * (planning / base_planning - 1):+8.1f} %  {ratio:10.4f}  "
            f"{dense_ratio:9.4f}  {over:4d}  {refused:4d}"
        )
    return ok


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--paths", type=int, default=200, help="random paths, half of segments, half of waypoints")
    parser.add_argument("--seed", type=int, default=38)
    parser.add_argument("--no-dense", action="store_true", help="skip the independent millisecond check")
    parser.add_argument("--write-paths", type=Path, default=None, metavar="DIR", help="write every path file here")
    args = parser.parse_args(argv)
    groups = {
        "shipped paths": shipped_paths(),
        "random segment paths": random_segment_paths(args.paths // 2, args.seed),
        "random waypoint paths": random_waypoint_paths(args.paths - args.paths // 2, args.seed),
    }
    if args.write_paths is not None:
        write_paths(args.write_paths, [spec for specs in groups.values() for spec in specs])
    ok = True
    for group, specs in groups.items():
        ok &= measure(group, specs, not args.no_dense)
    print("\nthe reported distance never exceeds the tolerance" if ok else "\nSOME PATH EXCEEDS ITS TOLERANCE")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
