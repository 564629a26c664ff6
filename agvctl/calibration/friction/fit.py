"""The friction fit: f_m and τ_c by weighted least squares over the hold windows (eqs 66-69), τ_s from the ramps
(eq 65), both as corrected in the docs' model notes; the report's two-speed formula; applying the result."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from agvctl.calibration.common import Estimate
from agvctl.calibration.friction.breakaway import Breakaway, breakaways
from agvctl.calibration.friction.log import SIDES, FrictionLog, Side
from agvctl.config import document_fields
from agvctl.errors import ConfigError
from agvctl.params import MotorParams, VehicleParams, motor_damping

__all__ = [
    "FrictionFit",
    "HoldWindow",
    "SideFriction",
    "apply_friction",
    "fit_friction",
    "two_speed_friction",
]


@document_fields
@dataclass(frozen=True)
class HoldWindow:
    """One steady constant-speed window of one side."""

    t_start_s: float
    """Its start, s."""
    t_end_s: float
    """Its end, s."""
    setpoint_rad_s: float
    """The motor-speed setpoint the loop held, rad/s."""
    omega_mean_rad_s: float
    """ω̄, the mean measured motor speed, rad/s."""
    da_voltage_mean_v: float
    """ū, the mean DA voltage, V."""
    drive_torque_n_m: float
    """k_pow k_t ū/R − k_e k_t ω̄/R: the torque the friction absorbs (steady state), N m."""
    drive_torque_stderr_n_m: float
    """Standard error of the window's mean torque (Newey-West, from the sample-to-sample scatter), N m."""


@document_fields
@dataclass(frozen=True)
class SideFriction:
    """The identified friction of one side, eqs 65-69."""

    viscous_friction_n_m_s_rad: Estimate
    """f_m, N m s/rad."""
    coulomb_friction_n_m: Estimate
    """τ_c, N m."""
    stiction_n_m: Estimate
    """τ_s, N m."""
    windows: tuple[HoldWindow, ...] = ()
    """The hold windows f_m and τ_c were fitted to."""
    breakaway_da_voltages_v: tuple[float, ...] = ()
    """``|u|`` held over the last still sample of each ramp, before the resolution and lag corrections, V."""

    def as_dict(self) -> dict[str, dict[str, float | None]]:
        """The ``--json`` object of one side."""
        return {
            "viscous_friction_n_m_s_rad": self.viscous_friction_n_m_s_rad.as_dict(),
            "coulomb_friction_n_m": self.coulomb_friction_n_m.as_dict(),
            "stiction_n_m": self.stiction_n_m.as_dict(),
        }


