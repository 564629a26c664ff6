"""Friction identification, the report's appendix A.1 (eqs 65-69, corrected per ``shared/reference/ERRATA.md``).

Two experiments per side, on the vehicle's own speed loops and DA converter:

1. **Constant speeds.** The PI loops hold both motors at N constant speeds (forward and reverse). In a steady
   window the armature balance (eq 1, inductance neglected) with the friction of eqs 2-4 in sliding reads, per
   side and on average over the window,

       k_pow k_t ū / R − k_e k_t ω̄ / R = f_m ω̄ + τ_c sign(ω̄)                        (steady state, ERRATA)

   with u the DA voltage (the control input of eqs 65-69, which the amplifier multiplies by k_pow). The left side
   is known from the log and the motor constants; least squares over the windows gives f_m and τ_c. With two
   speeds in one direction this is the report's two-speed formula, eqs 66-67 (68-69 for the right side), as
   corrected in the ERRATA: ``τ_c = k_pow k_t u₂/R − (k_e k_t/R + f_m) ω₂`` (:func:`two_speed_friction`).
2. **Slow voltage ramp.** From standstill the DA voltage of one side rises slowly until the wheel turns. While it
   sticks the motor does not move, so the drive torque is k_pow k_t u/R (eq 65 as corrected: the amplifier gain
   multiplies, and the measured torque is the break-away torque τ_s itself, not τ_c + τ_s).

The log format is :data:`FRICTION_LOG_COLUMNS`; :func:`simulate_friction_experiment` produces one on the
simulator, :func:`read_friction_log` reads a user's, :func:`fit_friction` fits either.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from agvctl.actuator import Actuator
from agvctl.calibration.common import Estimate, read_csv_columns
from agvctl.controllers.pi import PIWheelController
from agvctl.controllers.tuning import design_pi
from agvctl.errors import ConfigError
from agvctl.params import MotorParams, VehicleParams
from agvctl.plant.full import AUX_NAMES, STATE_NAMES, parameter_vector
from agvctl.sim.integrator import compiled_plant, sample_splits

__all__ = [
    "FRICTION_LOG_COLUMNS",
    "FrictionExperiment",
    "FrictionFit",
    "FrictionLog",
    "HoldWindow",
    "SPEED_NOISE_RAD_S",
    "SideFriction",
    "apply_friction",
    "fit_friction",
    "read_friction_log",
    "simulate_friction_experiment",
    "two_speed_friction",
]

Side = Literal["left", "right"]
SIDES: tuple[Side, Side] = ("left", "right")

FRICTION_LOG_COLUMNS: dict[str, str] = {
    "t_s": "sample time (s), one row per control sample",
    "phase": "'hold' (the speed loops hold a constant setpoint), 'ramp' (open-loop slow DA ramp from standstill) "
    "or anything else (ignored, e.g. 'idle')",
    "setpoint_omega_motor_left_rad_s": "left speed-loop setpoint, motor shaft (rad/s); constant within a hold "
    "window, ignored elsewhere",
    "setpoint_omega_motor_right_rad_s": "right speed-loop setpoint (rad/s)",
    "omega_motor_left_rad_s": "measured left motor speed (rad/s)",
    "omega_motor_right_rad_s": "measured right motor speed (rad/s)",
    "da_voltage_left_v": "left DA converter output (V): the control input u of eqs 65-69, before the amplifier",
    "da_voltage_right_v": "right DA converter output (V)",
}
"""The friction log's columns (CSV with a header row; other columns are ignored). Values must be finite."""

SPEED_NOISE_RAD_S = 0.5
"""Standard deviation of the simulated motor-speed measurement noise at ``noise_scale = 1`` (rad/s; 0.15 % of
the top motor speed, about 1.4 mm/s at the rim)."""


