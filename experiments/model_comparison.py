"""The report's point that models of different complexity differ: one voltage profile through all three.

The same DA voltages, held over 40 ms samples, drive
  * the full nonlinear model (friction of eqs 2-4, centrifugal/coriolis terms, current limit; eqs 52-59),
  * the simplified linear model (eqs 35-38, python-control ``StateSpace``, sampled exactly with a ZOH),
  * the decoupled per-wheel model (eqs 60-61, python-control ``TransferFunction``s, likewise).
Poses follow from each model's wheel speeds through the same kinematics (eqs 39-43).

The profile has five phases, each showing one reason the models part:
  1. creep (0-3 s): a voltage just above break-away. Friction (τ_c = 0.065 N m ≈ 0.9 V of motor voltage)
     eats most of it in the full model; the linear models, with no Coulomb friction, run at u/k_e.
  2. cruise (3-7 s): a moderate straight run; the models agree up to the Coulomb offset.
  3. spin (7-11 s): opposite voltages. The full model's centre of mass behind the axle loads the motors with
     M h ω² (centrifugal, eq 10): the vehicle drifts backwards. The linear models spin in place.
  4. coast (11-13 s): zero voltage. Coulomb friction stops the full model sooner, and stiction holds it.
  5. full-scale start (13-15 s): a step to full scale from rest. The current limit caps the full model's
     acceleration at a_lim (eq 5); the linear models accelerate several times faster.

Run:  python experiments/model_comparison.py [--out DIR]   (writes model_comparison.png and prints a table)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import control
import numpy as np

from agvctl.actuator import Actuator
from agvctl.params import load_vehicle
from agvctl.plant import decoupled_wheel_models, linear_model
from agvctl.sim import simulate_open_loop

PHASES = (  # (name, start_s, end_s, DA left V, DA right V)
    ("creep", 0.0, 3.0, 0.55, 0.55),
    ("cruise", 3.0, 7.0, 2.0, 2.0),
    ("spin", 7.0, 11.0, 3.0, -3.0),
    ("coast", 11.0, 13.0, 0.0, 0.0),
    ("full-scale start", 13.0, 15.0, 5.0, 5.0),
)


def profile(ts: float) -> np.ndarray:
    rows = []
    for _name, t0, t1, left, right in PHASES:
        rows += [(left, right)] * int(round((t1 - t0) / ts))
    return np.array(rows)


def kinematics(omega_motor: np.ndarray, r: float, n: float, b: float, ts: float) -> np.ndarray:
    """Pose (x, y, θ) from motor speeds sampled every ts (eqs 39-43, trapezoidal)."""
    v = omega_motor * r / n
    speed, yaw = (v[:, 0] + v[:, 1]) / 2, (v[:, 1] - v[:, 0]) / b
    pose = np.zeros((len(v), 3))
    for k in range(1, len(v)):
        th_mid = pose[k - 1, 2] + 0.5 * ts * 0.5 * (yaw[k] + yaw[k - 1])
        s = 0.5 * (speed[k] + speed[k - 1]) * ts
        pose[k] = pose[k - 1] + [s * np.cos(th_mid), s * np.sin(th_mid), 0.5 * (yaw[k] + yaw[k - 1]) * ts]
    return pose


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/model_comparison", help="directory for model_comparison.png")
    args = ap.parse_args()

    v = load_vehicle()
    ts, r, n, b = v.control.sample_period_s, v.wheels.left.radius_m, v.motor.left.gear_ratio, v.wheels.separation_m
    da = profile(ts)
    t = np.arange(len(da) + 1) * ts
    u = Actuator(v).apply(da).motor_voltage_v  # the same motor voltages into every model
    u_held = np.vstack([u, u[-1:]])

    full = simulate_open_loop(v, da).log
    w_full = np.column_stack([full["omega_motor_left_rad_s"], full["omega_motor_right_rad_s"]])

    lin_d = control.sample_system(linear_model(v), ts, method="zoh")  # exact for held inputs
    w_lin = control.forced_response(lin_d, T=t, U=u_held.T).outputs.T
    left, right = decoupled_wheel_models(v)
    w_dec = np.column_stack(
        [
            control.forced_response(control.sample_system(tf, ts, method="zoh"), T=t, U=u_held[:, i]).outputs
            for i, tf in enumerate((left, right))
        ]
    )

    poses = {
        "full (eqs 52-59)": np.column_stack([full["x_m"], full["y_m"], full["theta_rad"]]),
        "linear (eqs 35-38)": kinematics(w_lin, r, n, b, ts),
        "decoupled (eqs 60-61)": kinematics(w_dec, r, n, b, ts),
    }
    speeds = {"full (eqs 52-59)": w_full, "linear (eqs 35-38)": w_lin, "decoupled (eqs 60-61)": w_dec}

    print(f"{'phase':<18} {'model':<22} {'U end [m/s]':>12} {'ω end [rad/s]':>14} {'peak accel [m/s²]':>18}")
    for name, t0, t1, _l, _r in PHASES:
        k0, k1 = int(round(t0 / ts)), int(round(t1 / ts))
        for model, w in speeds.items():
            wheel = w * r / n
            U = (wheel[k1, 0] + wheel[k1, 1]) / 2
            om = (wheel[k1, 1] - wheel[k1, 0]) / b
            acc = np.max(np.abs(np.diff(wheel[k0 : k1 + 1], axis=0))) / ts
            print(f"{name:<18} {model:<22} {U:12.4f} {om:14.4f} {acc:18.3f}")
    print("\nwhere they part:")
    k = int(round(3.0 / ts))
    print(
        f"  creep:  full {w_full[k, 0]:.1f} rad/s vs linear {w_lin[k, 0]:.1f} rad/s — Coulomb friction "
        f"τ_c R/k_t = {0.065 * 0.38 / 0.027:.2f} V of the {u[0, 0]:.2f} V are lost to friction"
    )
    k = int(round(11.0 / ts))
    Uf = full["speed_m_s"][k]
    print(f"  spin:   full model drifts at U = {Uf:.3f} m/s (centrifugal load M h ω² on the motors); linear ones at 0")
    a_lim = v.derived.accel_limit_m_s2
    k0 = int(round(13.0 / ts))
    lin_acc = np.max(np.diff(w_lin[k0:, 0])) / ts * r / n
    print(
        f"  start:  full model's acceleration capped at a_lim = {a_lim:.3f} m/s² by the 5.5 A current limit; "
        f"linear model {lin_acc:.2f} m/s²"
    )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for (model, w), c in zip(speeds.items(), ("C0", "C1", "C2"), strict=True):
        wheel = w * r / n
        axes[0].plot(t, (wheel[:, 0] + wheel[:, 1]) / 2, color=c, label=model)
        axes[1].plot(t, (wheel[:, 1] - wheel[:, 0]) / b, color=c, label=model)
        axes[2].plot(t, wheel[:, 0], color=c, label=model)
    for ax, label in zip(axes, ("vehicle speed U [m/s]", "yaw rate ω [rad/s]", "left wheel speed [m/s]"), strict=True):
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        for name, t0, _t1, _l, _r in PHASES:
            ax.axvline(t0, color="k", lw=0.5, ls=":")
            if ax is axes[0]:
                ax.text(t0 + 0.1, ax.get_ylim()[1] * 0.9 if ax.get_ylim()[1] > 0 else 0, name, fontsize=8)
    axes[0].legend(loc="lower right", fontsize=8)
    axes[2].set_xlabel("t [s]")
    fig.suptitle("Same DA voltages, three models: friction at low speed, centrifugal load in the spin, current limit")
    fig.tight_layout()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "model_comparison.png", dpi=90)
    fig2, ax = plt.subplots(figsize=(6, 6))
    for (model, pose), c in zip(poses.items(), ("C0", "C1", "C2"), strict=True):
        ax.plot(pose[:, 0], pose[:, 1], color=c, label=model)
    ax.set(xlabel="x [m]", ylabel="y [m]", aspect="equal", title="paths from the same voltages")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig2.tight_layout()
    fig2.savefig(out / "model_comparison_paths.png", dpi=90)
    print(f"\nwrote {out / 'model_comparison.png'} and {out / 'model_comparison_paths.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
