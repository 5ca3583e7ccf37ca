"""
The ISO 2631-1 Wk frequency weighting
=====================================

Every comfort figure bodyvib prints (Wk r.m.s., VDV, MTVV) weights the vertical
acceleration with Wk. Here its modulus from :func:`bodyvib.comfort.wk_response`,
with the factors of the standard's Table 3 at the one-third-octave frequencies as
points: the curve passes through them.
"""

import matplotlib.pyplot as plt
import numpy as np

from bodyvib.comfort import wk_response

f = np.geomspace(0.1, 100.0, 600)
# ISO 2631-1 Table 3, Wk (factor, not dB), at a few one-third-octave frequencies
table = {0.5: 0.418, 1.0: 0.482, 2.0: 0.531, 4.0: 0.967, 6.3: 1.054, 8.0: 1.036, 20.0: 0.636}
fig, ax = plt.subplots(figsize=(7, 4))
ax.loglog(f, np.abs(wk_response(f)), label="wk_response")
ax.loglog(list(table), list(table.values()), "o", label="ISO 2631-1 Table 3")
ax.set(xlabel="frequency [Hz]", ylabel="|Wk| [-]", title="Wk weighting")
ax.grid(True, which="both", alpha=0.3)
ax.legend()
plt.show()
