"""The plant stepper: measure → actuate → integrate → record, one sample at a time (do-mpc's ``make_step``).

Every loop of the package drives the plant through :class:`PlantStepper`, so each of the four parts exists once:

* **measure**: the motor speeds at t_k as the encoders see them — the dead zone of the pre-velocity state
  (eq 2, :func:`agvctl.plant.friction.motor_speed`);
* **actuate**: the DA voltage command through the DA converter and amplifier (:class:`~agvctl.actuator.Actuator`);
* **integrate**: the compiled full model over [t_k, t_k+1) with the motor voltage held (the sample-and-hold rule:
  the update at t_k sees the state just before it);
* **record**: one row of :data:`~agvctl.log.PLANT_LOG_COLUMNS`, every column picked by name.

:meth:`PlantStepper.step` is one sample with feedback; :meth:`PlantStepper.run` applies a whole sequence of
commands without feedback in compiled chunks (the open-loop simulator), recorded the same way. A loop of unknown
length (a calibration experiment that runs until a wheel turns) just keeps calling :meth:`~PlantStepper.step`::

    stepper = PlantStepper(vehicle)
    while ...:
        omega = stepper.measure()
        stepper.step(controller.update(setpoint, omega))
    stepper.finish()
    log = stepper.log()
"""

from __future__ import annotations

import operator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agvctl.actuator import Actuator, ActuatorOutput
from agvctl.log import PLANT_LOG_COLUMNS, SimLog
from agvctl.params import VehicleParams
from agvctl.plant.friction import motor_speed
from agvctl.plant.full import AUX_NAMES, STATE_NAMES, PlantOptions, parameter_vector
from agvctl.plant.integrator import STATS_NAMES, CompiledPlant, compiled_plant, sample_splits

__all__ = ["PlantStepper", "instant_stats", "plant_log_rows"]

FloatArray = NDArray[np.float64]

_SIDES = ("left", "right")
_SOURCES = (
    "t_s",
    *(f"da_code_{s}" for s in _SIDES),
    *(f"da_voltage_{s}_v" for s in _SIDES),
    *(f"da_clipped_{s}" for s in _SIDES),
    *(f"motor_voltage_{s}_v" for s in _SIDES),
    *(f"aux.{name}" for name in AUX_NAMES),
    *STATS_NAMES,
    *(f"current_limited_{s}" for s in _SIDES),
    *(f"state.{name}" for name in STATE_NAMES),
)
"""The quantities a row is made from, in the order :func:`plant_log_rows` stacks them."""


def _source_of(column: str) -> int:
    for name in (column, f"aux.{column}", f"state.{column}"):
        if name in _SOURCES:
            return _SOURCES.index(name)
    raise KeyError(column)


_PICK = np.array([_source_of(name) for name in PLANT_LOG_COLUMNS])
"""Where each log column comes from: by name, once."""
_PICK_ONE = operator.itemgetter(*_PICK.tolist())
"""The same for one sample's quantities in a list: the row as a tuple."""
_LIMITED = [STATS_NAMES.index(f"current_limited_fraction_{s}") for s in _SIDES]

_AUX = {name: i for i, name in enumerate(AUX_NAMES)}
_ANGLE_LEFT = STATS_NAMES.index("motor_angle_increment_left_rad")
assert STATS_NAMES[_ANGLE_LEFT + 1] == "motor_angle_increment_right_rad"
_ANGLE = slice(_ANGLE_LEFT, _ANGLE_LEFT + 2)
"""The motor angles turned over an interval (left, right): adjacent statistics."""
_INSTANT_STATS = {
    **{f"current_limited_fraction_{s}": (f"current_limited_{s}", False) for s in _SIDES},
    **{f"current_peak_{s}_a": (f"current_{s}_a", True) for s in _SIDES},
    **{f"wheel_accel_peak_{s}_m_s2": (f"wheel_accel_{s}_m_s2", True) for s in _SIDES},
}
"""Each interval statistic at one instant: the auxiliary output it summarises, and whether its peak is of |·|."""


def instant_stats(aux: FloatArray) -> FloatArray:
    """The statistics of :data:`~agvctl.plant.integrator.STATS_NAMES` at one instant: the final row of a log, where
    no interval follows (no angle turned).

    Parameters
    ----------
    aux : ndarray
        The auxiliaries (:data:`~agvctl.plant.full.AUX_NAMES`) at the instant, … × 10.

    Returns
    -------
    ndarray
        The statistics, … × 8: fractions and peaks of that instant, increments zero.
    """
    cols = []
    for name in STATS_NAMES:
        if name not in _INSTANT_STATS:  # an increment over an interval of zero length
            cols.append(np.zeros(aux.shape[:-1]))
            continue
        source, absolute = _INSTANT_STATS[name]
        value = aux[..., _AUX[source]]
        cols.append(np.abs(value) if absolute else value)
    return np.stack(cols, axis=-1)


