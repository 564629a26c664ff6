"""``agvctl tune``: design the PI wheel-speed loops for a margin spec and verify them on the nonlinear
plant."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agvctl.cli.commands import command_summary
from agvctl.cli.options import add_vehicle_options
from agvctl.cli.outputs import Output, check_outputs, files_in, vehicle_input, writing
from agvctl.cli.tune_pose_cmd import add_pose_options, check_mode, run_pose
from agvctl.controllers.pi.gains_file import gains_toml
from agvctl.controllers.pi.options import WheelLoopOptions
from agvctl.controllers.pi.tuning import (
    SPEC_SOURCE,
    TuningResult,
    TuningSpec,
    design_pi,
)
from agvctl.errors import ConfigError
from agvctl.fileio import atomic_open, write_text
from agvctl.params import load_vehicle
from agvctl.plots import render_tuning_plots
from agvctl.sim.wheel_step import WheelStepResult, wheel_step_response

__all__ = ["register", "run", "summary"]

STEP_M_S = 0.3
"""The verification step: a 0.3 m/s wheel-speed step on both wheels."""
_FLAGS = {
    "phase_margin_deg": "--phase-margin",
    "gain_margin_db": "--gain-margin",
    "crossover_rad_s": "--bandwidth",
}

_LOOPS = WheelLoopOptions()
"""The wheel loops' defaults: the design is verified with them unless ``--[no-]coulomb-feedforward`` says."""


TUNING_PLOTS = ("bode.png", "nyquist.png", "step.png")
"""The files ``--plot DIR`` gets (:func:`~agvctl.plots.render_tuning_plots`)."""


def register(sub: Any) -> None:
    p = sub.add_parser(
        "tune",
        help=command_summary("tune"),
        description="Design the discrete PI wheel-speed controller from the decoupled model (eqs 60-61) "
        "sampled with a zero-order hold, for a phase margin, a gain margin and, optionally, a crossover; by "
        "default as fast as the margins allow. Margins are those of the sampled loop up to and including the "
        "Nyquist frequency; the step figures are from the full nonlinear plant with the DA/amplifier chain "
        f"for a {STEP_M_S:g} m/s wheel-speed step. With --pose FUZZ.toml: search the settings of a pose "
        "controller over the fuzz file's scenario distribution (Optuna, the tune extra), validate them on held-out "
        "scenarios against the defaults and write a settings file.",
    )
    add_vehicle_options(p)
    p.add_argument("--phase-margin", type=float, metavar="DEG", default=60.0, help="minimum phase margin (default 60)")
    p.add_argument("--gain-margin", type=float, metavar="DB", default=10.0, help="minimum gain margin (default 10)")
    p.add_argument(
        "--bandwidth",
        type=float,
        metavar="RAD_S",
        default=None,
        help="demanded gain crossover in rad/s (default: the fastest the margins allow)",
    )
    p.add_argument(
        "--coulomb-feedforward",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="verify (and record in the gains file) with or without the Coulomb-friction feed-forward "
        f"tau_c R/k_t sign(setpoint) (default: {'with' if _LOOPS.coulomb_feedforward else 'without'}, as the wheel "
        "loops' default)",
    )
    p.add_argument("--json", action="store_true", help="print the gains, margins and step figures as JSON")
    p.add_argument("--out", metavar="FILE", help="write the gains file (with --pose: the settings file)")
    p.add_argument("--plot", metavar="DIR", help="write bode.png, nyquist.png and step.png to DIR")
    add_pose_options(p)
    p.set_defaults(func=run)


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def summary(design: TuningResult, step: WheelStepResult) -> dict[str, Any]:
    """The ``--json`` object: controller C(z), margins of the sampled loop, nonlinear step figures."""
    g, m, s = design.gains, design.margins, step.metrics
    return {
        "controller": {"kp": g.kp, "ki": g.ki, "num": list(g.num), "den": list(g.den), "dt": g.dt_s},
        "margins": {
            "gain_margin_db": _finite_or_none(m.gain_margin_db),
            "phase_margin_deg": _finite_or_none(m.phase_margin_deg),
            "crossover_rad_s": _finite_or_none(m.crossover_rad_s),
        },
        "step": {
            "rise_time_s": _finite_or_none(s.rise_time_s),
            "overshoot_pct": _finite_or_none(s.overshoot_pct),
            "settling_time_s": _finite_or_none(s.settling_time_s),
            "steady_state_error_pct": _finite_or_none(s.steady_state_error_pct),
        },
    }


