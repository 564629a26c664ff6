"""The PI wheel loops as generated C99: rendered from templates, compiled, and run through ctypes.

:func:`render_wheel_loops_c` writes the C of a :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController`: a
header with a documented init/step API (the state in a struct the caller owns, no heap, no file I/O) and a source
with the loops' gains and vehicle constants as ``static const`` data. The source mirrors the Python loops'
arithmetic operation by operation (Python's ``max``/``min`` included), so that the two agree to the last bit on the
same inputs.

:class:`CompiledPIWheelController` is that C in the closed loop (software-in-the-loop): compiled with
:data:`STRICT_C_FLAGS` by :func:`~agvctl.plant.codegen.compiled_library`, the plant's compiler and disk cache, and
called through ctypes behind the same :class:`~agvctl.controllers.base.WheelSpeedController` protocol as the Python
loops.
"""

from __future__ import annotations

import ctypes
import subprocess
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.base import CStep
from agvctl.controllers.pi.options import FEEDFORWARD_RAMP_RAD_S, PIGains, WheelLoopOptions
from agvctl.controllers.pi.wheel_loop import PIWheelController
from agvctl.errors import AgvctlError
from agvctl.params import SIDES, VehicleParams
from agvctl.plant.codegen import c_double, c_templates, compiled_library

__all__ = [
    "STRICT_C_FLAGS",
    "CompiledPIWheelController",
    "GeneratedC",
    "StaticMemory",
    "WheelLoopsC",
    "compile_generated_c",
    "compile_wheel_loops",
    "render_wheel_loops_c",
    "static_memory",
]

STRICT_C_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-O2")
"""The flags the generated C compiles with, warnings as errors (plus ``-fPIC -shared`` for the library)."""

PREFIX = "agv_wheel_loops"
"""The generated files' stem and the prefix of every name they define."""


@dataclass(frozen=True)
class GeneratedC:
    """One generated C module: a header and its source.

    Parameters
    ----------
    header : str
        ``<prefix>.h``: the API.
    source : str
        ``<prefix>.c``: the code and its constants as ``static const`` data.
    prefix : str
        The files' stem and the names' prefix.
    """

    header: str
    source: str
    prefix: str

    @property
    def files(self) -> dict[str, str]:
        """``{file name: text}``: the header and the source."""
        return {f"{self.prefix}.h": self.header, f"{self.prefix}.c": self.source}

    def single_unit(self) -> str:
        """The source with the header pasted in place of its ``#include``: one translation unit."""
        return self.source.replace(f'#include "{self.prefix}.h"', self.header, 1)


@dataclass(frozen=True)
class WheelLoopsC(GeneratedC):
    """The generated C of the wheel loops.

    Parameters
    ----------
    header : str
        ``agv_wheel_loops.h``: the state struct and the init/step API.
    source : str
        ``agv_wheel_loops.c``: the loops, their constants as ``static const`` data.
    prefix : str
        The files' stem and the names' prefix.
    """

    prefix: str = PREFIX


