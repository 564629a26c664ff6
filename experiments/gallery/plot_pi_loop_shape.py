"""
The PI wheel loop: loop shape and margins
=========================================

The wheel-speed PI is designed on the decoupled model of eqs 60-61, sampled with a zero-order hold at 40 ms, for a
phase margin of 60° and a gain margin of 10 dB, as fast as the margins allow (``agvctl tune``). This is the open
loop L(z) of the left wheel up to the Nyquist frequency π/T_s, where this loop's phase reaches −180° and the gain
margin is taken.
"""

import matplotlib.pyplot as plt
import numpy as np

from agvctl.controllers.pi.tuning import TuningSpec, design_pi
from agvctl.params import load_vehicle

vehicle = load_vehicle()
design = design_pi(vehicle, TuningSpec(phase_margin_deg=60, gain_margin_db=10))
m = design.margins
print(f"kp = {design.gains.kp:.5g} V s/rad, ki = {design.gains.ki:.5g} V/rad")
print(f"PM {m.phase_margin_deg:.1f}° at {m.crossover_rad_s:.2f} rad/s")
print(f"GM {m.gain_margin_db:.1f} dB at {m.phase_crossover_rad_s:.2f} rad/s")

loop = design.loop("left")
dt_s = loop.dt
omega = np.logspace(-1, np.log10(np.pi / dt_s), 400)
response = np.array([complex(loop(np.exp(1j * w * dt_s))) for w in omega])
magnitude_db = 20 * np.log10(np.abs(response))
phase_deg = np.degrees(np.unwrap(np.angle(response)))

fig, (ax_mag, ax_phase) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
ax_mag.semilogx(omega, magnitude_db)
ax_mag.axhline(0, color="k", lw=0.5)
ax_mag.axvline(m.crossover_rad_s, color="C1", ls=":", label=f"crossover {m.crossover_rad_s:.1f} rad/s")
ax_mag.annotate(f"GM {m.gain_margin_db:.1f} dB", (omega[-1], magnitude_db[-1]), ha="right", va="bottom")
ax_mag.set(ylabel="|L| [dB]", title="open loop of the left wheel, C(z) k G_zoh(z)")
ax_mag.legend(fontsize=8)
ax_phase.semilogx(omega, phase_deg)
ax_phase.axhline(-180, color="k", lw=0.5)
ax_phase.axvline(m.crossover_rad_s, color="C1", ls=":")
ax_phase.annotate(f"PM {m.phase_margin_deg:.1f}°", (m.crossover_rad_s, -180 + m.phase_margin_deg), ha="left")
ax_phase.set(xlabel="ω [rad/s] (up to π/T_s)", ylabel="∠L [°]")
for ax in (ax_mag, ax_phase):
    ax.grid(alpha=0.3, which="both")
fig.tight_layout()
plt.show()