@document_fields
@dataclass(frozen=True)
class FrictionFit:
    """Both sides' identified friction."""

    left: SideFriction
    """The left side's."""
    right: SideFriction
    """The right side's."""
    notes: tuple[str, ...] = field(default=())
    """What the fit noted (hold windows dropped, and why)."""

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
    """The report's two-speed formula: f_m and τ_c of one side from the DA voltages that hold two speeds.

    Eq 66 (68): f_m = (k_pow k_t/R (u₂ − u₁) − k_e k_t/R (ω₂ − ω₁)) / (ω₂ − ω₁). Eq 67 (69), corrected as in
    the docs' model notes: τ_c = k_pow k_t u₂/R − (k_e k_t/R + f_m) ω₂.

    Parameters
    ----------
    motor : MotorParams
        The side's motor: k_t, k_e and R (known, as in the report).
    amplifier_gain : float
        k_pow, motor volts per DA volt.
    omega_1_rad_s : float
        The first held motor speed ω₁, rad/s.
    u_1_v : float
        The DA voltage u₁ that holds it, V.
    omega_2_rad_s : float
        The second held motor speed ω₂, rad/s.
    u_2_v : float
        The DA voltage u₂ that holds it, V.
    corrected : bool
        False: the report's printed sign, τ_c = k_pow k_t u₂/R − (k_e k_t/R − f_m) ω₂, which is 2 f_m ω₂ too
        large.

    Returns
    -------
    viscous_friction_n_m_s_rad : float
        f_m, N m s/rad.
    coulomb_friction_n_m : float
        τ_c, N m.
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


def _steady_windows(
    log: FrictionLog, side: int, settle_s: float, min_window_s: float, max_speed_deviation: float, notes: list[str]
) -> list[tuple[int, int]]:
    """The hold windows of one side that held their setpoint (a loop at a current or voltage limit has no steady
    state: noted and dropped); :class:`ConfigError` unless at least two remain, at different speeds."""
    name = SIDES[side]
    col = f"setpoint_omega_motor_{name}_rad_s"
    ranges = []
    for a, b in _hold_windows(log, side, settle_s, min_window_s):
        sp, mean = float(log.setpoint_rad_s[a, side]), float(np.mean(log.omega_motor_rad_s[a:b, side]))
        if abs(mean - sp) > max_speed_deviation * abs(sp):
            notes.append(
                f"{name}: window at {sp:g} rad/s from t = {log.t_s[a]:g} s ignored: the speed averaged "
                f"{mean:.4g} rad/s (the loop could not hold it)"
            )
        else:
            ranges.append((a, b))
    if len(ranges) < 2:
        raise ConfigError(
            log.source,
            col,
            f"{len(ranges)} steady constant-speed window{'s' if len(ranges) != 1 else ''} "
            f"(phase = hold, non-zero setpoint, at least {settle_s:g} s settling + {min_window_s:g} s); "
            "need at least 2 at different speeds",
        )
    mags = np.sort(np.abs([float(np.mean(log.omega_motor_rad_s[a:b, side])) for a, b in ranges]))
    if mags[-1] - mags[0] <= 0.1 * mags[-1]:
        raise ConfigError(
            log.source,
            col,
            f"all {len(ranges)} constant-speed windows are at one speed (|ω| ≈ {mags[-1]:.4g} rad/s); "
            "need at least 2 different speeds to separate viscous and Coulomb friction",
        )
    return ranges


def _viscous_coulomb(
    log: FrictionLog, side: int, ranges: list[tuple[int, int]], k_pow: float, motor: MotorParams, max_lag: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], tuple[HoldWindow, ...]]:
    """(f_m, τ_c), their standard errors and the windows: weighted least squares of the windows' mean drive torque
    y_i = k_pow k_t ū_i/R − k_e k_t ω̄_i/R on (ω̄_i, sign ω̄_i) (the steady state of eqs 66-69, corrected).

    A first unweighted pass gives the residuals; each window is then weighted by the Newey-West variance of its
    mean residual torque, and the covariance scaled by the reduced χ² when it exceeds 1.
    """
    k_t, k_e, R = motor.torque_constant_n_m_a, motor.voltage_constant_v_s_rad, motor.resistance_ohm
    omegas = np.array([float(np.mean(log.omega_motor_rad_s[a:b, side])) for a, b in ranges])
    y_series = [
        k_pow * k_t * log.da_voltage_v[a:b, side] / R - k_e * k_t * log.omega_motor_rad_s[a:b, side] / R
        for a, b in ranges
    ]
    w_series = [log.omega_motor_rad_s[a:b, side] for a, b in ranges]
    y = np.array([float(np.mean(s)) for s in y_series])
    X = np.column_stack([omegas, np.sign(omegas)])
    theta = np.linalg.lstsq(X, y, rcond=None)[0]
    var = np.array([_mean_stderr(ys - theta[0] * ws, max_lag) ** 2 for ys, ws in zip(y_series, w_series, strict=True)])
    var = np.maximum(var, (1e-9 * max(1.0, float(np.max(np.abs(y))))) ** 2)
    W = 1.0 / var
    A = X.T @ (X * W[:, None])
    theta = np.linalg.solve(A, X.T @ (W * y))
    cov = np.linalg.inv(A)
    dof = len(y) - 2
    if dof > 0:
        chi2 = float(np.sum(W * (y - X @ theta) ** 2)) / dof
        cov = cov * max(1.0, chi2)
    windows = tuple(
        HoldWindow(
            t_start_s=float(log.t_s[a]),
            t_end_s=float(log.t_s[b - 1]),
            setpoint_rad_s=float(log.setpoint_rad_s[a, side]),
            omega_mean_rad_s=float(omegas[i]),
            da_voltage_mean_v=float(np.mean(log.da_voltage_v[a:b, side])),
            drive_torque_n_m=float(y[i]),
            drive_torque_stderr_n_m=math.sqrt(float(var[i])),
        )
        for i, (a, b) in enumerate(ranges)
    )
    return theta, np.sqrt(np.diag(cov)), windows


def _stiction(found: list[Breakaway], torque_per_da_v: float) -> tuple[float, float]:
    """τ_s and its standard error from the ramps' break-aways (eq 65, corrected: τ_s = k_pow k_t ``|u_b|``/R).

    u_b broke the wheel away and one step less did not; with noise the wheel may have moved up to the lag bound
    earlier: so half a resolution step and half the lag bound are taken off. The standard error combines the
    ramps' scatter with the resolution and the lag bound (each uniform).
    """
    tau_s_all = np.array([(b.u_still_v - 0.5 * b.resolution_v - 0.5 * b.lag_bound_v) * torque_per_da_v for b in found])
    spread = [math.hypot(b.resolution_v, b.lag_bound_v) for b in found]
    resolution = float(np.mean(spread)) * torque_per_da_v / math.sqrt(12.0)
    scatter = float(np.std(tau_s_all, ddof=1)) / math.sqrt(len(found)) if len(found) > 1 else 0.0
    return float(np.mean(tau_s_all)), math.hypot(scatter, resolution)


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
    """Identify f_m, τ_c (least squares over the hold windows) and τ_s (ramps) per side from a friction log.

    Parameters
    ----------
    log : FrictionLog
        The experiment's log (:func:`~agvctl.calibration.friction.log.read_friction_log`, or simulated).
    vehicle : VehicleParams
        The motor constants k_t, k_e, R and the amplifier gain k_pow (known, as in the report), and the DA
        resolution.
    settle_s : float
        Dropped at the start of every hold window, s.
    min_window_s : float
        Windows shorter than this after that are ignored, s.
    max_speed_deviation : float
        Windows whose mean speed misses the setpoint by more than this, relative, are ignored (the loop hit a
        current or voltage limit).
    breakaway_threshold_rad_s : float
        The motor speed beyond which a ramped wheel counts as moving (without noise), rad/s.
    truth : VehicleParams or None
        The true vehicle (simulations only): fills each :class:`~agvctl.calibration.common.Estimate`'s truth.

    Returns
    -------
    FrictionFit
        Both sides' f_m, τ_c and τ_s with their standard errors.

    Raises
    ------
    ConfigError
        One line naming ``log.source``: a side with fewer than two hold windows, all its windows at one speed, or
        no ramp that breaks away.

    Notes
    -----
    Least squares: per window i, the mean drive torque y_i = k_pow k_t ū_i/R − k_e k_t ω̄_i/R (the steady state
    of eqs 66-69, corrected) and the regressors (ω̄_i, sign ω̄_i); weighted by each window's Newey-West variance;
    the covariance scaled by the reduced χ² when it exceeds 1 (:func:`_viscous_coulomb`). Stiction:
    τ_s = k_pow k_t ``|u_b|``/R (eq 65 corrected) with u the voltage held over the last sample at which the wheel
    was still, less half a resolution step and half the noise's detection lag
    (:func:`~agvctl.calibration.friction.breakaway.breakaways`), averaged over the ramps; its standard error
    combines the ramps' scatter with the resolution and the lag bound (each uniform).
    """
    k_pow = vehicle.amplifier.gain
    notes: list[str] = []
    sides: list[SideFriction] = []
    max_lag = _max_lag(log, vehicle)
    for j, name in enumerate(SIDES):
        motor = vehicle.motor.side(name)
        ranges = _steady_windows(log, j, settle_s, min_window_s, max_speed_deviation, notes)
        theta, se, windows = _viscous_coulomb(log, j, ranges, k_pow, motor, max_lag)
        f_m, tau_c = float(theta[0]), float(theta[1])

        found, tau_s, tau_s_se = _side_stiction(log, j, vehicle, f_m, breakaway_threshold_rad_s)

        true_motor = truth.motor.side(name) if truth is not None else None
        sides.append(
            SideFriction(
                viscous_friction_n_m_s_rad=Estimate(
                    f_m, float(se[0]), None if true_motor is None else true_motor.viscous_friction_n_m_s_rad
                ),
                coulomb_friction_n_m=Estimate(
                    tau_c, float(se[1]), None if true_motor is None else true_motor.coulomb_friction_n_m
                ),
                stiction_n_m=Estimate(tau_s, tau_s_se, None if true_motor is None else true_motor.stiction_n_m),
                windows=windows,
                breakaway_da_voltages_v=tuple(b.u_still_v for b in found),
            )
        )
    return FrictionFit(left=sides[0], right=sides[1], notes=tuple(notes))


def _max_lag(log: FrictionLog, vehicle: VehicleParams) -> int:
    """The Newey-West lags of a window's mean torque: the samples of one second of the log."""
    ts_log = float(np.median(np.diff(log.t_s))) if len(log.t_s) > 1 else vehicle.control.sample_period_s
    if not (math.isfinite(ts_log) and ts_log > 0):
        raise ConfigError(log.source, "t_s", "sample times must increase")
    return max(1, int(round(1.0 / ts_log)))