def render_wheel_loops_c(loops: PIWheelController, *, origin: str, generator: str) -> WheelLoopsC:
    """The C99 of ``loops``: their gains, options and vehicle constants baked in as ``static const`` data.

    Parameters
    ----------
    loops : PIWheelController
        The Python loops whose constants (per side: gains, motor, current and voltage windows, braking, rest) the
        C takes.
    origin : str
        One line saying what the loops were designed for (the experiment), written into both files.
    generator : str
        What wrote them (``"agvctl 0.2.0"``), written into both files.

    Returns
    -------
    WheelLoopsC
        The header and the source.
    """
    g = loops.gains
    constants = []
    for side, loop, last in zip(SIDES, loops.loops, (False, True), strict=True):
        margin_v = loop.R * loop.current_limit_a - 0.5 * loop.quantum_v
        constants.append(
            {
                "side": side,
                "last": last,
                "kp": g.kp,
                "ki_dt": g.ki * g.dt_s,
                "k_e": loop.k_e,
                "resistance_ohm": loop.R,
                "margin_v": margin_v,
                "brake_v": max(0.0, loop.R * loop.braking_current_limit_a - 0.5 * loop.quantum_v),
                "brake_below_rad_s": loop.braking_limit_below_rad_s,
                "voltage_min_v": loop.voltage_min_v,
                "voltage_max_v": loop.voltage_max_v,
                "feedforward_v": loop.tau_c * loop.R / loop.k_t if loop.coulomb_feedforward else 0.0,
                "standstill_rad_s": loop.standstill_rad_s,
            }
        )
    options = loops.options
    values = {
        "prefix": PREFIX,
        "guard": f"{PREFIX.upper()}_H",
        "macro": PREFIX.upper(),
        "origin": origin,
        "generator": generator,
        "sample_period_s": c_double(g.dt_s),
        "comment": (
            f"k_p = {g.kp:.6g} V s/rad, k_i = {g.ki:.6g} V/rad; coulomb_feedforward = "
            f"{str(options.coulomb_feedforward).lower()}, anti_windup = {str(options.anti_windup).lower()}, "
            f"braking = {options.braking.value}, steering_priority = {str(options.steering_priority).lower()}"
        ),
        "loops": constants,
        "feedforward_ramp_rad_s": FEEDFORWARD_RAMP_RAD_S,
        "amplifier_gain": loops.amplifier_gain,
        "anti_windup": int(options.anti_windup),
        "steering_priority": int(options.steering_priority),
    }
    env = c_templates("agvctl.controllers.pi")
    return WheelLoopsC(
        header=env.get_template("wheel_loops.h.j2").render(values),
        source=env.get_template("wheel_loops.c.j2").render(values),
    )


def compile_generated_c(code: GeneratedC, what: str) -> ctypes.CDLL:
    """``code`` compiled with :data:`STRICT_C_FLAGS` into the cache of compiled code (once) and loaded.

    Parameters
    ----------
    code : GeneratedC
        The generated C.
    what : str
        What it is, for the error message (``"wheel loops"``, ``"Ramsete law"``).

    Returns
    -------
    ctypes.CDLL
        The library.

    Raises
    ------
    AgvctlError
        No C compiler, or the compiler refused the code (its first message line).
    """
    try:
        return compiled_library(code.single_unit(), code.prefix, flags=(*STRICT_C_FLAGS, "-fPIC", "-shared"))
    except subprocess.CalledProcessError as exc:
        message = (exc.stderr or b"").decode(errors="replace").strip().splitlines()
        raise AgvctlError(f"the generated C of the {what} does not compile: {message[0] if message else exc}") from None
    except OSError as exc:
        raise AgvctlError(f"the generated C of the {what} cannot be compiled or loaded: {exc}") from None


def compile_wheel_loops(code: WheelLoopsC) -> ctypes.CDLL:
    """The wheel loops' C compiled and loaded (:func:`compile_generated_c`).

    Parameters
    ----------
    code : WheelLoopsC
        The generated C.

    Returns
    -------
    ctypes.CDLL
        The library, with ``<prefix>_init``, ``<prefix>_step``, ``<prefix>_state_size`` and
        ``<prefix>_constant_size``.

    Raises
    ------
    AgvctlError
        No C compiler, or the compiler refused the code (its first message line).
    """
    return compile_generated_c(code, "wheel loops")


@dataclass(frozen=True)
class StaticMemory:
    """The memory the generated loops use, all of it static (they allocate nothing).

    Parameters
    ----------
    state_bytes : int
        sizeof the state struct the caller owns, bytes.
    constant_bytes : int
        The ``static const`` data (gains and vehicle constants), bytes.
    """

    state_bytes: int
    constant_bytes: int


def _size_function(lib: ctypes.CDLL, name: str) -> Any:
    function = getattr(lib, name)
    function.restype = ctypes.c_size_t
    return function


def static_memory(code: WheelLoopsC) -> StaticMemory:
    """The state's and the constants' sizes, as the compiler lays them out (compiles ``code`` once).

    Parameters
    ----------
    code : WheelLoopsC
        The generated C.

    Returns
    -------
    StaticMemory
        The bytes of the state struct and of the constant data.

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.
    """
    return _memory_of(compile_wheel_loops(code), code.prefix)


