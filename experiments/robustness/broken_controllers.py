"""Does the default gate catch broken controllers? The default pose controller and deliberately broken variants of
it, each run on the scenarios of a fuzz file and judged by the default gate alone.

Each fault is one a real integration makes: the wheels' sides swapped, the heading feedback's sign flipped, commands
that stop at 60 % of the path (ramping the wheels down gently, so no acceleration gives it away), the wheel loops'
gains four times the design, one sample of extra delay, setpoints 20 % short, docking switched off, a QP solver
allowed one iteration, NaN commands from 60 % of the path on, and the delay and the scaling again inside the wheel
loops (their wheels driven at 0.8 of the speed asked, their DA commands a sample late). For each, the table gives
how often the gate fails it, in all scenarios and in those where the fault changes the run at all (a run within 1 mm
and 0.5° of the healthy one, all along, is one the fault cannot show in), which limits caught it, and the median
change the fault makes to the largest cross-track error, the final position error and the completion time.

Run: python experiments/robustness/broken_controllers.py [FUZZ.toml] [--jobs 2] [--out TABLE.md]
(the CI fuzz file by default: 30 scenarios, about a minute and a half on 2 cores).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import datetime
import json
import math
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.controllers.base import PoseCommand, PoseController, WheelSpeedController
from agvctl.controllers.mpc.docking import DockingConfig
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.controllers.registry import POSE_CONTROLLERS
from agvctl.evaluation.limits import judge_run
from agvctl.feasibility import HeadroomWarning
from agvctl.fuzz.generate import generate_scenario, scenario_files
from agvctl.fuzz.spec import load_fuzz_config
from agvctl.params import load_vehicle
from agvctl.planning.reference import Reference
from agvctl.scenario import Experiment, load_experiment, run_experiment

HERE = Path(__file__).resolve().parent
CI_FUZZ = HERE.parent / "fuzz" / "ci.toml"


class Wrapped:
    """A pose controller around the default one, changing what goes in or comes out."""

    def __init__(self, inner: PoseController) -> None:
        self.inner = inner
        self.reference: Reference | None = None

    def reset(self, reference: Reference) -> None:
        self.reference = reference
        self.inner.reset(reference)

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        return self.inner.update(t_s, pose, wheel_speed_m_s)


class SidesSwapped(Wrapped):
    """Left and right setpoints exchanged (a wiring or a sign convention mixed up)."""

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        return dataclasses.replace(
            c, wheel_speed_left_m_s=c.wheel_speed_right_m_s, wheel_speed_right_m_s=c.wheel_speed_left_m_s
        )


class HeadingFlipped(Wrapped):
    """The heading error fed back with the wrong sign (the heading mirrored about the reference's)."""

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        theta_ref = float(self.reference.sample([min(t_s, self.reference.duration_s)]).theta_rad[0])
        mirrored = np.array([pose[0], pose[1], 2.0 * theta_ref - pose[2]])
        return self.inner.update(t_s, mirrored, wheel_speed_m_s)


class StopsAt60(Wrapped):
    """From 60 % of the path's duration on, the setpoints ramp down to rest at eq 5's a_lim and stay there."""

    def __init__(self, inner: PoseController, sample_period_s: float, accel_m_s2: float) -> None:
        super().__init__(inner)
        self.step_m_s = sample_period_s * accel_m_s2
        self.previous = np.zeros(2)

    def reset(self, reference: Reference) -> None:
        super().reset(reference)
        self.previous = np.zeros(2)

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        if t_s >= 0.6 * self.reference.duration_s:
            s = np.sign(self.previous) * np.maximum(np.abs(self.previous) - self.step_m_s, 0.0)
            c = dataclasses.replace(c, wheel_speed_left_m_s=float(s[0]), wheel_speed_right_m_s=float(s[1]))
        self.previous = np.array([c.wheel_speed_left_m_s, c.wheel_speed_right_m_s])
        return c


class NaNAt60(Wrapped):
    """From 60 % of the path's duration on, the setpoints are NaN (a division by zero in the controller's code)."""

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        if t_s >= 0.6 * self.reference.duration_s:
            c = dataclasses.replace(c, wheel_speed_left_m_s=math.nan, wheel_speed_right_m_s=math.nan)
        return c


class Scaled(Wrapped):
    """Setpoints multiplied by a factor (a wrong wheel radius or gear ratio in the conversion)."""

    def __init__(self, inner: PoseController, factor: float) -> None:
        super().__init__(inner)
        self.factor = factor

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        return dataclasses.replace(
            c,
            wheel_speed_left_m_s=self.factor * c.wheel_speed_left_m_s,
            wheel_speed_right_m_s=self.factor * c.wheel_speed_right_m_s,
        )


class Delayed(Wrapped):
    """Each setpoint applied one sample late (a queue between the pose and the wheel computer)."""

    def reset(self, reference: Reference) -> None:
        super().reset(reference)
        self.previous: PoseCommand | None = None

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        out = self.previous or dataclasses.replace(c, wheel_speed_left_m_s=0.0, wheel_speed_right_m_s=0.0)
        self.previous = c
        return dataclasses.replace(out, reference_done=c.reference_done)


class HeadingOffset(Wrapped):
    """The heading the controller is given is off by a constant angle (a gyro or a scanner mounted askew)."""

    def __init__(self, inner: PoseController, offset_deg: float) -> None:
        super().__init__(inner)
        self.offset_rad = math.radians(offset_deg)

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        return self.inner.update(t_s, np.array([pose[0], pose[1], pose[2] + self.offset_rad]), wheel_speed_m_s)


class FastClock(Wrapped):
    """The controller's clock runs fast (a timer's prescaler wrong): it drives the path faster than it was planned,
    beyond the path's speed and acceleration limits."""

    def __init__(self, inner: PoseController, factor: float) -> None:
        super().__init__(inner)
        self.factor = factor

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        return self.inner.update(self.factor * t_s, pose, wheel_speed_m_s)


class PausesMidway(Wrapped):
    """At half the path's duration, the setpoints stop for a while (a safety scanner's false alarm, a blocked
    message queue), then the controller resumes."""

    def __init__(self, inner: PoseController, pause_s: float) -> None:
        super().__init__(inner)
        self.pause_s = pause_s

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        start = 0.5 * self.reference.duration_s
        if start <= t_s < start + self.pause_s:
            c = dataclasses.replace(c, wheel_speed_left_m_s=0.0, wheel_speed_right_m_s=0.0)
        return c


class DockSteers(Wrapped):
    """Once the reference is at rest, while it drives in reverse (the dock's backing up), one wheel's setpoint is
    off by a constant (a steering term whose sign is wrong in reverse): the dock leaves the path's line."""

    def __init__(self, inner: PoseController, bias_m_s: float) -> None:
        super().__init__(inner)
        self.bias_m_s = bias_m_s

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        if t_s >= self.reference.duration_s and c.wheel_speed_left_m_s < 0.0 and c.wheel_speed_right_m_s < 0.0:
            c = dataclasses.replace(c, wheel_speed_left_m_s=c.wheel_speed_left_m_s + self.bias_m_s)
        return c


class WheelWrapped:
    """The default wheel loops, changing what goes in or comes out; they still say when they are clamped."""

    def __init__(self, inner: PIWheelController) -> None:
        self.inner = inner

    @property
    def limited(self) -> tuple[bool, bool]:
        return self.inner.limited

    def reset(self) -> None:
        self.inner.reset()

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        return self.inner.update(setpoint_rad_s, measured_rad_s)


class WheelScaled(WheelWrapped):
    """The wheel loops drive their wheels at 0.8 of the speed they are given (a gear ratio or an encoder's resolution
    wrong in the wheel computer's conversion)."""

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        return self.inner.update(0.8 * np.asarray(setpoint_rad_s), measured_rad_s)


class WheelLate(WheelWrapped):
    """Each DA command written one sample late (the converter loaded before the new command is computed)."""

    def reset(self) -> None:
        super().reset()
        self.previous = np.zeros(2)

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        out, self.previous = self.previous, self.inner.update(setpoint_rad_s, measured_rad_s)
        return out


class DAOffset(WheelWrapped):
    """The left wheel's DA command is off by a constant voltage (a converter's offset never calibrated out)."""

    def __init__(self, inner: PIWheelController, offset_v: float) -> None:
        super().__init__(inner)
        self.offset_v = offset_v

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        return self.inner.update(setpoint_rad_s, measured_rad_s) + np.array([self.offset_v, 0.0])


class HoldsAtRest(WheelWrapped):
    """At rest, the wheel loops keep the DA command they had when the wheels stopped instead of releasing them to
    stiction: the motors hold current against each other and the floor while nothing moves."""

    def reset(self) -> None:
        super().reset()
        self.held = np.zeros(2)

    def update(self, setpoint_rad_s: np.ndarray, measured_rad_s: np.ndarray) -> np.ndarray:
        out = self.inner.update(setpoint_rad_s, measured_rad_s)
        resting = np.asarray(setpoint_rad_s) == 0.0
        out = np.where(resting & (out == 0.0), self.held, out)
        self.held = out
        return out


Controllers = tuple[PoseController, WheelSpeedController | None]


def _default(e: Experiment, **settings: Any) -> PoseController:
    spec = e.spec.controller
    pose_settings = dataclasses.replace(spec.pose_settings, **settings) if settings else spec.pose_settings
    return POSE_CONTROLLERS[spec.pose].make(e.controller_vehicle, pose_settings)


class Overcorrects(Wrapped):
    """The feedback's correction (the setpoints minus the reference's wheel speeds) multiplied by a gain (a
    correction tuned on a lighter, faster vehicle)."""

    def __init__(self, inner: PoseController, gain: float) -> None:
        super().__init__(inner)
        self.gain = gain

    def update(self, t_s: float, pose: np.ndarray, wheel_speed_m_s: np.ndarray) -> PoseCommand:
        assert self.reference is not None
        c = self.inner.update(t_s, pose, wheel_speed_m_s)
        ref = self.reference.sample([min(t_s, self.reference.duration_s)])
        ff = np.array([ref.wheel_speed_left_m_s[0], ref.wheel_speed_right_m_s[0]])
        out = ff + self.gain * (np.array([c.wheel_speed_left_m_s, c.wheel_speed_right_m_s]) - ff)
        return dataclasses.replace(c, wheel_speed_left_m_s=float(out[0]), wheel_speed_right_m_s=float(out[1]))


def _loops(e: Experiment) -> PIWheelController:
    return e.wheel_loops.controller(e.controller_vehicle)


def _gains_x4(e: Experiment) -> WheelSpeedController:
    loops = e.wheel_loops
    gains = dataclasses.replace(loops.design.gains, kp=4 * loops.design.gains.kp, ki=4 * loops.design.gains.ki)
    return PIWheelController(e.controller_vehicle, gains, loops.options)


FAULTS: dict[str, Callable[[Experiment], Controllers]] = {
    "healthy": lambda e: (_default(e), None),
    "sides swapped": lambda e: (SidesSwapped(_default(e)), None),
    "heading feedback flipped": lambda e: (HeadingFlipped(_default(e)), None),
    "stops at 60 %": lambda e: (
        StopsAt60(
            _default(e), e.controller_vehicle.control.sample_period_s, e.controller_vehicle.derived.accel_limit_m_s2
        ),
        None,
    ),
    "wheel-loop gains x4": lambda e: (_default(e), _gains_x4(e)),
    "one sample of delay": lambda e: (Delayed(_default(e)), None),
    "setpoints x0.8": lambda e: (Scaled(_default(e), 0.8), None),
    "never docks": lambda e: (_default(e, docking=DockingConfig(enabled=False)), None),
    "solver stopped after one iteration": lambda e: (_default(e, max_iterations=1), None),
    "NaN from 60 % of the path": lambda e: (NaNAt60(_default(e)), None),
    "wheel loops at 0.8 of their setpoints": lambda e: (
        _default(e),
        WheelScaled(e.wheel_loops.controller(e.controller_vehicle)),
    ),
    "wheel loops one sample late": lambda e: (_default(e), WheelLate(e.wheel_loops.controller(e.controller_vehicle))),
    "heading 1.5° off": lambda e: (HeadingOffset(_default(e), 1.5), None),
    "heading 0.75° off": lambda e: (HeadingOffset(_default(e), 0.75), None),
    "0.3 V DA offset on one wheel": lambda e: (_default(e), DAOffset(_loops(e), 0.3)),
    "clock 25 % fast": lambda e: (FastClock(_default(e), 1.25), None),
    "feedback x2": lambda e: (Overcorrects(_default(e), 2.0), None),
    "dock steers in reverse": lambda e: (DockSteers(_default(e), 0.02), None),
    "pauses 3 s midway": lambda e: (PausesMidway(_default(e), 3.0), None),
    "wheel loops hold their output at rest": lambda e: (_default(e), HoldsAtRest(_loops(e))),
}


def run_scenario(args: tuple[str, int, tuple[str, ...]]) -> list[dict[str, Any]]:
    """The healthy controller and ``faults`` on one scenario: each verdict, the limits it failed and whether the run
    differs from the healthy one."""
    fuzz_file, index, faults = args
    warnings.simplefilter("ignore", HeadroomWarning)  # the fuzz draws limits up to the vehicle's maxima on purpose
    spec = load_fuzz_config(fuzz_file)
    scenario = generate_scenario(spec, load_vehicle(), index)
    files = scenario_files(spec, scenario, "mpc")
    rows, healthy_pose = [], None
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            Path(tmp, name).write_text(text)
        experiment = load_experiment(Path(tmp, list(files)[-1]))
        for fault in ("healthy", *faults):
            pose_controller, wheel_controller = FAULTS[fault](experiment)
            try:
                result = run_experiment(experiment, pose_controller=pose_controller, wheel_controller=wheel_controller)
            except Exception as exc:  # a fault that breaks the run is caught by check's exit code 3
                rows.append(
                    dict(index=index, fault=fault, passed=False, failed=[f"error: {type(exc).__name__}"], differs=True)
                )
                continue
            verdict = judge_run(result, experiment.spec.limits, experiment.controller_vehicle)
            metrics, limits = verdict.metrics, verdict.limits
            pose = np.column_stack([result.log["x_m"], result.log["y_m"], result.log["theta_rad"]])
            if fault == "healthy":
                healthy_pose = pose
            rows.append(
                dict(
                    index=index,
                    fault=fault,
                    passed=all(r.passed for r in limits),
                    failed=[r.limit for r in limits if not r.passed],
                    differs=_differs(pose, healthy_pose),
                    final_pose=[float(v) for v in pose[-1]],
                    **{key: float(metrics[key]) for key in (*EFFECTS, *RECORDED)},
                )
            )
    return rows


EFFECTS = ("cross_track_error_max_m", "final_position_error_m", "completion_time_s")
"""What a fault changes, by the healthy run's value on the same scenario: how far off the path, how far from the
end, and how late (the time after which the vehicle stays within 2 cm of the end)."""

RECORDED = (
    "final_heading_error_deg",
    "lateness_s",
    "dock_cross_track_error_max_m",
    "rest_current_max_a",
    "reference_duration_s",
    "peak_wheel_speed_m_s",
    "peak_wheel_accel_m_s2",
    "path_heading_error_max_deg",
)
"""Further metrics kept in the rows, from which a default's bound is derived."""

HARM_M, HARM_DEG, HARM_S = 1e-3, 0.5, 0.5
"""A fault harms a run that ends more than 1 mm or 0.5° from where the healthy run of its scenario ends, strays
more than 1 mm further from the path, or arrives for good more than 0.5 s earlier or later."""


def harmed(run: dict[str, Any], healthy: dict[str, Any]) -> bool:
    """Whether a faulty run is harmed against the healthy run of its scenario (:data:`HARM_M`, ...); a run that
    raised is."""
    if "final_pose" not in run:
        return True
    a, b = np.asarray(run["final_pose"]), np.asarray(healthy["final_pose"])
    heading = abs(math.degrees(math.remainder(a[2] - b[2], 2 * math.pi)))
    late = abs(run["completion_time_s"] - healthy["completion_time_s"])
    return bool(
        math.hypot(*(a[:2] - b[:2])) > HARM_M
        or heading > HARM_DEG
        or run["cross_track_error_max_m"] - healthy["cross_track_error_max_m"] > HARM_M
        or not late <= HARM_S  # inf or nan: never arrives where the healthy run does
    )


def _effect(runs: list[dict[str, Any]], healthy: dict[int, dict[str, Any]]) -> str:
    """The median change of each of :data:`EFFECTS` against the healthy run of the same scenario (a run that raised
    counts as infinitely worse)."""
    change = {k: np.median([r.get(k, math.inf) - healthy[r["index"]].get(k, 0.0) for r in runs]) for k in EFFECTS}
    late = change["completion_time_s"]
    late_text = "never within 2 cm" if math.isinf(late) else f"{late:+.1f} s"
    return (
        f"{1e3 * change['cross_track_error_max_m']:+.1f} mm, {1e3 * change['final_position_error_m']:+.1f} mm, "
        + late_text
    )


def _differs(pose: np.ndarray, healthy: np.ndarray | None) -> bool:
    """Whether a run leaves the healthy run's pose by more than 1 mm or 0.5° at any sample (or lasts longer)."""
    if healthy is None or len(pose) != len(healthy):
        return True
    distance = np.hypot(pose[:, 0] - healthy[:, 0], pose[:, 1] - healthy[:, 1])
    return bool(np.max(distance) > 1e-3 or np.max(np.abs(pose[:, 2] - healthy[:, 2])) > math.radians(0.5))


def table(rows: list[dict[str, Any]]) -> str:
    """The Markdown table of how often the default gate fails each fault."""
    lines = [
        "| controller | fails the gate | of the runs the fault changes | of the runs it harms | limits that caught it "
        "| median change: cross-track max, final position, completion |",
        "|---|---|---|---|---|---|",
    ]
    healthy = {r["index"]: r for r in rows if r["fault"] == "healthy"}
    for fault in dict.fromkeys(r["fault"] for r in rows):
        runs = [r for r in rows if r["fault"] == fault]
        shows = [r for r in runs if r["differs"]]
        harms = [r for r in runs if harmed(r, healthy[r["index"]])]
        caught = sum(not r["passed"] for r in runs)
        caught_shows = sum(not r["passed"] for r in shows)
        caught_harms = sum(not r["passed"] for r in harms)
        keys = collections.Counter(k for r in runs for k in r["failed"])
        named = ", ".join(f"`{k}` {n}" for k, n in keys.most_common()) or "none"
        where = "—" if fault == "healthy" else f"{caught_shows} of {len(shows)}"
        harm = "—" if fault == "healthy" else f"{caught_harms} of {len(harms)}"
        effect = "—" if fault == "healthy" else _effect(runs, healthy)
        lines.append(f"| {fault} | {caught} of {len(runs)} | {where} | {harm} | {named} | {effect} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("fuzz", nargs="?", default=str(CI_FUZZ), help="fuzz file whose scenarios to run")
    parser.add_argument("--jobs", type=int, default=2, help="worker processes")
    parser.add_argument("--faults", help=f"comma-separated subset of: {', '.join(list(FAULTS)[1:])}")
    parser.add_argument("--out", help="also write the table to this Markdown file")
    parser.add_argument("--rows", help="also write every run's verdict to this JSON file")
    args = parser.parse_args(argv)
    faults = tuple(f for f in FAULTS if f != "healthy")
    if args.faults:
        faults = tuple(f.strip() for f in args.faults.split(",") if f.strip())
        unknown = [f for f in faults if f not in FAULTS]
        if unknown:
            parser.error(f"--faults: unknown {unknown}; choose from {list(FAULTS)[1:]}")
    spec = load_fuzz_config(args.fuzz)
    t0, rows = time.perf_counter(), []
    with ProcessPoolExecutor(args.jobs) as pool:
        tasks = [(args.fuzz, k, faults) for k in range(spec.scenarios)]
        for i, scenario_rows in enumerate(pool.map(run_scenario, tasks)):
            rows.extend(scenario_rows)
            print(f"\r{i + 1}/{spec.scenarios} scenarios", end="", file=sys.stderr, flush=True)
    print(file=sys.stderr)
    text = table(rows)
    command = " ".join(["python experiments/robustness/broken_controllers.py", *(argv or sys.argv[1:])])
    header = (
        f"Written by `{command}` on {datetime.date.today()}; do not edit by hand. The default gate against broken "
        f"controllers: {spec.scenarios} scenarios of `{Path(args.fuzz).name}` (seed {spec.seed}), "
        f"{time.perf_counter() - t0:.0f} s on {args.jobs} workers.\n\n"
    )
    print(header + text)
    if args.out:
        Path(args.out).write_text(header + text)
    if args.rows:
        Path(args.rows).write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
