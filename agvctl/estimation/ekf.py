"""An extended Kalman filter for the pose: odometry (and the gyro) between late, noisy absolute fixes.

State (5): the pose x, y (m), θ (rad) and the relative errors ε_l, ε_r of the believed wheel radii (a 0.5 %
larger wheel is ε = 0.005: the travel the counts give is scaled by 1 + ε). Process model, once per sample, driven
by the travel the encoder counts give with the believed radii, d = Δn·q·r/N (eqs 26, 29):

    s_l,r = (1 + ε_l,r) d_l,r,   Δs = (s_l + s_r)/2 (eq 39),   Δθ = (s_r − s_l)/b (eq 40) or the gyro's Ω·T_s,
    x += Δs cos(θ + Δθ/2),   y += Δs sin(θ + Δθ/2),   θ += Δθ   (eqs 41-43, the midpoint rule)

with process noise from each wheel's travel (one count's quantisation, q_s²/6 from the two latched counts, plus
a relative slip σ) and a slow random walk of ε. A fix (x, y, θ) updates the pose directly (H = [I₃ 0]).

Latency: a fix measured at sample j arrives at sample k > j. With ``latency_compensation`` (the default) the
filter keeps the last samples' states, covariances and travels, applies the fix to the state at j and replays
the travels j+1…k (buffer and replay: exact for a linear update, as if the fix had arrived on time). Without it
the fix is applied at k as if just measured: the error it makes is what a test shows.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agvctl.angles import wrap_angle
from agvctl.config import check_fields, number
from agvctl.params import SIDES, VehicleParams
from agvctl.sensing import Measurements, PositionFix, fix_delay_samples

__all__ = ["EkfSettings", "PoseEkf"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class EkfSettings:
    """The EKF's tuning (beliefs about what the sensor table does not say).

    Parameters
    ----------
    slip_sigma
        Relative σ of each wheel's travel per sample (dimensionless): slip and floor unevenness.
    radius_sigma
        Prior relative σ of each wheel radius (dimensionless, the ε states).
    radius_walk_sigma_per_sqrt_s
        Random walk of ε, 1/√s.
    initial_position_sigma_m
        Initial σ of x and y, m.
    initial_heading_sigma_rad
        Initial σ of θ, rad.
    latency_compensation
        Apply each fix at the sample it was measured and replay the travels since; ``False`` applies it on
        arrival as if just measured.
    history_s
        How far back fixes are replayed, s (at least the believed latency).
    """

    slip_sigma: float = number(ge=0, default=0.0005)
    """Relative σ of each wheel's travel per sample: slip and floor unevenness (the simulated plant has none)."""
    radius_sigma: float = number(gt=0, default=0.01)
    """Prior relative σ of each wheel radius (the ε states): tyre tolerance and wear."""
    radius_walk_sigma_per_sqrt_s: float = number(ge=0, default=1e-5)
    """Random walk of ε (1/√s): keeps the filter adapting to a radius that changes with load."""
    initial_position_sigma_m: float = number(gt=0, default=0.005)
    initial_heading_sigma_rad: float = number(gt=0, default=0.005)
    latency_compensation: bool = True
    """Apply each fix at the sample it was measured and replay the travels since (buffer and replay)."""
    history_s: float = number(gt=0, le=60.0, default=2.0)
    """How far back fixes are replayed (at least the believed latency); older ones are dropped (counted in
    :attr:`PoseEkf.dropped_fixes`)."""

    def __post_init__(self) -> None:
        check_fields(self)


