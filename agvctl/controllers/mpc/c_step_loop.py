"""The LTV MPC's step as generated C in the loop: the QP's step (:mod:`~agvctl.controllers.mpc.c_step`) and the
controller's around it (:mod:`~agvctl.controllers.mpc.c_update`), their state, the controller's settings, the present
reference's tables, and the calls through ctypes; and the QP step's input as a ctypes structure, for calling a
generated step from Python.

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

from agvctl.controllers.mpc.c_solver import CompiledQp, QpInfo
from agvctl.controllers.mpc.c_step import MpcPartC, StepC
from agvctl.controllers.mpc.c_update import UPDATE_SETTINGS
from agvctl.controllers.mpc.qp_blocks import BlockQp
from agvctl.errors import AgvctlError

__all__ = ["CompiledController", "StepInput"]

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


class CompiledController:
    """The generated controller step (:mod:`~agvctl.controllers.mpc.c_update`) in the loop: its state (the QP step's
    within it), its settings, the present reference's tables, and the calls.

    Parameters
    ----------
    solver : CompiledQp
        The QP's generated solver, compiled with the step and the controller's step.
    step : StepC
        The QP step's C.
    update : MpcPartC
        The controller step's C.
    """

    def __init__(self, solver: CompiledQp, step: StepC, update: MpcPartC) -> None:
        library, p = solver.library, update.prefix
        self._hold = solver.held
        self.horizon = update.horizon

        def function(name: str, restype: Any, *argtypes: Any) -> Any:
            f = getattr(library, name)
            f.argtypes, f.restype = list(argtypes), restype
            return f

        pointer = ctypes.c_void_p
        self._start = function(f"{step.prefix}_start", None, *[pointer] * 6)
        self._reset = function(f"{p}_reset", None, pointer)
        self._track = function(f"{p}_track", None, pointer)
        self._observe = function(f"{p}_observe", None, pointer, pointer)
        self._clock = function(f"{p}_clock", ctypes.c_double, pointer)
        self._sequence = function(f"{p}_sequence", ctypes.c_int, pointer, pointer)
        self._update = function(
            f"{p}_update", ctypes.c_int, *[pointer] * 3, ctypes.c_double, ctypes.c_int, ctypes.c_int, *[pointer] * 4
        )
        self._state = np.zeros(int(getattr(library, f"{p}_state_size")()), dtype=np.uint8)
        self.settings = np.zeros(len(UPDATE_SETTINGS))
        """The controller's numbers, by :data:`~agvctl.controllers.mpc.c_update.UPDATE_SETTINGS`."""
        self._index = {name: i for i, name in enumerate(UPDATE_SETTINGS)}
        self._tables = (ctypes.c_void_p * len(step.table_names))()
        self._kept: list[FloatArray] = []
        self._pose, self._wheel, self._command = np.empty(3), np.empty(2), np.empty(2)
        self._info = QpInfo()
        self._address = int(self._state.ctypes.data)
        self._arguments = (
            int(self.settings.ctypes.data),
            ctypes.addressof(self._tables),
        )
        self._buffers = (
            int(self._pose.ctypes.data),
            int(self._wheel.ctypes.data),
            int(self._command.ctypes.data),
            ctypes.addressof(self._info),
        )

    def set(self, **values: float) -> None:
        """Set numbers of :attr:`settings` by name.

        Parameters
        ----------
        **values
            Names of :data:`~agvctl.controllers.mpc.c_update.UPDATE_SETTINGS` and their values.
        """
        for name, value in values.items():
            self.settings[self._index[name]] = value

    def start(self, qp: BlockQp[Any, Any], tables: Sequence[FloatArray]) -> None:
        """Start the QP's step on a reference: its tables, and the QP's vectors as they are.

        Parameters
        ----------
        qp : BlockQp
            The QP after set-up.
        tables : sequence of ndarray
            The reference's tables (:func:`~agvctl.controllers.mpc.c_step.step_tables`).
        """
        if len(tables) != len(self._tables):
            raise AgvctlError(f"the QP step reads {len(self._tables)} tables, given {len(tables)}")
        self._kept = [np.ascontiguousarray(t, dtype=np.float64) for t in tables]
        for i, table in enumerate(self._kept):
            self._tables[i] = table.ctypes.data
        vectors = [qp.q, qp.lower, qp.upper, qp.p_data[qp.p_varying], qp.a_data[qp.a_varying]]
        arrays = [np.ascontiguousarray(v, dtype=np.float64) for v in vectors]
        self._start(self._address, *(a.ctypes.data for a in arrays))  # the QP step's state comes first

    def reset(self) -> None:
        """A new path (see ``<prefix>_reset``)."""
        self._reset(self._address)

    def track(self) -> None:
        """A new reference (see ``<prefix>_track``)."""
        self._track(self._address)

    def observe(self, covariance: FloatArray) -> None:
        """The pose estimate's 3×3 covariance at this sample.

        Parameters
        ----------
        covariance : ndarray
            3×3, m², m rad, rad².
        """
        values = np.ascontiguousarray(covariance, dtype=np.float64).reshape(9)
        self._observe(self._address, values.ctypes.data)

    @property
    def clock(self) -> float:
        """The governed clock in samples (−1: not started)."""
        return float(self._clock(self._address))

    def sequence(self) -> FloatArray:
        """The last solved setpoints (N × 2), m/s."""
        out = np.empty(2 * self.horizon)
        self._sequence(self._address, out.ctypes.data)
        return out.reshape(-1, 2)

    def update(
        self, local_time_s: float, on_main_path: bool, done: bool, pose: FloatArray, wheel_speed_m_s: FloatArray
    ) -> tuple[int, float, float]:
        """One sample (see ``<prefix>_update``).

        Parameters
        ----------
        local_time_s : float
            The time on the present reference, s.
        on_main_path : bool
            The reference is the path itself.
        done : bool
            The controller is done with its references.
        pose : ndarray
            x, y, θ.
        wheel_speed_m_s : ndarray
            The measured wheel speeds, m/s.

        Returns
        -------
        tuple
            The code (0 solved or held, 1 the shifted sequence, 2 the feed-forward) and the setpoints (left, right),
            m/s.
        """
        self._pose[:] = pose
        self._wheel[:] = wheel_speed_m_s
        with self._hold():
            code = self._update(self._address, *self._arguments, local_time_s, on_main_path, done, *self._buffers)
        left, right = self._command.tolist()
        return int(code), left, right
