"""The unicycle tracking laws (Ramsete, LTV-LQR) as generated C99: rendered from templates, compiled, and run
through ctypes.

:func:`render_unicycle_c` writes the C of a :class:`~agvctl.controllers.baselines.ramsete.RamseteController` or a
:class:`~agvctl.controllers.baselines.ltv_lqr.LtvLqrController`: a header with a documented init/step API (the state
in a struct the caller owns, the reference a table the caller hands over, no heap, no file I/O) and a source with
the law's gains (the LQR's whole gain schedule) and the vehicle's constants as ``static const`` data. What the laws
share (the robot-frame error, the wheel speeds within their limit, the fallback) is one template
(``unicycle.c.j2``) that each law's template extends with its constants and its law. The source mirrors the Python
law's arithmetic operation by operation, with the same ``<math.h>`` functions, so the two agree to the last bit on
the same inputs.

:class:`CompiledRamseteController` and :class:`CompiledLtvLqrController` are that C in the closed loop
(software-in-the-loop, ``pose = "ramsete_c"`` and ``"ltv_lqr_c"``): compiled with the strict flags
(:func:`~agvctl.controllers.pi.c_loops.compile_generated_c`) into the cache of compiled code, once per gains and
vehicle (the reference is data, handed over at each reset), and called through ctypes behind the same
:class:`~agvctl.controllers.base.PoseController` protocol as the Python laws.
"""

from __future__ import annotations

import ctypes
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import CStep, PoseCommand, SolveStatus
from agvctl.controllers.baselines.ltv_lqr import LtvLqrConfig, LtvLqrController
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController
from agvctl.controllers.baselines.unicycle import UnicycleTracker
from agvctl.controllers.pi.c_loops import GeneratedC, compile_generated_c
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference
from agvctl.plant.codegen import c_double, c_templates

__all__ = [
    "COMPILED_LAWS",
    "CompiledLaw",
    "CompiledLtvLqrController",
    "CompiledRamseteController",
    "generated_prefix",
    "render_unicycle_c",
]


def _law_values(controller: UnicycleTracker) -> tuple[str, str, dict[str, Any]]:
    """(prefix, title, the law's own template values) of a law that has a template."""
    if isinstance(controller, RamseteController):
        c = controller.config
        comment = f"b = {c.b_rad2_m2:.6g}, zeta = {c.zeta:.6g}"
        values = {"b_rad2_m2": c.b_rad2_m2, "zeta": c.zeta, "comment": comment, "python_class": "RamseteController"}
        return "agv_ramsete", "the Ramsete law", values
    if isinstance(controller, LtvLqrController):
        q = controller.config
        comment = (
            f"tolerances {q.tolerance_x_m:.6g} m, {q.tolerance_y_m:.6g} m, {q.tolerance_heading_rad:.6g} rad; "
            f"efforts {q.effort_speed_m_s:.6g} m/s, {q.effort_yaw_rate_rad_s:.6g} rad/s"
        )
        values = {
            "schedule_speeds": controller.schedule_speeds_m_s.tolist(),
            "schedule_gains": controller.schedule_gains.tolist(),
            "comment": comment,
            "python_class": "LtvLqrController",
        }
        return "agv_ltv_lqr", "the LTV unicycle LQR", values
    raise TypeError(f"no C template for {type(controller).__name__}")


def generated_prefix(controller: object) -> str | None:
    """The generated files' stem of ``controller``'s law, or None where it has no template.

    Parameters
    ----------
    controller : object
        A pose controller.

    Returns
    -------
    str or None
        ``"agv_ramsete"`` or ``"agv_ltv_lqr"``, or None.
    """
    if isinstance(controller, (RamseteController, LtvLqrController)):  # the laws with a template
        return _law_values(controller)[0]
    return None