class PoseEkf:
    """The pose EKF (``localization = "ekf"``): the state (x, y, θ, ε_l, ε_r), ε the relative errors of the
    believed wheel radii; odometry from the encoder counts (and the gyro when on) predicts, position fixes
    update, a late fix at the sample it was measured (buffer and replay).

    Parameters
    ----------
    vehicle
        The controller's vehicle: its believed geometry and sensor table (encoder resolution, gyro, fix noise and
        latency).
    settings
        The filter's tuning: slip, radius prior and random walk, the initial covariance, latency compensation.
    """

    def __init__(self, vehicle: VehicleParams, settings: EkfSettings | None = None) -> None:
        self.settings = s = settings or EkfSettings()
        sens = vehicle.sensors
        q = 2.0 * math.pi / sens.encoder_counts_per_rev
        self.metres_per_count = np.array([vehicle.to_rim(side, q) for side in SIDES])
        self.separation_m = vehicle.wheels.separation_m
        ts = vehicle.control.sample_period_s
        self.sample_period_s = ts
        self._count_var = (self.metres_per_count**2 / 6.0).tolist()  # two latched counts, each uniform over one
        self._use_gyro = sens.gyro_enabled
        self._gyro_bias = sens.gyro_bias_rad_s
        self._gyro_var = (sens.gyro_sigma_rad_s**2 + sens.gyro_quantum_rad_s**2 / 12.0) * ts**2
        self._walk_var = s.radius_walk_sigma_per_sqrt_s**2 * ts
        self._fix_r = np.diag([sens.position_fix_sigma_m**2] * 2 + [math.radians(sens.heading_fix_sigma_deg) ** 2])
        # at least the fixes' believed delay and two samples more, whatever history_s says
        self._history_samples = max(int(round(s.history_s / ts)), fix_delay_samples(vehicle) + 2)
        self.x = np.zeros(5)
        self.P = np.zeros((5, 5))
        self.last_nis = math.nan
        """NIS νᵀS⁻¹ν of the last fix applied at the latest update (NaN when none arrived)."""
        self.dropped_fixes = 0
        self._history: deque[tuple[int, FloatArray, FloatArray, FloatArray]] = deque()
        self._counts: NDArray[np.int64] | None = None

    @property
    def pose_covariance(self) -> FloatArray:
        """The pose's 3×3 covariance (m², m rad, rad²)."""
        return self.P[:3, :3]

    def reset(self, pose: FloatArray) -> None:
        s = self.settings
        self.x = np.array([*pose, 0.0, 0.0], dtype=float)
        self.P = np.diag(
            [s.initial_position_sigma_m**2] * 2 + [s.initial_heading_sigma_rad**2] + [s.radius_sigma**2] * 2
        )
        self._history.clear()
        self._counts = None
        self.last_nis = math.nan
        self.dropped_fixes = 0

    def update(self, measurements: Measurements) -> FloatArray:
        """The :class:`~agvctl.estimation.base.PoseEstimator` step: :meth:`step` on this sample's readings."""
        m = measurements
        return self.step(m.sample, m.encoder_counts, m.gyro_rate_rad_s, m.fixes)

    def step(
        self, k: int, encoder_counts: NDArray[np.int64], gyro_rate_rad_s: float, fixes: tuple[PositionFix, ...]
    ) -> FloatArray:
        """Advance to sample k with the latched counts, the gyro's rate (NaN: none) and the fixes arriving."""
        if self._counts is None:
            travel = np.array([0.0, 0.0, math.nan])
        else:
            d_l, d_r = ((encoder_counts - self._counts) * self.metres_per_count).tolist()
            travel = np.array([d_l, d_r, (gyro_rate_rad_s - self._gyro_bias) * self.sample_period_s])
            self.x, self.P = self._predict(self.x, self.P, travel)
        self._counts = encoder_counts
        self._history.append((k, travel, self.x, self.P))
        while len(self._history) > self._history_samples:
            self._history.popleft()
        self.last_nis = math.nan
        for fix in fixes:
            self._apply_fix(fix, k)
        return self.x[:3]

    def _predict(self, x: FloatArray, P: FloatArray, travel: FloatArray) -> tuple[FloatArray, FloatArray]:
        x_new, F, Q = self.transition(x, travel)
        P_new = F @ P @ F.T
        P_new += Q
        return x_new, P_new

    def transition(self, x: FloatArray, travel: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Eqs 39-43 over one sample from state ``x`` with ``travel`` = (d_l m, d_r m, gyro Δθ rad or NaN):
        the next state, its Jacobian F (5×5) and the process noise Q (5×5). Scalars in plain floats, one array
        built per result: numpy's per-call cost would exceed the arithmetic."""
        d_l, d_r, gyro_dtheta = travel.tolist()
        px, py, th, e_l, e_r = x.tolist()
        b = self.separation_m
        s_l, s_r = (1.0 + e_l) * d_l, (1.0 + e_r) * d_r
        ds = 0.5 * (s_l + s_r)  # eq 39
        gyro = self._use_gyro and not math.isnan(gyro_dtheta)
        dtheta = gyro_dtheta if gyro else (s_r - s_l) / b  # eq 40
        mid = th + 0.5 * dtheta
        c, s = math.cos(mid), math.sin(mid)
        x_new = np.array([px + ds * c, py + ds * s, th + dtheta, e_l, e_r])  # eqs 41-43
        # ∂(x, y, θ)/∂(s_l, s_r): how each wheel's travel moves the pose
        k_h = 0.0 if gyro else 1.0 / b
        gl = (0.5 * c + 0.5 * ds * s * k_h, 0.5 * s - 0.5 * ds * c * k_h, -k_h)
        gr = (0.5 * c - 0.5 * ds * s * k_h, 0.5 * s + 0.5 * ds * c * k_h, k_h)
        F = np.eye(5)
        F[0, 2], F[1, 2] = -ds * s, ds * c
        F[0, 3], F[1, 3], F[2, 3] = gl[0] * d_l, gl[1] * d_l, gl[2] * d_l
        F[0, 4], F[1, 4], F[2, 4] = gr[0] * d_r, gr[1] * d_r, gr[2] * d_r
        slip = self.settings.slip_sigma
        v_l = self._count_var[0] + (slip * d_l) ** 2
        v_r = self._count_var[1] + (slip * d_r) ** 2
        gg = (-0.5 * ds * s, 0.5 * ds * c, 1.0) if gyro else (0.0, 0.0, 0.0)
        Q = np.zeros((5, 5))
        for i in range(3):
            for j in range(i, 3):
                Q[i, j] = Q[j, i] = gl[i] * gl[j] * v_l + gr[i] * gr[j] * v_r + gg[i] * gg[j] * self._gyro_var
        Q[3, 3] = Q[4, 4] = self._walk_var
        return x_new, F, Q

    def fix_update(self, x: FloatArray, P: FloatArray, z: FloatArray) -> tuple[FloatArray, FloatArray, float]:
        """A fix z = (x, y, θ) applied to (x, P): H = [I₃ 0], R from the believed sensor table; returns the
        updated state and covariance and the NIS."""
        nu = z - x[:3]
        nu[2] = wrap_angle(nu[2])
        S = P[:3, :3] + self._fix_r
        K = np.linalg.solve(S, P[:3, :]).T  # P Hᵀ S⁻¹ (S symmetric)
        x_new = x + K @ nu
        P_new = P - K @ P[:3, :]
        P_new = 0.5 * (P_new + P_new.T)
        return x_new, P_new, float(nu @ np.linalg.solve(S, nu))

    def _apply_fix(self, fix: PositionFix, k: int) -> None:
        if not self.settings.latency_compensation:
            self.x, self.P, self.last_nis = self.fix_update(self.x, self.P, fix.pose)
            self._history[-1] = (k, self._history[-1][1], self.x, self.P)
            return
        start = next((i for i, entry in enumerate(self._history) if entry[0] == fix.measured_sample), None)
        if start is None:
            self.dropped_fixes += 1
            return
        j, travel, x, P = self._history[start]
        x, P, self.last_nis = self.fix_update(x, P, fix.pose)
        self._history[start] = (j, travel, x, P)
        for i in range(start + 1, len(self._history)):  # replay the travels since the fix was measured
            j, travel, _, _ = self._history[i]
            x, P = self._predict(x, P, travel)
            self._history[i] = (j, travel, x, P)
        self.x, self.P = x, P