def _memory_of(lib: ctypes.CDLL, prefix: str) -> StaticMemory:
    """The sizes a loaded library of the loops reports."""
    return StaticMemory(
        int(_size_function(lib, f"{prefix}_state_size")()), int(_size_function(lib, f"{prefix}_constant_size")())
    )


class CompiledPIWheelController:
    """The PI wheel loops as generated C, compiled and called through ctypes: a
    :class:`~agvctl.controllers.base.WheelSpeedController` and
    :class:`~agvctl.controllers.base.LimitReporting` one, with the outputs of
    :class:`~agvctl.controllers.pi.wheel_loop.PIWheelController` on the same inputs.

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's model.
    gains : PIGains
        The loops' gains.
    options : WheelLoopOptions or None
        The loops' choices (None: their defaults).

    Raises
    ------
    AgvctlError
        No C compiler, or the generated code does not compile.

    Examples
    --------
    >>> import numpy as np
    >>> from agvctl.params import load_vehicle
    >>> from agvctl.controllers.pi import default_pi_gains
    >>> vehicle = load_vehicle()
    >>> gains = default_pi_gains(vehicle).gains
    >>> c_loops, py_loops = CompiledPIWheelController(vehicle, gains), PIWheelController(vehicle, gains)
    >>> setpoint, measured = np.array([10.0, -4.0]), np.array([0.0, 1.0])
    >>> bool((c_loops.update(setpoint, measured) == py_loops.update(setpoint, measured)).all())
    True
    """

    def __init__(self, vehicle: VehicleParams, gains: PIGains, options: WheelLoopOptions | None = None) -> None:
        python = PIWheelController(vehicle, gains, options)
        self.code = render_wheel_loops_c(
            python, origin=f"PI wheel loops for vehicle {vehicle.name}", generator="agvctl (software-in-the-loop)"
        )
        lib = compile_wheel_loops(self.code)
        prefix = self.code.prefix
        self._init = getattr(lib, f"{prefix}_init")
        self._init.restype = None
        self._step = getattr(lib, f"{prefix}_step")
        self._step.restype = ctypes.c_uint
        self.memory = _memory_of(lib, prefix)
        """The C state's and constants' sizes."""
        self._state = (ctypes.c_double * -(-self.memory.state_bytes // 8))()  # caller-owned, double-aligned
        self._setpoint = (ctypes.c_double * 2)()
        self._measured = (ctypes.c_double * 2)()
        self._da = (ctypes.c_double * 2)()
        self._limited = (False, False)
        self.gains = gains
        self.options = python.options
        self.reset()

    def reset(self) -> None:
        """Zero both integrators (the C ``init``)."""
        self._init(self._state)
        self._limited = (False, False)

    @property
    def limited(self) -> tuple[bool, bool]:
        """Whether each loop's last output (left, right) was clamped to its window."""
        return self._limited

    def update(self, setpoint_rad_s: NDArray[np.float64], measured_rad_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """DA voltage commands (left, right) in V for one sample, from the C step.

        Parameters
        ----------
        setpoint_rad_s : ndarray
            The motor-speed setpoints (left, right), rad/s.
        measured_rad_s : ndarray
            The measured motor speeds (left, right), rad/s.

        Returns
        -------
        ndarray
            The DA voltages (left, right), V.
        """
        sp, meas, da = self._setpoint, self._measured, self._da
        sp[0], sp[1] = float(setpoint_rad_s[0]), float(setpoint_rad_s[1])
        meas[0], meas[1] = float(measured_rad_s[0]), float(measured_rad_s[1])
        mask = self._step(self._state, sp, meas, da)
        self._limited = (bool(mask & 1), bool(mask & 2))
        return np.array([da[0], da[1]])

    def compiled_step(self) -> CStep:
        """The C step and its state, for a closed loop run in C (:class:`~agvctl.controllers.base.CompiledStep`).

        Returns
        -------
        CStep
            The addresses of ``agv_wheel_loops_step`` and of the state.
        """
        address = ctypes.cast(self._step, ctypes.c_void_p).value
        assert address is not None
        return CStep(address, ctypes.addressof(self._state))