def plant_log_rows(
    t_s: ArrayLike, actuated: ActuatorOutput, aux: FloatArray, stats: FloatArray, state: FloatArray
) -> FloatArray:
    """Rows of :data:`~agvctl.log.PLANT_LOG_COLUMNS` for m samples.

    Parameters
    ----------
    t_s : array_like
        The samples' times (m), s.
    actuated : ActuatorOutput
        What the actuator chain did at each (m × 2 each).
    aux : ndarray
        The auxiliaries (:data:`~agvctl.plant.full.AUX_NAMES`) at each sample's start, m × 10.
    stats : ndarray
        The statistics over each sample's interval (:data:`~agvctl.plant.integrator.STATS_NAMES`), m × 8.
    state : ndarray
        The plant states at the samples (:data:`~agvctl.plant.full.STATE_NAMES`), m × 5.

    Returns
    -------
    ndarray
        m × columns, in the order of :data:`~agvctl.log.PLANT_LOG_COLUMNS`.
    """
    limited = stats[:, _LIMITED] > 0
    parts = (
        np.reshape(t_s, (-1, 1)),
        actuated.da_code,
        actuated.da_voltage_v,
        actuated.da_clipped,
        actuated.motor_voltage_v,
        aux,
        stats,
        limited,
        state,
    )
    rows = np.concatenate([np.asarray(p, dtype=np.float64).reshape(len(stats), -1) for p in parts], axis=1)
    return np.asarray(rows[:, _PICK], dtype=np.float64)


def _plant_log_row(
    t_s: float, actuated: ActuatorOutput, aux: FloatArray, stats: FloatArray, state: FloatArray
) -> tuple[float, ...]:
    """One row of :func:`plant_log_rows` for one sample (actuator outputs of one pair, vectors of auxiliaries,
    statistics and state), in plain Python numbers: a per-sample record, where numpy's per-call cost would
    dominate. The same quantities in the same order as :func:`plant_log_rows` stacks them (:data:`_SOURCES`)."""
    limited = [float(stats[j] > 0) for j in _LIMITED]
    sources = [
        t_s,
        *actuated.da_code.ravel().tolist(),
        *actuated.da_voltage_v.ravel().tolist(),
        *actuated.da_clipped.ravel().tolist(),
        *actuated.motor_voltage_v.ravel().tolist(),
        *aux.tolist(),
        *stats.tolist(),
        *limited,
        *state.tolist(),
    ]
    row: tuple[float, ...] = _PICK_ONE(sources)
    return row


