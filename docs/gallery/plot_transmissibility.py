"""
Seat-to-head transmissibility of the shipped bodies
===================================================

The modulus of ``X_head / X_seat`` of the reduced 3-DOF model (the paper's Table 2)
and of the ISO 7962 four-mass model, computed exactly from their state space, with
the resonance peaks :func:`bodyvib.frequency.find_peaks` finds. This is what
``bodyvib frf --plot`` draws.
"""

import matplotlib.pyplot as plt
import numpy as np

from bodyvib import available_models, load_model
from bodyvib.frequency import find_peaks, transmissibility

f = np.geomspace(0.5, 31.5, 800)
fig, ax = plt.subplots(figsize=(7, 4))
for name in available_models():
    modulus = np.abs(transmissibility(load_model(name), f))
    ax.semilogx(f, modulus, label=name)
    for p in find_peaks(f, modulus):
        ax.plot(p.frequency_hz, p.modulus, "k.")
        print(f"{name}: peak {p.modulus:.3f} at {p.frequency_hz:.2f} Hz")
ax.set(xlabel="frequency [Hz]", ylabel="|T| seat to head [-]", title="Transmissibility")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
plt.show()
