"""The Ramsete pose controller as generated C99: rendered from templates, compiled, and run through ctypes.

:func:`render_ramsete_c` writes the C of a :class:`~agvctl.controllers.baselines.ramsete.RamseteController`: a
header with a documented init/step API (the state in a struct the caller owns, the reference a table the caller
hands over, no heap, no file I/O) and a source with the gains and the vehicle's constants as ``static const`` data.
The source mirrors the Python law's arithmetic operation by operation, with the same ``<math.h>`` functions, so the
two agree to the last bit on the same inputs.

:class:`CompiledRamseteController` is that C in the closed loop (software-in-the-loop, ``pose = "ramsete_c"``):
compiled with the strict flags (:func:`~agvctl.controllers.pi.c_loops.compile_generated_c`) into the cache of
compiled code, once per gains and vehicle (the reference is data, handed over at each reset), and called through
ctypes behind the same :class:`~agvctl.controllers.base.PoseController` protocol as the Python law.
"""

from __future__ import annotations

import ctypes
import math
import time

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import PoseCommand, SolveStatus
from agvctl.controllers.baselines.ramsete import RamseteConfig, RamseteController
from agvctl.controllers.pi.c_loops import GeneratedC, compile_generated_c
from agvctl.params import VehicleParams
from agvctl.planning.reference import Reference
from agvctl.plant.codegen import c_double, c_templates

__all__ = ["RAMSETE_PREFIX", "CompiledRamseteController", "render_ramsete_c"]

RAMSETE_PREFIX = "agv_ramsete"
"""The generated files' stem and the prefix of every name they define."""


def render_ramsete_c(controller: RamseteController, *, origin: str, generator: str) -> GeneratedC:
    """The C99 of ``controller``: its gains, wheel separation and wheel-speed limit baked in.

    Parameters
    ----------
    controller : RamseteController
        The Python controller whose constants the C takes.
    origin : str
        One line saying what the controller was designed for, written into both files.
    generator : str
        What wrote them (``"agvctl 0.2.0"``), written into both files.

    Returns
    -------
    GeneratedC
        The header and the source.
    """
    config = controller.config
    values = {
        "prefix": RAMSETE_PREFIX,
        "guard": f"{RAMSETE_PREFIX.upper()}_H",
        "macro": RAMSETE_PREFIX.upper(),
        "origin": origin,
        "generator": generator,
        "sample_period_s": c_double(controller.sample_period_s),
        "comment": f"b = {config.b_rad2_m2:.6g} rad^2/m^2, zeta = {config.zeta:.6g}",
        "b_rad2_m2": config.b_rad2_m2,
        "zeta": config.zeta,
        "separation_m": controller.separation_m,
        "max_wheel_speed_m_s": controller.max_wheel_speed_m_s,
        "pi": math.pi,
        "two_pi": 2.0 * math.pi,
    }
    env = c_templates("agvctl.controllers.baselines")
    return GeneratedC(
        env.get_template("ramsete.h.j2").render(values),
        env.get_template("ramsete.c.j2").render(values),
        RAMSETE_PREFIX,
    )


class CompiledRamseteController(RamseteController):
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
        super().__init__(vehicle, config)
        self.code = render_ramsete_c(
            self, origin=f"The Ramsete law for vehicle {vehicle.name}", generator="agvctl (software-in-the-loop)"
        )
        lib = compile_generated_c(self.code, "Ramsete controller")
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
            The measured wheel speeds (unused by the law).

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
            raise ValueError(f"the generated Ramsete controller runs on the control grid (t = {t_s} s is off it)")
        p = self._pose
        p[0], p[1], p[2] = float(pose[0]), float(pose[1]), float(pose[2])
        fallback = self._step(self._state, k, p, self._setpoint)
        self._failures += fallback
        status: SolveStatus = "fallback_feedforward" if fallback else "solved"
        left, right = self._setpoint[0], self._setpoint[1]
        return PoseCommand(left, right, time.perf_counter() - start, status)