class PlantStepper:
    """The true vehicle's actuator chain and full plant, advanced and recorded one sample at a time.

    Parameters
    ----------
    vehicle
        The simulated truth (its parameters, DA converter, amplifier and sample period T_s in s).
    initial_state
        The plant state (:data:`~agvctl.plant.full.STATE_NAMES`: pre-velocities in rad/s, x_m, y_m, theta_rad);
        default at rest at the origin.
    options
        Plant options (friction, current limit); default :class:`~agvctl.plant.full.PlantOptions`.
    """

    def __init__(
        self, vehicle: VehicleParams, *, initial_state: ArrayLike | None = None, options: PlantOptions | None = None
    ) -> None:
        self.plant: CompiledPlant = compiled_plant(options)
        self.sample_period_s = vehicle.control.sample_period_s
        self._splits = sample_splits(vehicle)
        self._p = parameter_vector(vehicle)
        self._actuator = Actuator(vehicle)
        self._friction = (options or PlantOptions()).friction
        d = vehicle.derived
        self._stiction_n_m = (vehicle.motor.left.stiction_n_m, vehicle.motor.right.stiction_n_m)
        self._friction_gain_p = (d.left.friction_gain_p, d.right.friction_gain_p)
        x0 = np.zeros(len(STATE_NAMES)) if initial_state is None else np.asarray(initial_state, dtype=float)
        self.state: FloatArray = np.array(x0, dtype=float)
        """The plant state at the current sample time."""
        self.k = 0
        """The index of the current sample (t_k = k·T_s)."""
        self.motor_angle_rad: FloatArray = np.zeros(2)
        """The motor shafts' angles (left, right) turned since the start, in rad: what the encoders count."""
        self._rows: list[FloatArray] = []
        """Blocks of recorded rows; the rows of single samples gather in :attr:`_sample_rows` first."""
        self._sample_rows: list[tuple[float, ...]] = []
        self._last: ActuatorOutput | None = None

    @property
    def pose(self) -> FloatArray:
        """The true pose (x_m, y_m, theta_rad) at the current sample time."""
        return np.array(self.state[2:5])

    def measure(self) -> FloatArray:
        """The motor speeds (left, right) in rad/s at t_k: the dead zone of the pre-velocity (eq 2)."""
        pre = self.state[:2]
        if not self._friction:
            return np.array(pre)
        tau_s, gain_p = self._stiction_n_m, self._friction_gain_p
        return np.array([motor_speed(w, tau_s[i], gain_p[i]) for i, w in enumerate(pre.tolist())])

    def step(self, da_command_v: ArrayLike) -> ActuatorOutput:
        """Actuate ``da_command_v`` (left, right, V), record row k and integrate to t_k+1."""
        out = self._actuator.apply(da_command_v)
        x_next, aux, stats = self.plant.step(
            self.state, out.motor_voltage_v, self._p, self.sample_period_s, self._splits
        )
        self._record(out, aux, stats)
        self.state = x_next
        self.motor_angle_rad = self.motor_angle_rad + stats[_ANGLE]
        self.k += 1
        return out

    def finish(self, da_command_v: ArrayLike | None = None) -> ActuatorOutput:
        """Record the final row: the state at the end with ``da_command_v`` (default: the last command) applied,
        not integrated further."""
        if da_command_v is None:
            if self._last is None:
                raise RuntimeError("PlantStepper.finish: no command yet")
            out = self._last
        else:
            out = self._actuator.apply(da_command_v)
        aux = self.plant.aux(self.state, np.asarray(out.motor_voltage_v, dtype=float), self._p)
        self._record(out, aux, instant_stats(aux))
        return out

    def run(self, da_commands_v: ArrayLike) -> None:
        """Apply n commands (n × 2, V) without feedback, each held over one sample, in compiled chunks."""
        out = self._actuator.apply(da_commands_v)
        u = np.asarray(out.motor_voltage_v, dtype=float)
        X, A, S = self.plant.run(self.state, u, self._p, self.sample_period_s, self._splits)
        self._append(da_commands_v, out, X, A, S)

    def append(self, da_commands_v: ArrayLike, states: FloatArray, aux: FloatArray, stats: FloatArray) -> FloatArray:
        """Record n samples that C integrated from the current state with this stepper's plant and parameters (a
        closed loop run in C, :mod:`agvctl.sim.compiled_loop`), as :meth:`step` would have recorded them.

        Parameters
        ----------
        da_commands_v : array_like
            The DA voltage commands (left, right), n × 2, V.
        states : ndarray
            The states at the n + 1 sample times, from the current one, (n + 1) × 5.
        aux : ndarray
            The auxiliaries at each sample's start, n × 10.
        stats : ndarray
            The statistics over each sample (its sub-samples' merged), n × 8.

        Returns
        -------
        ndarray
            The motor angles (left, right) turned since the start at the n + 1 sample times, rad, (n + 1) × 2:
            what :attr:`motor_angle_rad` was at each.
        """
        return self._append(da_commands_v, self._actuator.apply(da_commands_v), states, aux, stats)

    @property
    def parameters(self) -> FloatArray:
        """The plant's parameter vector (:data:`~agvctl.plant.full.PARAMETER_NAMES`)."""
        return self._p

    @property
    def splits(self) -> int:
        """Sub-samples per sample (:func:`~agvctl.plant.integrator.sample_splits`)."""
        return self._splits

    @property
    def actuator(self) -> Actuator:
        """The true vehicle's DA converter and amplifier."""
        return self._actuator

    @property
    def dead_zone_rad_s(self) -> tuple[float, float] | None:
        """The half-width τ_s/P of each motor's speed dead zone (eq 2) that :meth:`measure` applies; None
        without friction."""
        if not self._friction:
            return None
        (tau_l, tau_r), (p_l, p_r) = self._stiction_n_m, self._friction_gain_p
        return tau_l / p_l, tau_r / p_r

    def _append(
        self, da_commands_v: ArrayLike, out: ActuatorOutput, X: FloatArray, A: FloatArray, S: FloatArray
    ) -> FloatArray:
        """Record n samples integrated as a block; the motor angles at the n + 1 sample times, summed one sample
        after the other as :meth:`step` sums them."""
        n = len(S)
        t = (self.k + np.arange(n)) * self.sample_period_s
        self._flush()
        self._rows.append(plant_log_rows(t, out, A, S, X[:-1]))
        self._last = self._actuator.apply(np.asarray(da_commands_v, dtype=float)[-1])
        self.state = X[-1]
        angles: FloatArray = np.cumsum(np.vstack([self.motor_angle_rad, S[:, _ANGLE]]), axis=0)
        self.motor_angle_rad = angles[-1]
        self.k += n
        return angles

    def _record(self, out: ActuatorOutput, aux: FloatArray, stats: FloatArray) -> None:
        self._sample_rows.append(_plant_log_row(self.k * self.sample_period_s, out, aux, stats, self.state))
        self._last = out

    def _flush(self) -> None:
        """The single samples' rows gathered so far as one block of :attr:`_rows`."""
        if self._sample_rows:
            self._rows.append(np.array(self._sample_rows, dtype=np.float64))
            self._sample_rows = []

    def log(self) -> SimLog:
        """The rows recorded so far, as a :class:`~agvctl.log.SimLog`."""
        self._flush()
        rows = np.vstack(self._rows) if self._rows else np.zeros((0, len(PLANT_LOG_COLUMNS)))
        return SimLog({name: rows[:, j] for j, name in enumerate(PLANT_LOG_COLUMNS)})