@dataclass(frozen=True)
class FrictionExperiment:
    """How the simulated friction experiment is driven (and what a real one should look like)."""

    motor_speeds_rad_s: tuple[float, ...] = (50.0, 100.0, 150.0, 200.0)
    """The constant motor speeds the speed loops hold, both sides alike (straight line)."""
    both_directions: bool = True
    """Hold every speed forward and in reverse (separates τ_c from an offset; averages direction effects)."""
    settle_s: float = 1.5
    """Time given to reach each speed before the steady window."""
    hold_s: float = 3.0
    """Length of each steady window."""
    rest_s: float = 1.0
    """Standstill between experiments (0 V)."""
    ramp_rate_da_v_s: float = 0.05
    """DA voltage ramp rate for the break-away experiment (V/s; 2 mV, under one DA code, per 40 ms sample)."""
    ramp_repeats: int = 1
    """Ramps per side and direction (forward and reverse each)."""
    ramp_stop_speed_rad_s: float = 5.0
    """The simulated experimenter ends a ramp once the measured speed passes this (the wheel clearly turns)."""

    def __post_init__(self) -> None:
        if not self.motor_speeds_rad_s or any(not (math.isfinite(w) and w > 0) for w in self.motor_speeds_rad_s):
            raise ValueError(f"motor_speeds_rad_s must be positive numbers (got {self.motor_speeds_rad_s})")
        for name in ("settle_s", "hold_s", "rest_s", "ramp_rate_da_v_s", "ramp_stop_speed_rad_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"FrictionExperiment.{name} must be > 0 (got {value})")
        if self.ramp_repeats < 1:
            raise ValueError(f"FrictionExperiment.ramp_repeats must be >= 1 (got {self.ramp_repeats})")


@dataclass(frozen=True)
class FrictionLog:
    """A friction experiment's log, one row per control sample (columns as :data:`FRICTION_LOG_COLUMNS`)."""

    t_s: NDArray[np.float64]
    phase: tuple[str, ...]
    setpoint_rad_s: NDArray[np.float64]
    """n × 2 speed-loop setpoints (left, right), motor shaft."""
    omega_motor_rad_s: NDArray[np.float64]
    """n × 2 measured motor speeds (left, right)."""
    da_voltage_v: NDArray[np.float64]
    """n × 2 DA output voltages (left, right): the control input u of eqs 65-69."""
    source: str = "<simulated>"
    """Where the log came from (for error messages)."""

    def columns(self) -> dict[str, NDArray[np.float64]]:
        """The numeric columns by their CSV names (``phase`` is text; see :meth:`write_csv`)."""
        return {
            "t_s": self.t_s,
            "setpoint_omega_motor_left_rad_s": self.setpoint_rad_s[:, 0],
            "setpoint_omega_motor_right_rad_s": self.setpoint_rad_s[:, 1],
            "omega_motor_left_rad_s": self.omega_motor_rad_s[:, 0],
            "omega_motor_right_rad_s": self.omega_motor_rad_s[:, 1],
            "da_voltage_left_v": self.da_voltage_v[:, 0],
            "da_voltage_right_v": self.da_voltage_v[:, 1],
        }

    def write_csv(self, path: str | Path) -> None:
        """Write the log as CSV in the :data:`FRICTION_LOG_COLUMNS` format (atomically)."""
        from agvctl.fileio import atomic_open

        cols = self.columns()
        names = ["t_s", "phase", *[n for n in cols if n != "t_s"]]
        with atomic_open(path) as fh:
            fh.write(",".join(names) + "\n")
            for i in range(len(self.t_s)):
                cells = [f"{self.t_s[i]:.12g}", self.phase[i], *(f"{cols[n][i]:.12g}" for n in names[2:])]
                fh.write(",".join(cells) + "\n")


def read_friction_log(path: str | Path) -> FrictionLog:
    """Read a friction log (CSV, :data:`FRICTION_LOG_COLUMNS`). Missing columns, empty or non-finite cells:
    :class:`ConfigError` naming the column or row."""
    numeric = [c for c in FRICTION_LOG_COLUMNS if c != "phase"]
    values, text = read_csv_columns(path, numeric, ["phase"])
    return FrictionLog(
        t_s=values["t_s"],
        phase=tuple(p.lower() for p in text["phase"]),
        setpoint_rad_s=np.column_stack([values["setpoint_omega_motor_left_rad_s"],
                                        values["setpoint_omega_motor_right_rad_s"]]),
        omega_motor_rad_s=np.column_stack([values["omega_motor_left_rad_s"], values["omega_motor_right_rad_s"]]),
        da_voltage_v=np.column_stack([values["da_voltage_left_v"], values["da_voltage_right_v"]]),
        source=str(path),
    )


# ----------------------------------------------------------------------------------------------------------------
# Simulation


def simulate_friction_experiment(
    plant_vehicle: VehicleParams,
    controller_vehicle: VehicleParams,
    experiment: FrictionExperiment | None = None,
    *,
    noise_scale: float = 0.0,
    seed: int | None = None,
) -> FrictionLog:
    """Run the friction experiment on the full nonlinear plant and return its log.

    ``plant_vehicle`` is the truth; the PI loops are designed for, and know only, ``controller_vehicle`` (no
    friction feed-forward). Every command goes through the DA converter and amplifier
    (:class:`~agvctl.actuator.Actuator`). The measured motor speeds carry white Gaussian noise of
    ``noise_scale`` × :data:`SPEED_NOISE_RAD_S`; the controller sees the noisy speeds, as a real one would.

    Sequence: the speed loops hold each of ``experiment.motor_speeds_rad_s`` (then the same in reverse) for
    ``settle_s + hold_s`` (phase ``hold``); a stop (``idle``); then, one side at a time with the other at 0 V, a
    DA ramp from 0 V at ``ramp_rate_da_v_s`` until the wheel turns (``ramp``), forward then reverse, each
    followed by ``rest_s`` at 0 V (``idle``).
    """
    exp = experiment or FrictionExperiment()
    if not (math.isfinite(noise_scale) and noise_scale >= 0):
        raise ValueError(f"noise_scale must be >= 0 (got {noise_scale})")
    rng = np.random.default_rng(seed)
    sigma = noise_scale * SPEED_NOISE_RAD_S
    ts = plant_vehicle.control.sample_period_s
    plant = compiled_plant()
    splits = sample_splits(plant_vehicle)
    p = parameter_vector(plant_vehicle)
    actuator = Actuator(plant_vehicle)
    pi = PIWheelController(controller_vehicle, design_pi(controller_vehicle).gains)
    i_w = AUX_NAMES.index("omega_motor_left_rad_s")

    x = np.zeros(len(STATE_NAMES))
    u = np.zeros(2)
    rows_t: list[float] = []
    rows_phase: list[str] = []
    rows_sp: list[NDArray[np.float64]] = []
    rows_w: list[NDArray[np.float64]] = []
    rows_v: list[NDArray[np.float64]] = []

    def measure() -> NDArray[np.float64]:
        w = plant.aux(x, u, p)[i_w : i_w + 2]
        return w + (rng.normal(0.0, sigma, 2) if sigma > 0 else 0.0)

    def step(phase: str, setpoint: NDArray[np.float64], da_command_v: NDArray[np.float64],
             measured: NDArray[np.float64]) -> None:
        nonlocal x, u
        out = actuator.apply(da_command_v)
        u = np.asarray(out.motor_voltage_v, dtype=float)
        rows_t.append(len(rows_t) * ts)
        rows_phase.append(phase)
        rows_sp.append(setpoint)
        rows_w.append(measured)
        rows_v.append(np.asarray(out.da_voltage_v, dtype=float))
        x, _aux, _stats = plant.step(x, u, p, ts, splits)

    def samples(duration_s: float) -> int:
        return max(1, int(round(duration_s / ts)))

    speeds = list(exp.motor_speeds_rad_s)
    if exp.both_directions:
        speeds += [-w for w in exp.motor_speeds_rad_s]
    pi.reset()
    for w_ref in speeds:
        sp = np.array([w_ref, w_ref])
        for _ in range(samples(exp.settle_s + exp.hold_s)):
            meas = measure()
            step("hold", sp, pi.update(sp, meas), meas)
    zero = np.zeros(2)
    for _ in range(samples(exp.rest_s)):  # brake to a stop on the speed loops, then let go
        meas = measure()
        step("idle", zero, pi.update(zero, meas), meas)
    for _ in range(samples(exp.rest_s)):
        step("idle", zero, zero, measure())

    v_max = actuator.max_da_voltage_v
    for side in range(2):
        for sign in (1.0, -1.0):
            for _ in range(exp.ramp_repeats):
                k = 0
                while True:
                    meas = measure()
                    v = sign * min(exp.ramp_rate_da_v_s * k * ts, v_max)
                    cmd = np.zeros(2)
                    cmd[side] = v
                    step("ramp", zero, cmd, meas)
                    k += 1
                    if sign * meas[side] > exp.ramp_stop_speed_rad_s or abs(v) >= v_max:
                        break
                for _ in range(samples(exp.rest_s)):
                    step("idle", zero, zero, measure())

    return FrictionLog(
        t_s=np.asarray(rows_t, dtype=float),
        phase=tuple(rows_phase),
        setpoint_rad_s=np.asarray(rows_sp, dtype=float),
        omega_motor_rad_s=np.asarray(rows_w, dtype=float),
        da_voltage_v=np.asarray(rows_v, dtype=float),
        source="<simulated friction experiment>",
    )


# ----------------------------------------------------------------------------------------------------------------
# Fitting


@dataclass(frozen=True)
class HoldWindow:
    """One steady constant-speed window of one side."""

    t_start_s: float
    t_end_s: float
    setpoint_rad_s: float
    omega_mean_rad_s: float
    """ω̄, the mean measured motor speed."""
    da_voltage_mean_v: float
    """ū, the mean DA voltage."""
    drive_torque_n_m: float
    """k_pow k_t ū/R − k_e k_t ω̄/R: the torque the friction absorbs (steady state)."""
    drive_torque_stderr_n_m: float
    """Standard error of the window's mean torque (Newey-West, from the sample-to-sample scatter)."""


@dataclass(frozen=True)
class SideFriction:
    """The identified friction of one side, eqs 65-69."""

    viscous_friction_n_m_s_rad: Estimate
    coulomb_friction_n_m: Estimate
    stiction_n_m: Estimate
    windows: tuple[HoldWindow, ...] = ()
    breakaway_da_voltages_v: tuple[float, ...] = ()
    """|u| held over the last still sample of each ramp (DA volts), before the resolution and lag corrections."""

    def as_dict(self) -> dict[str, dict[str, float | None]]:
        """The ``--json`` object of one side."""
        return {
            "viscous_friction_n_m_s_rad": self.viscous_friction_n_m_s_rad.as_dict(),
            "coulomb_friction_n_m": self.coulomb_friction_n_m.as_dict(),
            "stiction_n_m": self.stiction_n_m.as_dict(),
        }


@dataclass(frozen=True)
class FrictionFit:
    """Both sides' identified friction."""

    left: SideFriction
    right: SideFriction
    notes: tuple[str, ...] = field(default=())

    def side(self, name: Side) -> SideFriction:
        return self.left if name == "left" else self.right

    def as_dict(self) -> dict[str, dict[str, dict[str, float | None]]]:
        """``{"left": {...}, "right": {...}}`` as documented for ``agvctl identify friction --json``."""
        return {"left": self.left.as_dict(), "right": self.right.as_dict()}


def two_speed_friction(
    motor: MotorParams,
    amplifier_gain: float,
    omega_1_rad_s: float,
    u_1_v: float,
    omega_2_rad_s: float,
    u_2_v: float,
    *,
    corrected: bool = True,
) -> tuple[float, float]:
    """The report's two-speed formula: ``(f_m, τ_c)`` from the DA voltages u₁, u₂ holding ω₁, ω₂ (one side).

    eq 66 (68): f_m = (k_pow k_t/R (u₂ − u₁) − k_e k_t/R (ω₂ − ω₁)) / (ω₂ − ω₁).
    eq 67 (69), corrected (ERRATA): τ_c = k_pow k_t u₂/R − (k_e k_t/R + f_m) ω₂. With ``corrected=False`` the
    report's printed sign, τ_c = k_pow k_t u₂/R − (k_e k_t/R − f_m) ω₂, which is 2 f_m ω₂ too large.
    """
    k_t, k_e, R = motor.torque_constant_n_m_a, motor.voltage_constant_v_s_rad, motor.resistance_ohm
    d_omega = omega_2_rad_s - omega_1_rad_s
    if d_omega == 0:
        raise ValueError("two_speed_friction: the two speeds must differ")
    f_m = (amplifier_gain * k_t / R * (u_2_v - u_1_v) - k_e * k_t / R * d_omega) / d_omega  # eq 66
    sign = 1.0 if corrected else -1.0
    tau_c = amplifier_gain * k_t * u_2_v / R - (k_e * k_t / R + sign * f_m) * omega_2_rad_s  # eq 67
    return f_m, tau_c


def _mean_stderr(z: NDArray[np.float64], max_lag: int) -> float:
    """Standard error of the mean of an autocorrelated series (Newey-West, Bartlett weights)."""
    n = len(z)
    d = z - z.mean()
    var = float(d @ d) / n
    for lag in range(1, min(max_lag, n - 1) + 1):
        var += 2.0 * (1.0 - lag / (max_lag + 1)) * float(d[lag:] @ d[:-lag]) / n
    return math.sqrt(max(var, 0.0) / n)


def _hold_windows(log: FrictionLog, side: int, settle_s: float, min_window_s: float) -> list[tuple[int, int]]:
    """Index ranges [a, b) of steady hold windows of one side: runs of 'hold' rows with one non-zero setpoint,
    the first ``settle_s`` dropped, at least ``min_window_s`` left."""
    ranges: list[tuple[int, int]] = []
    n = len(log.t_s)
    i = 0
    while i < n:
        if log.phase[i] != "hold":
            i += 1
            continue
        sp = log.setpoint_rad_s[i, side]
        j = i
        while j < n and log.phase[j] == "hold" and log.setpoint_rad_s[j, side] == sp:
            j += 1
        if sp != 0.0:
            a = i
            while a < j and log.t_s[a] < log.t_s[i] + settle_s - 1e-9:
                a += 1
            if j - a >= 2 and log.t_s[j - 1] - log.t_s[a] >= min_window_s - 1e-9:
                ranges.append((a, j))
        i = j
    return ranges


@dataclass(frozen=True)
class _Breakaway:
    u_still_v: float
    """|u| held over the last sample at whose start the wheel was still (it broke the wheel away)."""
    resolution_v: float
    """The larger of the ramp's step per sample and one DA code."""
    lag_bound_v: float
    """How much later than the break-away the noise let the wheel be seen moving, at most (0 without noise)."""


def _onset_time_s(speed_rad_s: float, accel_gain: float, tau_s: float) -> float:
    """Time after a break-away at which a ramp-driven wheel reaches ``speed_rad_s`` when τ_s = τ_c (the slowest
    onset): linear sliding dynamics, ω(t) = g (t − τ (1 − e^(−t/τ)))."""
    if speed_rad_s <= 0:
        return 0.0
    lo, hi = 0.0, 1.0
    while accel_gain * (hi - tau_s * (1.0 - math.exp(-hi / tau_s))) < speed_rad_s and hi < 1e4:
        hi *= 2.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if accel_gain * (mid - tau_s * (1.0 - math.exp(-mid / tau_s))) < speed_rad_s:
            lo = mid
        else:
            hi = mid
    return hi


def _breakaways(
    log: FrictionLog,
    side: int,
    *,
    threshold_rad_s: float,
    volts_per_code: float,
    torque_per_da_v: float,
    damping_n_m_s_rad: float,
    inertia_kg_m2: float,
    smooth: int = 5,
) -> list[_Breakaway]:
    """The break-aways of one side, one per ramp block that drives it and sees the wheel move.

    σ, the speed noise, is the RMS speed over the block's samples below half its peak voltage (the wheel surely
    sticks there). Without noise the wheel is moving at the first sample with a speed beyond ``threshold`` in the
    ramp's direction, and was still at the last sample with speed exactly 0 before it. With noise the speed is
    first averaged over ``smooth`` samples (trailing), "moving" means beyond max(threshold, 4σ/√smooth) and
    "still" within 2σ/√smooth; the wheel may then have started up to the time its speed needs to reach that band
    (from linear sliding dynamics with J̃ and the damping k_e k_t/R + f_m, the slowest case τ_s = τ_c) plus the
    averaging delay earlier: the lag bound.
    """
    n = len(log.t_s)
    found: list[_Breakaway] = []
    i = 0
    while i < n:
        if log.phase[i] != "ramp":
            i += 1
            continue
        j = i
        while j < n and log.phase[j] == "ramp":
            j += 1
        u = log.da_voltage_v[i:j, side]
        w = log.omega_motor_rad_s[i:j, side]
        t = log.t_s[i:j]
        i = j
        u_peak = float(np.max(np.abs(u)))
        if u_peak <= 0.0 or len(u) < 2:
            continue  # this block ramps the other side
        sign = 1.0 if float(np.max(u)) >= -float(np.min(u)) else -1.0
        quiet = np.abs(u) <= 0.5 * u_peak
        sigma = float(np.sqrt(np.mean(w[quiet] ** 2))) if np.count_nonzero(quiet) >= 5 else 0.0
        m = max(1, min(smooth, len(w))) if sigma > 0 else 1
        w_s = np.convolve(w, np.ones(m) / m, mode="valid")  # w_s[k - m + 1] = mean of w[k - m + 1 .. k]
        moving = np.nonzero(sign * w_s > max(threshold_rad_s, 4.0 * sigma / math.sqrt(m)))[0]
        if moving.size == 0:
            continue
        k = int(moving[0])
        still = 2.0 * sigma / math.sqrt(m) if sigma > 0 else 0.0
        while k > 0 and sign * float(w_s[k]) > still:
            k -= 1
        k_still = k + m - 1  # the last sample of the averaging window
        duration = float(t[k_still] - t[0]) if k_still > 0 else 0.0
        rate_v_s = abs(float(u[k_still]) - float(u[0])) / duration if duration > 0 else 0.0
        ts = float(t[1] - t[0])
        lag_v = 0.0
        if sigma > 0:
            accel_gain = torque_per_da_v * rate_v_s / damping_n_m_s_rad
            onset = _onset_time_s(still, accel_gain, inertia_kg_m2 / damping_n_m_s_rad)
            lag_v = rate_v_s * (onset + 0.5 * (m - 1) * ts)
        found.append(_Breakaway(abs(float(u[k_still])), max(rate_v_s * ts, volts_per_code), lag_v))
    return found


def fit_friction(
    log: FrictionLog,
    vehicle: VehicleParams,
    *,
    settle_s: float = 1.0,
    min_window_s: float = 1.0,
    breakaway_threshold_rad_s: float = 0.2,
    max_speed_deviation: float = 0.02,
    truth: VehicleParams | None = None,
) -> FrictionFit:
    """Identify f_m, τ_c (least squares over the hold windows) and τ_s (ramps) per side from ``log``.

    ``vehicle`` supplies the motor constants k_t, k_e, R and the amplifier gain k_pow (known, as in the report),
    and the DA resolution. ``settle_s`` is dropped at the start of every hold window; windows shorter than
    ``min_window_s`` after that are ignored, and so are windows whose mean speed misses the setpoint by more than
    ``max_speed_deviation`` (relative: the loop hit a current or voltage limit). ``truth`` (simulations only)
    fills each :class:`Estimate`'s truth.

    Least squares: per window i, the mean drive torque y_i = k_pow k_t ū_i/R − k_e k_t ω̄_i/R (ERRATA's steady
    state of eqs 66-69) and the regressors (ω̄_i, sign ω̄_i); weighted by each window's Newey-West variance; the
    covariance scaled by the reduced χ² when it exceeds 1. Stiction: τ_s = k_pow k_t |u_b|/R (eq 65 corrected)
    with u the voltage held over the last sample at which the wheel was still, less half a resolution step and
    half the noise's detection lag (:func:`_breakaways`), averaged over the ramps; its standard error combines the
    ramps' scatter with the resolution and the lag bound (each uniform).

    Raises :class:`ConfigError` (one line, naming ``log.source``) when a side has fewer than two hold windows,
    all its windows at one speed, or no ramp that breaks away.
    """
    k_pow = vehicle.amplifier.gain
    notes: list[str] = []
    sides: list[SideFriction] = []
    ts_log = float(np.median(np.diff(log.t_s))) if len(log.t_s) > 1 else vehicle.control.sample_period_s
    if not (math.isfinite(ts_log) and ts_log > 0):
        raise ConfigError(log.source, "t_s", "sample times must increase")
    max_lag = max(1, int(round(1.0 / ts_log)))
    for j, name in enumerate(SIDES):
        motor = vehicle.motor.side(name)
        k_t, k_e, R = motor.torque_constant_n_m_a, motor.voltage_constant_v_s_rad, motor.resistance_ohm
        col = f"setpoint_omega_motor_{name}_rad_s"
        ranges = _hold_windows(log, j, settle_s, min_window_s)
        kept = []
        for a, b in ranges:  # a loop that could not hold its setpoint (current or voltage limit): no steady state
            sp, mean = float(log.setpoint_rad_s[a, j]), float(np.mean(log.omega_motor_rad_s[a:b, j]))
            if abs(mean - sp) > max_speed_deviation * abs(sp):
                notes.append(f"{name}: window at {sp:g} rad/s from t = {log.t_s[a]:g} s ignored: the speed averaged "
                             f"{mean:.4g} rad/s (the loop could not hold it)")
            else:
                kept.append((a, b))
        ranges = kept
        if len(ranges) < 2:
            raise ConfigError(
                log.source, col,
                f"{len(ranges)} steady constant-speed window{'s' if len(ranges) != 1 else ''} "
                f"(phase = hold, non-zero setpoint, at least {settle_s:g} s settling + {min_window_s:g} s); "
                "need at least 2 at different speeds",
            )
        omegas = np.array([float(np.mean(log.omega_motor_rad_s[a:b, j])) for a, b in ranges])
        mags = np.sort(np.abs(omegas))
        if mags[-1] - mags[0] <= 0.1 * mags[-1]:
            raise ConfigError(
                log.source, col,
                f"all {len(ranges)} constant-speed windows are at one speed (|ω| ≈ {mags[-1]:.4g} rad/s); "
                "need at least 2 different speeds to separate viscous and Coulomb friction",
            )
        # per-sample drive torque; first pass unweighted, then weights from the residual scatter
        y_series = [k_pow * k_t * log.da_voltage_v[a:b, j] / R - k_e * k_t * log.omega_motor_rad_s[a:b, j] / R
                    for a, b in ranges]
        w_series = [log.omega_motor_rad_s[a:b, j] for a, b in ranges]
        y = np.array([float(np.mean(s)) for s in y_series])
        X = np.column_stack([omegas, np.sign(omegas)])
        theta = np.linalg.lstsq(X, y, rcond=None)[0]
        var = np.array([
            _mean_stderr(ys - theta[0] * ws, max_lag) ** 2 for ys, ws in zip(y_series, w_series, strict=True)
        ])
        var = np.maximum(var, (1e-9 * max(1.0, float(np.max(np.abs(y))))) ** 2)
        W = 1.0 / var
        A = X.T @ (X * W[:, None])
        theta = np.linalg.solve(A, X.T @ (W * y))
        cov = np.linalg.inv(A)
        dof = len(y) - 2
        if dof > 0:
            chi2 = float(np.sum(W * (y - X @ theta) ** 2)) / dof
            cov = cov * max(1.0, chi2)
        f_m, tau_c = float(theta[0]), float(theta[1])
        se = np.sqrt(np.diag(cov))
        windows = tuple(
            HoldWindow(
                t_start_s=float(log.t_s[a]), t_end_s=float(log.t_s[b - 1]),
                setpoint_rad_s=float(log.setpoint_rad_s[a, j]), omega_mean_rad_s=float(omegas[i]),
                da_voltage_mean_v=float(np.mean(log.da_voltage_v[a:b, j])), drive_torque_n_m=float(y[i]),
                drive_torque_stderr_n_m=math.sqrt(float(var[i])),
            )
            for i, (a, b) in enumerate(ranges)
        )

        torque_per_v = k_pow * k_t / R  # eq 65, corrected
        found = _breakaways(
            log, j, threshold_rad_s=breakaway_threshold_rad_s, volts_per_code=vehicle.da.volts_per_code,
            torque_per_da_v=torque_per_v, damping_n_m_s_rad=k_e * k_t / R + max(f_m, 0.0),
            inertia_kg_m2=getattr(vehicle.derived, name).inertia_equivalent_kg_m2,
        )
        if not found:
            raise ConfigError(
                log.source, f"da_voltage_{name}_v",
                "no ramp breaks the wheel away (phase = ramp: a slow DA ramp from standstill until the measured "
                f"speed exceeds {breakaway_threshold_rad_s:g} rad/s); the stiction needs one",
            )
        # u_k broke the wheel away, one step less did not; with noise it may have moved up to lag_bound earlier
        tau_s_all = np.array([(b.u_still_v - 0.5 * b.resolution_v - 0.5 * b.lag_bound_v) * torque_per_v
                              for b in found])
        tau_s = float(np.mean(tau_s_all))
        spread = [math.hypot(b.resolution_v, b.lag_bound_v) for b in found]
        resolution = float(np.mean(spread)) * torque_per_v / math.sqrt(12.0)
        scatter = float(np.std(tau_s_all, ddof=1)) / math.sqrt(len(found)) if len(found) > 1 else 0.0
        tau_s_se = math.hypot(scatter, resolution)
        f_m_se, tau_c_se = float(se[0]), float(se[1])

        true_motor = truth.motor.side(name) if truth is not None else None
        sides.append(SideFriction(
            viscous_friction_n_m_s_rad=Estimate(
                f_m, f_m_se, None if true_motor is None else true_motor.viscous_friction_n_m_s_rad),
            coulomb_friction_n_m=Estimate(
                tau_c, tau_c_se, None if true_motor is None else true_motor.coulomb_friction_n_m),
            stiction_n_m=Estimate(tau_s, tau_s_se, None if true_motor is None else true_motor.stiction_n_m),
            windows=windows,
            breakaway_da_voltages_v=tuple(b.u_still_v for b in found),
        ))
    return FrictionFit(left=sides[0], right=sides[1], notes=tuple(notes))


def apply_friction(vehicle: VehicleParams, fit: FrictionFit) -> tuple[VehicleParams, list[str]]:
    """``vehicle`` with the identified f_m, τ_c, τ_s per side, and notes on any value that had to be clamped.

    A vehicle file needs f_m ≥ 0 and τ_s ≥ τ_c (ERRATA): a slightly negative f_m (a true f_m near zero plus
    noise) becomes 0, a τ_s below τ_c becomes τ_c.
    """
    notes: list[str] = []
    overrides: list[tuple[str, float]] = []
    for name in SIDES:
        s = fit.side(name)
        f_m = s.viscous_friction_n_m_s_rad.estimate
        tau_c = s.coulomb_friction_n_m.estimate
        tau_s = s.stiction_n_m.estimate
        if f_m < 0:
            notes.append(f"{name}: viscous friction estimate {f_m:.3g} N m s/rad < 0, written as 0")
            f_m = 0.0
        if tau_c < 0:
            notes.append(f"{name}: Coulomb friction estimate {tau_c:.3g} N m < 0, written as 0")
            tau_c = 0.0
        if tau_s < tau_c:
            notes.append(f"{name}: stiction estimate {tau_s:.4g} N m below the Coulomb friction {tau_c:.4g} N m, "
                         "written as equal to it")
            tau_s = tau_c
        overrides += [
            (f"motor.{name}.viscous_friction_n_m_s_rad", f_m),
            (f"motor.{name}.coulomb_friction_n_m", tau_c),
            (f"motor.{name}.stiction_n_m", tau_s),
        ]
    return vehicle.with_overrides(overrides, source="identified friction"), notes