def render_unicycle_c(controller: UnicycleTracker, *, origin: str, generator: str) -> GeneratedC:
    """The C99 of ``controller``'s law: its gains, wheel separation and wheel-speed limit baked in.

    Parameters
    ----------
    controller : RamseteController or LtvLqrController
        The Python controller whose constants the C takes.
    origin : str
        One line saying what the controller was designed for, written into both files.
    generator : str
        What wrote them (``"agvctl 0.2.0"``), written into both files.

    Returns
    -------
    GeneratedC
        The header and the source.

    Raises
    ------
    TypeError
        ``controller`` is neither law.
    """
    prefix, title, law = _law_values(controller)
    values = {
        **law,
        "prefix": prefix,
        "guard": f"{prefix.upper()}_H",
        "macro": prefix.upper(),
        "law_title": title,
        "origin": origin,
        "generator": generator,
        "sample_period_s": c_double(controller.sample_period_s),
        "separation_m": controller.separation_m,
        "max_wheel_speed_m_s": controller.max_wheel_speed_m_s,
        "pi": math.pi,
        "two_pi": 2.0 * math.pi,
    }
    env = c_templates("agvctl.controllers.baselines")
    source = env.get_template(f"{prefix.removeprefix('agv_')}.c.j2").render(values)
    return GeneratedC(env.get_template("unicycle.h.j2").render(values), source, prefix)


