"""Back-to-back: an experiment's generated C wheel loops beside its Python loops, on the same inputs, in the closed
loop (software-in-the-loop, as an embedded code generator checks its code against the model).

:func:`back_to_back` runs the experiment twice. First the Python loops drive the plant while the C loops
(:class:`~agvctl.controllers.pi.c_loops.CompiledPIWheelController`) are stepped beside them on the same setpoints
and measurements (:class:`SideBySideWheelLoops`): the largest difference of their DA voltages and of their
clamped flags, sample by sample. Then the C loops drive the plant alone. Both runs are judged against the
experiment's gate, limit by limit.

:func:`qp_back_to_back` runs the experiment's LTV MPC twice, with OSQP in Python and with its generated C
(``qp_solver = "osqp_c"``), each in its own closed loop: the largest difference of the commanded DA voltages, sample
by sample, and the two verdicts. :func:`cascade_back_to_back` does the same for a whole cascade that is generated:
a unicycle law (Ramsete, LTV-LQR) and the PI loops in Python, then both as C.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import PoseController, WheelSpeedController
from agvctl.controllers.baselines.c_unicycle import COMPILED_LAWS
from agvctl.controllers.mpc.config import MpcConfig, QpSolver
from agvctl.controllers.mpc.ltv import LtvMpcController
from agvctl.controllers.pi.c_loops import CompiledPIWheelController
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.errors import ConfigError
from agvctl.evaluation.limits import RunVerdict, judge_run
from agvctl.scenario.experiment import Experiment, load_experiment, run_experiment

__all__ = [
    "BackToBack",
    "RunsBackToBack",
    "SideBySideWheelLoops",
    "back_to_back",
    "cascade_back_to_back",
    "qp_back_to_back",
]


class SideBySideWheelLoops:
    """Two wheel-loop implementations stepped on the same inputs; the first one's outputs are commanded.

    Parameters
    ----------
    driving : PIWheelController
        The loops whose DA voltages go to the plant (the Python ones).
    beside : CompiledPIWheelController
        The loops stepped beside them (the C ones).
    """

    def __init__(self, driving: PIWheelController, beside: CompiledPIWheelController) -> None:
        self.driving = driving
        self.beside = beside
        self.samples = 0
        """The samples stepped since the last reset."""
        self.max_da_difference_v = 0.0
        """The largest absolute difference of the DA voltages over both wheels and every sample, V."""
        self.limited_mismatches = 0
        """The samples where the two disagree on which loops were clamped."""

    def reset(self) -> None:
        """Reset both (and the comparison)."""
        self.driving.reset()
        self.beside.reset()
        self.samples = 0
        self.max_da_difference_v = 0.0
        self.limited_mismatches = 0

    @property
    def limited(self) -> tuple[bool, bool]:
        """The driving loops' clamped flags (left, right)."""
        return self.driving.limited

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Both loops' step on the same inputs; the driving loops' DA voltages (V).

        Parameters
        ----------
        setpoint_rad_s : ndarray
            The motor-speed setpoints (left, right), rad/s.
        measured_rad_s : ndarray
            The measured motor speeds (left, right), rad/s.

        Returns
        -------
        ndarray
            The driving loops' DA voltages (left, right), V.
        """
        da = self.driving.update(setpoint_rad_s, measured_rad_s)
        other = self.beside.update(setpoint_rad_s, measured_rad_s)
        self.samples += 1
        self.max_da_difference_v = max(self.max_da_difference_v, float(np.max(np.abs(da - other))))
        if self.driving.limited != self.beside.limited:
            self.limited_mismatches += 1
        return da


@dataclass(frozen=True)
class BackToBack:
    """The comparison of an experiment's Python and C wheel loops.

    Parameters
    ----------
    experiment : str
        The experiment's name.
    samples : int
        The samples compared (of the run the Python loops drive).
    max_da_difference_v : float
        The largest absolute difference of the two's DA voltages on the same inputs, V.
    limited_mismatches : int
        The samples where they disagree on which loops were clamped.
    python : RunVerdict
        The run with the Python loops, judged.
    c : RunVerdict
        The run with the C loops driving the plant, judged.
    """

    experiment: str
    samples: int
    max_da_difference_v: float
    limited_mismatches: int
    python: RunVerdict
    c: RunVerdict

    @property
    def same_verdicts(self) -> bool:
        """Whether every limit and requirement passes or fails alike in the two runs."""
        return _same_verdicts(self.python, self.c)


def _same_verdicts(first: RunVerdict, second: RunVerdict) -> bool:
    return [(v.limit, v.passed) for v in first.limits] == [(v.limit, v.passed) for v in second.limits]


def _judged(experiment: Experiment, wheel_controller: WheelSpeedController) -> RunVerdict:
    result = run_experiment(experiment, wheel_controller=wheel_controller)
    return judge_run(result, experiment.spec.limits, experiment.controller_vehicle, experiment.spec.requirements)


def back_to_back(experiment: str | Path | Experiment) -> BackToBack:
    """Run an experiment with its Python wheel loops and the C ones beside them, then with the C ones alone.

    Parameters
    ----------
    experiment : str, Path or Experiment
        The experiment file, or one loaded (:func:`~agvctl.scenario.experiment.load_experiment`). Its wheel loops'
        gains and options are used whatever its ``controller.wheel_loops`` names.

    Returns
    -------
    BackToBack
        The largest DA difference on the same inputs and both runs' verdicts.

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.
    """
    loaded = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    vehicle = loaded.controller_vehicle
    gains, options = loaded.wheel_loops.design.gains, loaded.wheel_loops.options
    side_by_side = SideBySideWheelLoops(
        PIWheelController(vehicle, gains, options), CompiledPIWheelController(vehicle, gains, options)
    )
    python = _judged(loaded, side_by_side)
    c = _judged(loaded, CompiledPIWheelController(vehicle, gains, options))
    return BackToBack(
        loaded.spec.name,
        side_by_side.samples,
        side_by_side.max_da_difference_v,
        side_by_side.limited_mismatches,
        python,
        c,
    )


@dataclass(frozen=True)
class RunsBackToBack:
    """Two runs of one experiment, its controller in Python and as generated C, each in its own closed loop: the
    LTV MPC on OSQP in Python and on OSQP's generated solver (:func:`qp_back_to_back`), or the whole cascade
    (:func:`cascade_back_to_back`).

    Parameters
    ----------
    experiment : str
        The experiment's name.
    samples : int
        The samples of the run in Python.
    samples_c : int
        The samples of the run with the generated C (another count where the run ends at another time).
    max_da_difference_v : float
        The largest absolute difference of the commanded DA voltages, sample by sample over the samples both runs
        have, V.
    python : RunVerdict
        The run in Python, judged.
    c : RunVerdict
        The run with the generated C, judged.
    """

    experiment: str
    samples: int
    samples_c: int
    max_da_difference_v: float
    python: RunVerdict
    c: RunVerdict

    @property
    def same_verdicts(self) -> bool:
        """Whether every limit and requirement passes or fails alike in the two runs."""
        return _same_verdicts(self.python, self.c)


def qp_back_to_back(experiment: str | Path | Experiment, solver: QpSolver = "osqp_c") -> RunsBackToBack:
    """Run an experiment's LTV MPC with OSQP in Python, then with its generated C.

    Parameters
    ----------
    experiment : str, Path or Experiment
        The experiment file, or one loaded; its pose controller is the LTV MPC (``pose = "mpc"``), whatever its
        ``qp_solver``.
    solver : {'osqp_c', 'osqp_c_float'}
        The generated solver to compare: in double precision (the same answers, bit for bit), or in single
        precision (its error measured).

    Returns
    -------
    RunsBackToBack
        The largest difference of the commanded DA voltages and both runs' verdicts.

    Raises
    ------
    ConfigError
        The pose controller is not the LTV MPC, or the C solver cannot be built here (no compiler, another OSQP).
    """
    loaded = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    spec, vehicle = loaded.spec, loaded.controller_vehicle
    settings = spec.controller.pose_settings
    if spec.controller.pose != "mpc" or not isinstance(settings, MpcConfig):
        problem = f"the QP solvers' back-to-back runs the LTV MPC ('mpc'), not {spec.controller.pose!r}"
        raise ConfigError(str(spec.source), "controller.pose", problem)
    controllers = [LtvMpcController(vehicle, dataclasses.replace(settings, qp_solver=q)) for q in ("osqp", solver)]
    return _two_runs(loaded, controllers[0], controllers[1])


def _two_runs(
    loaded: Experiment,
    python: PoseController,
    c: PoseController,
    wheels: tuple[WheelSpeedController, WheelSpeedController] | None = None,
) -> RunsBackToBack:
    """``loaded`` run with each controller pair in its own closed loop, compared by their DA commands."""
    spec, vehicle = loaded.spec, loaded.controller_vehicle
    runs = []
    for k, pose in enumerate((python, c)):
        result = run_experiment(loaded, pose_controller=pose, wheel_controller=None if wheels is None else wheels[k])
        runs.append((result, judge_run(result, spec.limits, vehicle, spec.requirements)))
    (first, first_verdict), (second, second_verdict) = runs
    n = min(first.n_samples, second.n_samples)
    difference = max(
        float(np.max(np.abs(np.asarray(first.log.columns[k][:n]) - np.asarray(second.log.columns[k][:n]))))
        for k in ("da_command_left_v", "da_command_right_v")
    )
    return RunsBackToBack(spec.name, first.n_samples, second.n_samples, difference, first_verdict, second_verdict)


def cascade_back_to_back(experiment: str | Path | Experiment) -> RunsBackToBack:
    """Run an experiment's cascade in Python, then as generated C: the law (``pose = "ramsete_c"`` or
    ``"ltv_lqr_c"``) and the PI loops (``wheel_loops = "pi_c"``), the C that ``agvctl codegen`` writes.

    Parameters
    ----------
    experiment : str, Path or Experiment
        The experiment file, or one loaded; its pose controller is a unicycle law (``"ramsete"``, ``"ltv_lqr"`` or
        their ``_c`` twins) and its wheel loops the built-in PI loops.

    Returns
    -------
    RunsBackToBack
        The largest difference of the commanded DA voltages and both runs' verdicts.

    Raises
    ------
    ConfigError
        The pose controller has no generated C, or the wheel loops are not the built-in PI loops.
    AgvctlError
        No C compiler, or the generated code does not compile.
    """
    loaded = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    spec, vehicle = loaded.spec, loaded.controller_vehicle
    settings, name = spec.controller.pose_settings, spec.controller.pose.removesuffix("_c")
    if name not in COMPILED_LAWS or not isinstance(settings, COMPILED_LAWS[name].settings):
        problem = f"the cascade's back-to-back runs 'ramsete' or 'ltv_lqr', not {spec.controller.pose!r}"
        raise ConfigError(str(spec.source), "controller.pose", problem)
    if spec.controller.wheel_loops not in ("pi", "pi_c"):
        problem = f"the cascade's back-to-back runs the PI loops ('pi'), not {spec.controller.wheel_loops!r}"
        raise ConfigError(str(spec.source), "controller.wheel_loops", problem)
    law = COMPILED_LAWS[name]
    gains, options = loaded.wheel_loops.design.gains, loaded.wheel_loops.options
    loops = (PIWheelController(vehicle, gains, options), CompiledPIWheelController(vehicle, gains, options))
    return _two_runs(loaded, law.python(vehicle, settings), law.compiled(vehicle, settings), loops)
