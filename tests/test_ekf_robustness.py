"""The pose EKF against the fixes a beacon system really delivers: a fix a metre off (a reflector confusion) is
rejected by the gate and counted, a dropout of seconds stays inside the filter's 3σ, fixes late or out of order
are applied where they were measured (or dropped and counted when too old)."""

import math
from pathlib import Path

import numpy as np
import pytest

from agvctl.estimation.ekf import PoseEkf
from agvctl.estimation.offline import log_encoder_counts, log_fixes
from agvctl.scenario.experiment import load_experiment, run_experiment
from agvctl.sensing import PositionFix

EXPERIMENTS = Path(__file__).resolve().parent.parent / "experiments"


@pytest.fixture(scope="module")
def figure8():
    exp = load_experiment(EXPERIMENTS / "figure8_ekf.toml")
    return exp, run_experiment(exp).log


def filtered(exp, log, fixes):
    """The EKF over the log's counts with the given fixes per sample: estimates, pose σ and the filter."""
    ekf = PoseEkf(exp.controller_vehicle)
    ekf.reset(np.array([log["est_x_m"][0], log["est_y_m"][0], log["est_theta_rad"][0]]))
    counts, gyro = log_encoder_counts(log), log["gyro_rate_rad_s"]
    est, sigma = np.empty((len(log), 3)), np.empty((len(log), 2))
    for k in range(len(log)):
        est[k] = ekf.step(k, counts[k], float(gyro[k]), fixes[k])
        sigma[k] = np.sqrt(np.diagonal(ekf.P)[:2])
    return est, sigma, ekf


def position_error(log, est):
    return np.hypot(est[:, 0] - log["x_m"], est[:, 1] - log["y_m"])


def test_a_fix_a_metre_off_every_ten_seconds_is_rejected_and_counted(figure8):
    exp, log = figure8
    ts = exp.controller_vehicle.control.sample_period_s
    clean = log_fixes(log, ts)
    bad, n_bad = list(clean), 0
    for k, arrived in enumerate(clean):
        if arrived and arrived[0].measured_t_s >= 5.0 + 10.0 * n_bad:  # the first fix from 5, 15, 25 s on
            f = arrived[0]
            bad[k] = (PositionFix(f.measured_sample, f.measured_t_s, f.pose + np.array([1.0, 0.0, 0.0])),)
            n_bad += 1
    assert n_bad == 3  # at 5, 15 and 25 s
    est_clean, _, ekf_clean = filtered(exp, log, clean)
    est_bad, _, ekf_bad = filtered(exp, log, bad)
    assert ekf_clean.rejected_fixes == 0
    assert ekf_bad.rejected_fixes == n_bad and ekf_bad.applied_fixes == ekf_clean.applied_fixes - n_bad
    rms_clean = float(np.sqrt(np.mean(position_error(log, est_clean) ** 2)))
    rms_bad = float(np.sqrt(np.mean(position_error(log, est_bad) ** 2)))
    assert rms_bad <= 1.1 * rms_clean, (rms_bad, rms_clean)


def test_without_the_gate_the_bad_fixes_pull_the_estimate_off(figure8):
    from agvctl.estimation.ekf import EkfSettings

    exp, log = figure8
    ts = exp.controller_vehicle.control.sample_period_s
    fixes = log_fixes(log, ts)
    k_bad = next(k for k, f in enumerate(fixes) if f and f[0].measured_t_s >= 10.0)
    f = fixes[k_bad][0]
    fixes[k_bad] = (PositionFix(f.measured_sample, f.measured_t_s, f.pose + np.array([1.0, 0.0, 0.0])),)
    ungated = PoseEkf(exp.controller_vehicle, EkfSettings(gate_probability=1.0))
    ungated.reset(np.array([log["est_x_m"][0], log["est_y_m"][0], log["est_theta_rad"][0]]))
    counts = log_encoder_counts(log)
    for k in range(k_bad + 1):
        est = ungated.step(k, counts[k], math.nan, fixes[k])
    # the fix's σ is 1 cm against the estimate's few mm: the gain moves the estimate about a tenth of the way
    assert abs(est[0] - log["x_m"][k_bad]) > 0.05


def test_a_five_second_dropout_keeps_the_true_error_inside_three_sigma(figure8):
    exp, log = figure8
    ts = exp.controller_vehicle.control.sample_period_s
    fixes = log_fixes(log, ts)
    t = log["t_s"]
    dropped = [() if f and 10.0 <= f[0].measured_t_s < 15.0 else f for f in fixes]
    est, sigma, ekf = filtered(exp, log, dropped)
    e = np.abs(est[:, :2] - np.column_stack([log["x_m"], log["y_m"]]))
    assert np.all(e <= 3 * sigma), np.max(e / sigma, axis=0)
    during = (t >= 10.0) & (t < 15.0)
    growth = sigma[during][-1] / sigma[during][0]
    assert np.all(growth > 1.5), growth  # the filter knows it is dead reckoning: its σ grows
    assert ekf.rejected_fixes == 0  # and the first fix after the dropout is accepted, its larger σ allowing for it


def test_fixes_out_of_order_give_the_estimate_of_fixes_in_order(figure8):
    exp, log = figure8
    ts = exp.controller_vehicle.control.sample_period_s
    fixes = log_fixes(log, ts)
    arrivals = [k for k, f in enumerate(fixes) if f]
    swapped = list(fixes)
    a, b = arrivals[20], arrivals[21]  # fix 20 arrives just after fix 21: out of order
    swapped[a], swapped[b + 1] = (), fixes[a] + fixes[b + 1]
    est_in, _, in_order = filtered(exp, log, fixes)
    est_out, _, out_of_order = filtered(exp, log, swapped)
    assert out_of_order.reordered_fixes == 1 and in_order.reordered_fixes == 0
    np.testing.assert_allclose(est_out[b + 1 :], est_in[b + 1 :], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out_of_order.P, in_order.P, rtol=1e-7, atol=1e-15)


def test_a_fix_later_than_the_believed_latency_is_replayed_and_one_older_than_the_buffer_dropped(figure8):
    exp, log = figure8
    ts = exp.controller_vehicle.control.sample_period_s
    fixes = log_fixes(log, ts)
    arrivals = [k for k, f in enumerate(fixes) if f]
    late, lost = list(fixes), list(fixes)
    a = arrivals[30]
    late[a], late[a + 12] = (), fixes[a] + late[a + 12]  # 0.5 s later than believed, inside the 2 s buffer
    lost[a], lost[a + 60] = (), fixes[a] + lost[a + 60]  # 2.4 s later: older than the buffer
    est_on_time, _, _ = filtered(exp, log, fixes)
    est_late, _, ekf_late = filtered(exp, log, late)
    _, _, ekf_lost = filtered(exp, log, lost)
    np.testing.assert_allclose(est_late[a + 12 :], est_on_time[a + 12 :], rtol=0, atol=1e-9)
    assert ekf_late.dropped_fixes == 0 and ekf_late.reordered_fixes == 1  # three later fixes came first
    assert ekf_lost.dropped_fixes == 1