def _spec(args: argparse.Namespace) -> TuningSpec:
    try:
        return TuningSpec(
            phase_margin_deg=args.phase_margin,
            gain_margin_db=args.gain_margin,
            crossover_rad_s=args.bandwidth,
        )
    except ConfigError as exc:
        raise ConfigError(_FLAGS.get(exc.key, exc.source), "", exc.problem) from None


def run(args: argparse.Namespace) -> int:
    check_mode(args)
    if args.pose is not None:
        return run_pose(args)
    vehicle = load_vehicle(args.vehicle, args.overrides)
    spec = _spec(args)
    plot_dir = Path(args.plot) if args.plot else None
    outputs = [Output("--out", Path(args.out))] if args.out else []
    outputs += files_in("--plot", plot_dir, TUNING_PLOTS) if plot_dir is not None else []
    check_outputs(outputs, [vehicle_input(args.vehicle)], [("--plot", plot_dir)] if plot_dir is not None else [])
    try:
        design = design_pi(vehicle, spec)
    except ConfigError as exc:
        if exc.source != SPEC_SOURCE:
            raise
        raise ConfigError(_FLAGS.get(exc.key, exc.key), "", exc.problem) from None
    options = (
        _LOOPS if args.coulomb_feedforward is None else WheelLoopOptions(coulomb_feedforward=args.coulomb_feedforward)
    )
    step = wheel_step_response(vehicle, design.gains, wheel_speed_step_m_s=STEP_M_S, options=options)
    data = summary(design, step)

    # render everything before writing anything: no half-written output on error
    figures = render_tuning_plots(design, step, vehicle, STEP_M_S) if plot_dir is not None else {}
    gains_text = None
    if args.out:
        m = design.margins
        gains_text = gains_toml(
            design.gains,
            coulomb_feedforward=options.coulomb_feedforward,
            header=f"PI wheel-speed gains from `agvctl tune` for {vehicle.name}\n"
            f"C(z) = ((kp + ki dt_s) z - kp) / (z - 1), motor-speed error (rad/s) -> motor voltage (V)\n"
            f"margins: GM {m.gain_margin_db:.3f} dB, PM {m.phase_margin_deg:.3f} deg, "
            f"crossover {m.crossover_rad_s:.4f} rad/s",
        )
    for name, content in figures.items():
        assert plot_dir is not None
        with writing("--plot", plot_dir / name), atomic_open(plot_dir / name, "wb") as fh:
            fh.write(content)
    if gains_text is not None:
        with writing("--out", args.out):
            write_text(args.out, gains_text)

    if args.json:
        print(json.dumps(data, indent=2))
        return 0
    g, m, s = design.gains, design.margins, step.metrics
    wc_note = (
        "fastest the margins allow"
        if spec.crossover_rad_s is None
        else f"crossover {spec.crossover_rad_s:g} rad/s demanded"
    )
    print(f"{vehicle.name}: PI wheel-speed loops at T_s = {g.dt_s * 1e3:g} ms")
    print(f"  spec             PM >= {spec.phase_margin_deg:g}°, GM >= {spec.gain_margin_db:g} dB, {wc_note}")
    print(f"  C(z)             ({g.num[0]:.6g} z − {-g.num[1]:.6g}) / (z − 1)   [motor-speed error rad/s → motor V]")
    print(f"  gains            kp = {g.kp:.6g} V s/rad   ki = {g.ki:.6g} V/rad")
    print(
        f"  margins          GM {m.gain_margin_db:.2f} dB at {m.phase_crossover_rad_s:.2f} rad/s "
        "(Nyquist π/T_s = "
        f"{math.pi / g.dt_s:.2f}), PM {m.phase_margin_deg:.2f}° at crossover {m.crossover_rad_s:.3f} rad/s"
    )
    print(f"                   (sampled loop: ZOH plant of eqs 60-61, chain gain {design.chain_gain:g} V/V)")
    ff = ", Coulomb feed-forward" if options.coulomb_feedforward else ""
    print(
        f"  step             {STEP_M_S:g} m/s = {step.setpoint_rad_s[0]:.1f} rad/s motor, "
        f"full nonlinear plant, DA + amplifier{ff}:"
    )
    print(
        f"                   rise (10-90 %) {s.rise_time_s:.3f} s   overshoot {s.overshoot_pct:.2f} %   "
        f"settling (2 %) {s.settling_time_s:.3f} s   steady-state error {s.steady_state_error_pct:.3f} %"
    )
    print(
        f"                   peak current {float(np.max(step.current_peak_a)):.2f} A "
        f"(limit {vehicle.amplifier.current_limit_a:g} A)"
    )
    if args.out:
        print(f"  gains file       {args.out}")
    if plot_dir is not None:
        print(f"  plots            {', '.join(str(plot_dir / n) for n in figures)}")
    return 0
