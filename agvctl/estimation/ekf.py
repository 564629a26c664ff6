"""An extended Kalman filter for the pose and the odometry calibration: odometry (and the gyro) between late,
noisy absolute fixes.

State (6): the pose x, y (m), θ (rad) and the odometry calibration, relative errors of the believed geometry: ε_l,
ε_r of the wheel radii (a 0.5 % larger wheel is ε = 0.005: the travel its counts give is scaled by 1 + ε) and ε_b of
the wheel base (the true b is b·(1 + ε_b)). Process model, once per sample, driven by the travel the encoder counts
give with the believed radii, d = Δn·q·r/N (eqs 26, 29):

    s_l,r = (1 + ε_l,r) d_l,r,   Δs = (s_l + s_r)/2 (eq 39),   Δθ = (s_r − s_l)/(b(1 + ε_b)) (eq 40) or the gyro's,
    x += Δs cos(θ + Δθ/2),   y += Δs sin(θ + Δθ/2),   θ += Δθ   (eqs 41-43, the midpoint rule)

The three calibration states are observable from position fixes on any path that both drives straight and turns:
the mean of ε_l, ε_r scales the distance, their difference turns a straight drive, ε_b scales every turn. Their
priors are the vehicle file's tolerances (``wheels.radius_tolerance``, ``wheels.separation_tolerance``), each the
half-width of a uniform range (σ = tolerance/√3). Process noise: each wheel's travel carries the quantisation of
its two latched counts (q_s²/6, q_s the travel of one count, from the sensor table) and a relative slip σ; the
calibration a slow random walk. A fix (x, y, θ) updates the pose directly (H = [I₃ 0]) with R from the sensor table.

Robust to the fixes a beacon system really delivers:

* **Gating**: a fix whose NIS νᵀS⁻¹ν exceeds the chi-square quantile ``gate_probability`` (3 degrees of freedom)
  is rejected and counted (:attr:`PoseEkf.rejected_fixes`): a reflector confusion, a fix a metre off. After
  ``max_consecutive_rejections`` in a row the next fix is applied whatever its NIS: then the filter, not the fixes,
  is the more likely to be wrong.
* **Latency**: a fix measured at sample j arrives at sample k > j. With ``latency_compensation`` (the default) the
  filter keeps the last samples' states, covariances, travels and the fixes applied at each, applies the fix at j
  and replays j+1…k with their fixes (buffer and replay: as if each fix had arrived on time). A fix measured before
  one already applied (out of order) is handled the same way, exactly, and counted
  (:attr:`PoseEkf.reordered_fixes`); one older than the buffer is dropped and counted
  (:attr:`PoseEkf.dropped_fixes`). Without compensation the fix is applied at k as if just measured.
* **Dropouts**: without fixes the filter predicts; its covariance grows with the travel and the calibration's σ.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.special import chdtri

from agvctl.angles import wrap_angle
from agvctl.config import check_fields, document_fields, number
from agvctl.errors import expect_instance
from agvctl.params import SIDES, VehicleParams
from agvctl.sensing import Measurements, PositionFix, fix_delay_samples

__all__ = ["CALIBRATION_STATES", "EkfSettings", "PoseEkf"]

FloatArray = NDArray[np.float64]

CALIBRATION_STATES = ("radius_error_left", "radius_error_right", "separation_error")
"""The names of the calibration states 3…5: the relative errors of the believed left and right wheel radii and
wheel base (true = believed · (1 + ε))."""

_N = 6
_UNIFORM_SIGMA = 1.0 / math.sqrt(3.0)  # σ of a uniform range of half-width 1


@document_fields
@dataclass(frozen=True)
class EkfSettings:
    """The EKF's tuning (beliefs about what the sensor table and the vehicle file's tolerances do not say)."""

    slip_sigma: float = number(ge=0, default=0.0005)
    """Relative σ of each wheel's travel per sample (dimensionless): slip and floor unevenness (the simulated plant
    has none)."""
    calibration_walk_sigma_per_sqrt_s: float = number(ge=0, default=1e-5)
    """Random walk of each calibration state ε, 1/√s: keeps the filter adapting to a geometry that changes with
    load and wear."""
    initial_position_sigma_m: float = number(gt=0, default=0.005)
    """Initial σ of x and y, m."""
    initial_heading_sigma_rad: float = number(gt=0, default=0.005)
    """Initial σ of θ, rad."""
    gate_probability: float = number(gt=0.5, le=1.0, default=0.9999)
    """The chi-square quantile of the NIS (3 degrees of freedom) above which a fix is rejected; 1 turns gating off.
    A consistent filter rejects 1 in 10 000 good fixes; a fix 1 m off has an NIS of about 10⁴."""
    max_consecutive_rejections: int = number(ge=0, default=4)
    """Rejections in a row after which the next fix is applied whatever its NIS: four (1 s at 4 Hz) and the fifth
    is applied."""
    latency_compensation: bool = True
    """Apply each fix at the sample it was measured and replay the travels since (buffer and replay); ``False``
    applies it on arrival as if just measured."""
    history_s: float = number(gt=0, le=60.0, default=2.0)
    """How far back fixes are replayed (at least the believed latency), s; older ones are dropped (counted in
    :attr:`PoseEkf.dropped_fixes`)."""

    def __post_init__(self) -> None:
        check_fields(self)


class _Entry:
    """One sample of the replay buffer: the travel into it, the fixes applied at it and the state after them."""

    __slots__ = ("P", "fixes", "k", "travel", "x")

    def __init__(self, k: int, travel: tuple[float, float, float], x: FloatArray, P: FloatArray) -> None:
        self.k, self.travel, self.x, self.P = k, travel, x, P
        self.fixes: list[FloatArray] = []


class PoseEkf:
    """The pose EKF (``localization = "ekf"``): the state (x, y, θ, ε_l, ε_r, ε_b), ε the relative errors of the
    believed wheel radii and wheel base; odometry from the encoder counts (and the gyro when on) predicts, position
    fixes update (gated on their NIS), a late or out-of-order fix at the sample it was measured (buffer and replay).

    Parameters
    ----------
    vehicle : VehicleParams
        The controller's vehicle: its believed geometry and its tolerances (the calibration priors), and the
        sensor table (encoder resolution, gyro, fix noise and latency).
    settings : EkfSettings or None
        The filter's tuning: slip, calibration random walk, the initial pose covariance, gating, latency
        compensation.
    """

    def __init__(self, vehicle: VehicleParams, settings: EkfSettings | None = None) -> None:
        expect_instance(vehicle, VehicleParams, "PoseEkf", "vehicle")
        if settings is not None:
            expect_instance(settings, EkfSettings, "PoseEkf", "settings")
        self.settings = s = settings or EkfSettings()
        sens, wheels = vehicle.sensors, vehicle.wheels
        q = 2.0 * math.pi / sens.encoder_counts_per_rev
        self.metres_per_count = np.array([vehicle.to_rim(side, q) for side in SIDES])
        self._mpc = self.metres_per_count.tolist()
        self.separation_m = wheels.separation_m
        ts = vehicle.control.sample_period_s
        self.sample_period_s = ts
        self._count_var = (self.metres_per_count**2 / 6.0).tolist()  # two latched counts, each uniform over one
        self._use_gyro = sens.gyro_enabled
        self._gyro_bias = sens.gyro_bias_rad_s
        self._gyro_var = (sens.gyro_sigma_rad_s**2 + sens.gyro_quantum_rad_s**2 / 12.0) * ts**2
        self._eye = np.eye(_N)
        self._q_base = np.zeros((_N, _N))
        self._q_base[3, 3] = self._q_base[4, 4] = self._q_base[5, 5] = s.calibration_walk_sigma_per_sqrt_s**2 * ts
        self.calibration_prior_sigma = (
            np.array([wheels.radius_tolerance] * 2 + [wheels.separation_tolerance]) * _UNIFORM_SIGMA
        )
        """Prior σ of (ε_l, ε_r, ε_b): the vehicle file's tolerances as uniform ranges."""
        self._fix_r = np.diag([sens.position_fix_sigma_m**2] * 2 + [math.radians(sens.heading_fix_sigma_deg) ** 2])
        self.gate_nis = math.inf if s.gate_probability >= 1.0 else float(chdtri(3, 1.0 - s.gate_probability))
        """The NIS above which a fix is rejected (chi-square, 3 degrees of freedom)."""
        # at least the fixes' believed delay and two samples more, whatever history_s says
        history = max(int(round(s.history_s / ts)), fix_delay_samples(vehicle) + 2)
        self._history: deque[_Entry] = deque(maxlen=history)
        self.x = np.zeros(_N)
        self.P = np.zeros((_N, _N))
        self._counts: tuple[int, int] | None = None
        self._reset_counters()

    def _reset_counters(self) -> None:
        self.last_nis = math.nan
        """NIS νᵀS⁻¹ν of the last fix arriving at the latest update, applied or rejected (NaN when none arrived
        or it was dropped): the filter's consistency check, so rejections do not truncate it."""
        self.applied_fixes = 0
        """Fixes applied since the reset."""
        self.rejected_fixes = 0
        """Fixes rejected by the gate since the reset."""
        self.dropped_fixes = 0
        """Fixes measured before the replay buffer's oldest sample, dropped, since the reset."""
        self.reordered_fixes = 0
        """Fixes measured before one already applied (out of order), applied in order, since the reset."""
        self._latest_measured = -1
        self._consecutive_rejections = 0

    @property
    def pose_covariance(self) -> FloatArray:
        """The pose's 3×3 covariance (m², m rad, rad²)."""
        return self.P[:3, :3]

    @property
    def calibration(self) -> FloatArray:
        """The calibration estimate (ε_l, ε_r, ε_b): relative errors of the believed radii and wheel base."""
        return self.x[3:]

    @property
    def calibration_sigma(self) -> FloatArray:
        """The calibration estimate's σ (ε_l, ε_r, ε_b)."""
        return np.sqrt(np.diagonal(self.P)[3:])

    @property
    def fix_counts(self) -> dict[str, int]:
        """The fixes since the reset: ``applied``, ``rejected`` (gate), ``dropped`` (older than the buffer),
        ``reordered`` (out of order, applied in order)."""
        return {
            "applied": self.applied_fixes,
            "rejected": self.rejected_fixes,
            "dropped": self.dropped_fixes,
            "reordered": self.reordered_fixes,
        }

    def reset(self, pose: FloatArray) -> None:
        s = self.settings
        self.x = np.array([*pose, 0.0, 0.0, 0.0], dtype=float)
        pose_var = [s.initial_position_sigma_m**2] * 2 + [s.initial_heading_sigma_rad**2]
        self.P = np.diag(pose_var + (self.calibration_prior_sigma**2).tolist())
        self._history.clear()
        self._counts = None
        self._reset_counters()

    def update(self, measurements: Measurements) -> FloatArray:
        """The :class:`~agvctl.estimation.base.PoseEstimator` step: :meth:`step` on this sample's readings."""
        m = measurements
        return self.step(m.sample, m.encoder_counts, m.gyro_rate_rad_s, m.fixes)

    def step(
        self, k: int, encoder_counts: NDArray[np.int64], gyro_rate_rad_s: float, fixes: tuple[PositionFix, ...]
    ) -> FloatArray:
        """Advance to sample k with the latched counts, the gyro's rate (NaN: none) and the fixes arriving."""
        n_l, n_r = encoder_counts.tolist()
        if self._counts is None:
            travel = (0.0, 0.0, math.nan)
        else:
            travel = (
                (n_l - self._counts[0]) * self._mpc[0],
                (n_r - self._counts[1]) * self._mpc[1],
                (gyro_rate_rad_s - self._gyro_bias) * self.sample_period_s,
            )
            self.x, self.P = self._predict(self.x, self.P, travel)
        self._counts = (n_l, n_r)
        self._history.append(_Entry(k, travel, self.x, self.P))
        self.last_nis = math.nan
        for fix in fixes:
            self._apply_fix(fix, k)
        return self.x[:3]

    def _predict(
        self, x: FloatArray, P: FloatArray, travel: tuple[float, float, float]
    ) -> tuple[FloatArray, FloatArray]:
        x_new, F, Q = self.transition(x, travel)
        P_new = np.dot(np.dot(F, P), F.T)  # np.dot: less per-call cost than @ on 6×6
        P_new += Q
        return x_new, P_new

    def transition(
        self, x: FloatArray, travel: FloatArray | tuple[float, float, float]
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Eqs 39-43 over one sample from state ``x`` with ``travel`` = (d_l m, d_r m, gyro Δθ rad or NaN):
        the next state, its Jacobian F (6×6) and the process noise Q (6×6). Scalars in plain floats, one array
        built per result: numpy's per-call cost would exceed the arithmetic."""
        d_l, d_r, gyro_dtheta = travel.tolist() if isinstance(travel, np.ndarray) else travel
        px, py, th, e_l, e_r, e_b = x.tolist()
        s_l, s_r = (1.0 + e_l) * d_l, (1.0 + e_r) * d_r
        ds = 0.5 * (s_l + s_r)  # eq 39
        gyro = self._use_gyro and not math.isnan(gyro_dtheta)
        k_h = 0.0 if gyro else 1.0 / (self.separation_m * (1.0 + e_b))
        dtheta = gyro_dtheta if gyro else (s_r - s_l) * k_h  # eq 40
        mid = th + 0.5 * dtheta
        c, s = math.cos(mid), math.sin(mid)
        x_new = np.array([px + ds * c, py + ds * s, th + dtheta, e_l, e_r, e_b])  # eqs 41-43
        a0, a1 = -0.5 * ds * s, 0.5 * ds * c  # ∂(x, y)/∂Δθ; ∂θ/∂Δθ = 1
        # ∂(x, y, θ)/∂(s_l, s_r): how each wheel's travel moves the pose
        gl0, gl1, gl2 = 0.5 * c - k_h * a0, 0.5 * s - k_h * a1, -k_h
        gr0, gr1, gr2 = 0.5 * c + k_h * a0, 0.5 * s + k_h * a1, k_h
        db = 0.0 if gyro else -dtheta / (1.0 + e_b)  # ∂Δθ/∂ε_b
        F = self._eye.copy()  # item by item: cheaper than building the array from nested lists
        F[0, 2], F[1, 2] = -ds * s, ds * c
        F[0, 3], F[1, 3], F[2, 3] = gl0 * d_l, gl1 * d_l, gl2 * d_l
        F[0, 4], F[1, 4], F[2, 4] = gr0 * d_r, gr1 * d_r, gr2 * d_r
        F[0, 5], F[1, 5], F[2, 5] = a0 * db, a1 * db, db
        slip = self.settings.slip_sigma
        v_l = self._count_var[0] + (slip * d_l) ** 2
        v_r = self._count_var[1] + (slip * d_r) ** 2
        v_g = self._gyro_var if gyro else 0.0
        q00 = gl0 * gl0 * v_l + gr0 * gr0 * v_r + a0 * a0 * v_g
        q01 = gl0 * gl1 * v_l + gr0 * gr1 * v_r + a0 * a1 * v_g
        q02 = gl0 * gl2 * v_l + gr0 * gr2 * v_r + a0 * v_g
        q11 = gl1 * gl1 * v_l + gr1 * gr1 * v_r + a1 * a1 * v_g
        q12 = gl1 * gl2 * v_l + gr1 * gr2 * v_r + a1 * v_g
        q22 = gl2 * gl2 * v_l + gr2 * gr2 * v_r + v_g
        Q = self._q_base.copy()
        Q[0, 0], Q[1, 1], Q[2, 2] = q00, q11, q22
        Q[0, 1] = Q[1, 0] = q01
        Q[0, 2] = Q[2, 0] = q02
        Q[1, 2] = Q[2, 1] = q12
        return x_new, F, Q

    def innovation(self, x: FloatArray, P: FloatArray, z: FloatArray) -> tuple[FloatArray, FloatArray, float]:
        """The fix z = (x, y, θ) against (x, P): the innovation ν (heading wrapped), the inverse of its covariance
        S = P₃ + R and the NIS νᵀS⁻¹ν. S⁻¹ by the adjugate in plain floats (S is symmetric 3×3): a general solve
        costs more in numpy's per-call overhead than the arithmetic."""
        (a, b, c), (_, d, e), (_, _, f) = (P[:3, :3] + self._fix_r).tolist()
        A, B, C = d * f - e * e, c * e - b * f, b * e - c * d
        D, E, F = a * f - c * c, b * c - a * e, a * d - b * b
        det = a * A + b * B + c * C
        s_inv = np.array([[A, B, C], [B, D, E], [C, E, F]]) / det
        nu = z - x[:3]
        nu[2] = wrap_angle(nu[2])
        return nu, s_inv, float(nu @ s_inv @ nu)

    def fix_update(self, x: FloatArray, P: FloatArray, z: FloatArray) -> tuple[FloatArray, FloatArray, float]:
        """A fix z = (x, y, θ) applied to (x, P): H = [I₃ 0], R from the believed sensor table; returns the
        updated state and covariance and the NIS."""
        nu, s_inv, nis = self.innovation(x, P, z)
        K = np.dot(P[:, :3], s_inv)  # P Hᵀ S⁻¹
        x_new = x + np.dot(K, nu)
        P_new = P - np.dot(K, P[:3, :])
        P_new = 0.5 * (P_new + P_new.T)
        return x_new, P_new, nis

    def _gate(self, x: FloatArray, P: FloatArray, z: FloatArray) -> bool:
        """Whether the fix z passes the gate at (x, P) (counting a rejection)."""
        _nu, _s_inv, nis = self.innovation(x, P, z)
        self.last_nis = nis
        if nis <= self.gate_nis or self._consecutive_rejections >= self.settings.max_consecutive_rejections:
            self._consecutive_rejections = 0
            return True
        self._consecutive_rejections += 1
        self.rejected_fixes += 1
        return False

    def readout(self) -> tuple[float, ...]:
        """The calibration (ε_l, ε_r, ε_b), its σ and the fixes rejected, dropped and reordered, as plain floats:
        what the closed loop logs every sample (:data:`~agvctl.estimation.base.CALIBRATION_COLUMNS`)."""
        _, _, _, v_l, v_r, v_b = self.P.diagonal().tolist()
        return (
            *self.x[3:].tolist(),
            math.sqrt(v_l),
            math.sqrt(v_r),
            math.sqrt(v_b),
            float(self.rejected_fixes),
            float(self.dropped_fixes),
            float(self.reordered_fixes),
        )

    def _apply_fix(self, fix: PositionFix, k: int) -> None:
        if not self.settings.latency_compensation:
            if self._gate(self.x, self.P, fix.pose):
                self.x, self.P, _ = self.fix_update(self.x, self.P, fix.pose)
                self.applied_fixes += 1
                entry = self._history[-1]
                entry.x, entry.P = self.x, self.P
            return
        j = fix.measured_sample
        start = j - self._history[0].k if self._history else -1
        if not (0 <= start < len(self._history)) or self._history[start].k != j:
            self.dropped_fixes += 1
            return
        entry = self._history[start]
        if not self._gate(entry.x, entry.P, fix.pose):
            return
        if j < self._latest_measured:
            self.reordered_fixes += 1
        self._latest_measured = max(self._latest_measured, j)
        self.applied_fixes += 1
        entry.fixes.append(fix.pose)
        entry.x, entry.P, _ = self.fix_update(entry.x, entry.P, fix.pose)
        x, P = entry.x, entry.P
        for i in range(start + 1, len(self._history)):  # replay the samples since, with their fixes
            later = self._history[i]
            x, P = self._predict(x, P, later.travel)
            for z in later.fixes:
                x, P, _ = self.fix_update(x, P, z)
            later.x, later.P = x, P
        self.x, self.P = x, P
