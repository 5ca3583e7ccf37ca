"""
An ISO 8608 class C road and its displacement PSD
=================================================

The random road every run drives by default: class C, a sum of harmonics with
random phases (:func:`bodyvib.vehicle.road.random_road`). Its profile, and the PSD
estimated from the profile (:func:`bodyvib.vehicle.road.profile_psd`) against the
class's straight line Gd(n0) (n/n0)^-2 (:func:`bodyvib.vehicle.road.displacement_psd`).
"""

import matplotlib.pyplot as plt
import numpy as np

from bodyvib.vehicle.road import displacement_psd, profile_psd, random_road

road = random_road("C", length=600.0, seed=0)
x = np.arange(0.0, 600.0, 0.05)
z = road.displacement(x)
n, psd, _ = profile_psd(x, z)
band = (n > 0.011) & (n < 2.83)

fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6))
top.plot(x, 1e3 * z, lw=0.6)
top.set(xlabel="distance [m]", ylabel="elevation [mm]", title="Class C, seed 0")
bottom.loglog(n[band], psd[band], lw=0.6, label="from the profile")
bottom.loglog(n[band], displacement_psd(n[band], "C"), "k--", label="ISO 8608, class C")
bottom.set(xlabel="spatial frequency [cycle/m]", ylabel="Gd [m^3]")
bottom.grid(True, which="both", alpha=0.3)
bottom.legend()
fig.tight_layout()
plt.show()