class _CompiledLaw(UnicycleTracker):
    """The C of a unicycle law, compiled and loaded, stepped on the control grid: the base of the compiled laws,
    before the Python law in their bases (whose constants the C takes)."""

    def _load(self, vehicle: VehicleParams) -> None:
        self.code = render_unicycle_c(
            self, origin=f"For vehicle {vehicle.name}.", generator="agvctl (software-in-the-loop)"
        )
        """The generated header and source."""
        lib = compile_generated_c(self.code, _law_values(self)[1].removeprefix("the "))
        prefix = self.code.prefix
        self._init = getattr(lib, f"{prefix}_init")
        self._init.restype = None
        self._step = getattr(lib, f"{prefix}_step")
        self._step.restype = ctypes.c_int
        self._step.argtypes = [ctypes.c_void_p, ctypes.c_long, ctypes.c_void_p, ctypes.c_void_p]
        size = getattr(lib, f"{prefix}_state_size")
        size.restype = ctypes.c_size_t
        self._state = (ctypes.c_double * -(-int(size()) // 8))()  # caller-owned, double-aligned
        self._table: NDArray[np.float64] = np.zeros((1, 7))
        self._pose = (ctypes.c_double * 3)()
        self._setpoint = (ctypes.c_double * 2)()

    def reset(self, reference: Reference) -> None:
        """Start tracking ``reference`` from its time 0: its rows on the control grid become the C's table."""
        super().reset(reference)
        self._table = np.ascontiguousarray(self.reference_rows, dtype=np.float64)
        self._init(self._state, ctypes.c_void_p(self._table.ctypes.data), ctypes.c_long(len(self._table)))

    def update(self, t_s: float, pose: NDArray[np.float64], wheel_speed_m_s: NDArray[np.float64]) -> PoseCommand:
        """Wheel rim-speed setpoints (left, right) in m/s for the sample starting at ``t_s``, from the C step.

        Parameters
        ----------
        t_s : float
            The sample's time, on the control grid, s.
        pose : ndarray
            The pose: x (m), y (m), heading (rad).
        wheel_speed_m_s : ndarray
            The measured wheel speeds (unused by the laws).

        Returns
        -------
        PoseCommand
            The setpoints, the C step's time and ``"solved"`` or ``"fallback_feedforward"``.

        Raises
        ------
        ValueError
            ``t_s`` is off the control grid (the C indexes its table by sample).
        """
        del wheel_speed_m_s
        start = time.perf_counter()
        k = round(t_s / self.sample_period_s)
        if abs(t_s - k * self.sample_period_s) > 1e-9:
            raise ValueError(f"the generated law runs on the control grid (t = {t_s} s is off it)")
        p = self._pose
        p[0], p[1], p[2] = float(pose[0]), float(pose[1]), float(pose[2])
        fallback = self._step(self._state, k, p, self._setpoint)
        self._failures += fallback
        status: SolveStatus = "fallback_feedforward" if fallback else "solved"
        return PoseCommand(self._setpoint[0], self._setpoint[1], time.perf_counter() - start, status)

    def compiled_step(self) -> CStep:
        """The C step and its state, for a closed loop run in C (:class:`~agvctl.controllers.base.CompiledStep`).

        Returns
        -------
        CStep
            The addresses of ``<prefix>_step`` and of the state (its table the reference of the last reset); the
            fallbacks of a compiled run are added to :attr:`failures`.
        """
        address = ctypes.cast(self._step, ctypes.c_void_p).value
        assert address is not None
        return CStep(address, ctypes.addressof(self._state), self._count_failures)

    def _count_failures(self, fallbacks: int) -> None:
        self._failures += fallbacks


class CompiledRamseteController(_CompiledLaw, RamseteController):
    """The Ramsete law as generated C, compiled and called through ctypes: a
    :class:`~agvctl.controllers.base.PoseController` with the commands of
    :class:`~agvctl.controllers.baselines.ramsete.RamseteController` on the same inputs.

    The C runs on the control grid t_k = k·T_s, where the closed loop calls it; the reference's rows on that grid
    (:meth:`reset`) are handed to the C as its table.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.
    config : RamseteConfig or None
        Gains and the wheel-speed limit; None: WPILib's defaults.

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.

    Examples
    --------
    >>> import numpy as np
    >>> from agvctl.params import load_vehicle
    >>> from agvctl.planning import plan_file
    >>> vehicle = load_vehicle()
    >>> reference = plan_file("trajectories/figure8.toml", vehicle)
    >>> c_law, python_law = CompiledRamseteController(vehicle), RamseteController(vehicle)
    >>> c_law.reset(reference); python_law.reset(reference)
    >>> pose, wheels = np.array([0.02, -0.01, 0.05]), np.zeros(2)
    >>> c, p = c_law.update(0.4, pose, wheels), python_law.update(0.4, pose, wheels)
    >>> (c.wheel_speed_left_m_s, c.wheel_speed_right_m_s) == (p.wheel_speed_left_m_s, p.wheel_speed_right_m_s)
    True
    """

    def __init__(self, vehicle: VehicleParams, config: RamseteConfig | None = None) -> None:
        RamseteController.__init__(self, vehicle, config)
        self._load(vehicle)


class CompiledLtvLqrController(_CompiledLaw, LtvLqrController):
    """The LTV unicycle LQR as generated C, its gain schedule as data, compiled and called through ctypes: a
    :class:`~agvctl.controllers.base.PoseController` with the commands of
    :class:`~agvctl.controllers.baselines.ltv_lqr.LtvLqrController` on the same inputs.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.
    config : LtvLqrConfig or None
        Tolerances, efforts, the schedule's spacing and the wheel-speed limit; None: WPILib's defaults.

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.
    """

    def __init__(self, vehicle: VehicleParams, config: LtvLqrConfig | None = None) -> None:
        LtvLqrController.__init__(self, vehicle, config)
        self._load(vehicle)


@dataclass(frozen=True)
class CompiledLaw:
    """A unicycle law whose C is generated.

    Parameters
    ----------
    settings : type
        Its settings' dataclass (the ``[controller]`` table's other keys).
    python : callable
        The law in Python: its class, ``(vehicle, settings) -> controller``.
    compiled : callable
        The same law as generated C, behind the same protocol: its class.
    """

    settings: type
    python: Callable[[VehicleParams, Any], UnicycleTracker]
    compiled: Callable[[VehicleParams, Any], UnicycleTracker]


COMPILED_LAWS: dict[str, CompiledLaw] = {
    "ramsete": CompiledLaw(RamseteConfig, RamseteController, CompiledRamseteController),
    "ltv_lqr": CompiledLaw(LtvLqrConfig, LtvLqrController, CompiledLtvLqrController),
}
"""The unicycle laws whose C is generated, by their ``pose`` name: ``"<name>_c"`` runs the C in the closed loop,
``agvctl codegen`` writes it as the whole cascade, and the back-to-back compares the two."""
