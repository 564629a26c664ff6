"""The LTV MPC's QP step as generated C (:mod:`~agvctl.controllers.mpc.c_step`) in the loop: its state, the present
reference's tables, and the call through ctypes.

A step holds the solver's lock and state (:meth:`CompiledQp.held <agvctl.controllers.mpc.c_solver.CompiledQp.held>`)
while it runs, as every call into a generated solver does, so several controllers of the same QP in one process never
see each other's solver."""

from __future__ import annotations

import ctypes
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agvctl.controllers.mpc.c_solver import CompiledQp, QpInfo, QpSolverError
from agvctl.controllers.mpc.c_step import SOLVED, STEP_ERROR, StepC
from agvctl.controllers.mpc.qp_blocks import BlockQp
from agvctl.errors import AgvctlError

__all__ = ["CompiledStep", "StepInput"]

FloatArray = NDArray[np.float64]


class StepInput(ctypes.Structure):
    """What the controller measured and decided before the QP, for one step (the step's ``<prefix>_input``)."""

    _fields_ = [
        ("k", ctypes.c_int),
        ("fraction", ctypes.c_double),
        ("pose", ctypes.c_double * 3),
        ("wheel", ctypes.c_double * 2),
        ("previous", ctypes.c_double * 2),
        ("window_lower", ctypes.c_double * 2),
        ("window_upper", ctypes.c_double * 2),
        ("lead_down", ctypes.c_double * 2),
        ("lead_up", ctypes.c_double * 2),
    ]

    def set(
        self,
        k: int,
        fraction: float,
        pose: FloatArray,
        wheel_speed_m_s: FloatArray,
        previous_m_s: FloatArray,
        window: Any,
    ) -> None:
        """Fill the structure for one step.

        Parameters
        ----------
        k : int
            The window's first grid point.
        fraction : float
            How far the governed clock lies past it, in samples.
        pose : ndarray
            The pose (x, y, θ).
        wheel_speed_m_s : ndarray
            The measured wheel speeds (left, right), m/s.
        previous_m_s : ndarray
            The previous command (left, right), m/s.
        window : SetpointWindow or None
            Where the setpoints can be reached (None: a broken measurement, NaN in C).
        """
        self.k = k
        self.fraction = fraction
        self.pose[0], self.pose[1], self.pose[2] = pose[0], pose[1], pose[2]
        self.wheel[0], self.wheel[1] = wheel_speed_m_s[0], wheel_speed_m_s[1]
        self.previous[0], self.previous[1] = previous_m_s[0], previous_m_s[1]
        if window is None:
            nan = math.nan
            self.window_lower[0] = self.window_lower[1] = self.window_upper[0] = self.window_upper[1] = nan
            self.lead_down[0] = self.lead_down[1] = self.lead_up[0] = self.lead_up[1] = nan
        else:
            self.window_lower[0], self.window_lower[1] = window.lower_m_s
            self.window_upper[0], self.window_upper[1] = window.upper_m_s
            self.lead_down[0], self.lead_down[1] = window.lead_down_m_s
            self.lead_up[0], self.lead_up[1] = window.lead_up_m_s


class CompiledStep:
    """A generated QP step in the loop: its state, the present reference's tables, and the call.

    Parameters
    ----------
    solver : CompiledQp
        The QP's generated solver, compiled with the step (``GeneratedOsqp(..., step=code).solver``): the step
        solves with it, under its lock and with its state.
    code : StepC
        The step's C.
    """

    def __init__(self, solver: CompiledQp, code: StepC) -> None:
        p, library = code.prefix, solver.library
        self.code = code
        self._hold = solver.held
        self._start = getattr(library, f"{p}_start")
        self._start.argtypes = [ctypes.c_void_p] * 6
        self._start.restype = None
        self._solve = getattr(library, f"{p}_solve")
        self._solve.argtypes = [ctypes.c_void_p] * 5
        self._solve.restype = ctypes.c_int
        size = int(getattr(library, f"{p}_state_size")())
        self._state = np.zeros(size, dtype=np.uint8)
        self._tables = (ctypes.c_void_p * len(code.table_names))()
        self._kept: list[FloatArray] = []
        self._input = StepInput()
        self._correction = np.empty(2 * code.horizon)
        self._addresses: tuple[int, ...] = ()

    def start(self, qp: BlockQp[Any, Any], tables: Sequence[FloatArray]) -> None:
        """Start a reference: its tables, and the QP's vectors as they are.

        Parameters
        ----------
        qp : BlockQp
            The QP after set-up (the fixed parts of its vectors written).
        tables : sequence of ndarray
            The reference's tables (:func:`step_tables`).
        """
        if len(tables) != len(self._tables):
            raise AgvctlError(f"the QP step reads {len(self._tables)} tables, given {len(tables)}")
        self._kept = [np.ascontiguousarray(t, dtype=np.float64) for t in tables]
        for i, table in enumerate(self._kept):
            self._tables[i] = table.ctypes.data
        vectors = [qp.q, qp.lower, qp.upper, qp.p_data[qp.p_varying], qp.a_data[qp.a_varying]]
        arrays = [np.ascontiguousarray(v, dtype=np.float64) for v in vectors]
        self._start(self._state.ctypes.data, *(a.ctypes.data for a in arrays))
        self._info = QpInfo()
        self._addresses = (
            int(self._state.ctypes.data),
            ctypes.addressof(self._tables),
            ctypes.addressof(self._input),
            int(self._correction.ctypes.data),
            ctypes.addressof(self._info),
        )

    def solve(
        self,
        k: int,
        fraction: float,
        pose: FloatArray,
        wheel_speed_m_s: FloatArray,
        previous_m_s: FloatArray,
        window: Any,
    ) -> FloatArray | None:
        """One step (see the module's description).

        Parameters
        ----------
        k : int
            The window's first grid point.
        fraction : float
            How far the governed clock lies past it, in samples.
        pose : ndarray
            The pose (x, y, θ).
        wheel_speed_m_s : ndarray
            The measured wheel speeds (left, right), m/s.
        previous_m_s : ndarray
            The previous command (left, right), m/s.
        window : SetpointWindow or None
            Where the setpoints can be reached (None: a broken measurement).

        Returns
        -------
        ndarray or None
            The setpoints' corrections (N × 2), or None where the solver did not solve or the measurement is broken.

        Raises
        ------
        QpSolverError
            An OSQP call failed.
        """
        self._input.set(k, fraction, pose, wheel_speed_m_s, previous_m_s, window)
        with self._hold():
            result = self._solve(*self._addresses)
        if result == STEP_ERROR:
            raise QpSolverError(f"the generated QP step's solver failed: OSQP exit flag {self._info.error}")
        if result != SOLVED:
            return None
        return self._correction.reshape(-1, 2).copy()