def _side_stiction(
    log: FrictionLog, j: int, vehicle: VehicleParams, f_m: float, threshold_rad_s: float
) -> tuple[list[Breakaway], float, float]:
    """One side's break-aways, and τ_s with its standard error from them (:func:`_stiction`)."""
    name = SIDES[j]
    motor = vehicle.motor.side(name)
    k_t, k_e, R = motor.torque_constant_n_m_a, motor.voltage_constant_v_s_rad, motor.resistance_ohm
    torque_per_v = vehicle.amplifier.gain * k_t / R  # eq 65, corrected
    found = breakaways(
        log,
        j,
        threshold_rad_s=threshold_rad_s,
        volts_per_code=vehicle.da.volts_per_code,
        torque_per_da_v=torque_per_v,
        damping_n_m_s_rad=motor_damping(k_e, k_t, R, max(f_m, 0.0)),
        inertia_kg_m2=getattr(vehicle.derived, name).inertia_equivalent_kg_m2,
    )
    if not found:
        raise ConfigError(
            log.source,
            f"da_voltage_{name}_v",
            "no ramp breaks the wheel away (phase = ramp: a slow DA ramp from standstill until the measured "
            f"speed exceeds {threshold_rad_s:g} rad/s); the stiction needs one",
        )
    tau_s, tau_s_se = _stiction(found, torque_per_v)
    return found, tau_s, tau_s_se


def apply_friction(vehicle: VehicleParams, fit: FrictionFit) -> tuple[VehicleParams, list[str]]:
    """A vehicle with the identified f_m, τ_c, τ_s per side.

    A vehicle file needs f_m ≥ 0 and τ_s ≥ τ_c (model note 5, docs/model-notes.md): a slightly negative f_m (a true
    f_m near zero plus noise) becomes 0, a τ_s below τ_c becomes τ_c.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle to update.
    fit : FrictionFit
        The identified friction.

    Returns
    -------
    vehicle : VehicleParams
        A copy with the friction.
    notes : list of str
        One line per value that had to be clamped.
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
            notes.append(
                f"{name}: stiction estimate {tau_s:.4g} N m below the Coulomb friction {tau_c:.4g} N m, "
                "written as equal to it"
            )
            tau_s = tau_c
        overrides += [
            (f"motor.{name}.viscous_friction_n_m_s_rad", f_m),
            (f"motor.{name}.coulomb_friction_n_m", tau_c),
            (f"motor.{name}.stiction_n_m", tau_s),
        ]
    return vehicle.with_overrides(overrides, source="identified friction"), notes
