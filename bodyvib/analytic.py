"""The paper's analytic transfer functions of the reduced 3-DOF model.

Balci & Gundogdu (2025), Eqs. 4-13, for the chain
seat ``x_r`` --ks-- platform ``y`` --(k2 || c2)-- ``m2`` --(k1 || c1)-- ``m1``:

    X1/Xr = -ks (k1 + c1 s)(k2 + c2 s) / Delta(s)                    (4)
    X2/Xr = -ks (m1 s^2 + c1 s + k1)(k2 + c2 s) / Delta(s)           (5)
    Delta(s) = A0 + A1 s + ... + A5 s^5                              (7-13)

The paper's Eq. 6 for ``Y/Xr`` is misprinted (its numerator is of higher
degree than Delta). From the platform's force balance,
``ks (Xr - Y) = Z2 (Y - X2)`` with ``Z2 = k2 + c2 s``, so

    Y/Xr = (ks + Z2 X2/Xr) / (ks + Z2).

All functions take arrays of parameters, so a whole GA population is
evaluated in one call (broadcasting over leading axes).
"""

import numpy as np

__all__ = [
    "characteristic_coefficients",
    "head_transmissibility",
    "torso_transmissibility",
    "platform_transmissibility",
]


def characteristic_coefficients(m1, m2, k1, k2, c1, c2, ks):
    """Coefficients ``A0..A5`` of the paper's Delta(s) (Eqs. 8-13).

    Parameters
    ----------
    m1, m2 : float or ndarray
        Head and torso masses, kg.
    k1, k2, ks : float or ndarray
        Stiffnesses, N/m.
    c1, c2 : float or ndarray
        Damping coefficients, N s/m.

    Returns
    -------
    tuple of 6 arrays
        ``(A0, A1, A2, A3, A4, A5)``, lowest power first.

    References
    ----------
    M. Balci, O. Gundogdu, "Model Order Reduction of a Human Body Vibration
    Model", 2025, Eqs. 7-13.
    """
    A0 = -k1 * k2 * ks
    A1 = -c1 * k2 * ks - c2 * k1 * ks
    A2 = -c1 * c2 * ks - k1 * k2 * m1 - k1 * k2 * m2 - k1 * ks * m1 - k1 * ks * m2 - k2 * ks * m1
    A3 = (
        -c1 * k2 * m1
        - c2 * k1 * m1
        - c1 * k2 * m2
        - c2 * k1 * m2
        - c1 * ks * m1
        - c1 * ks * m2
        - c2 * ks * m1
    )
    A4 = -c1 * c2 * m1 - c1 * c2 * m2 - k2 * m1 * m2 - ks * m1 * m2
    A5 = -c2 * m1 * m2
    return A0, A1, A2, A3, A4, A5


def _delta(s, coeffs):
    out = 0.0
    for a in reversed(coeffs):  # Horner
        out = out * s + a
    return out


def _params(p, s):
    """Broadcast parameter arrays against the frequency axis (last axis)."""
    p = [np.asarray(x, dtype=float)[..., None] for x in p]
    return p, np.asarray(s)


def head_transmissibility(s, m1, m2, k1, k2, c1, c2, ks):
    """``X1/Xr`` of the reduced model (paper Eq. 4), dimensionless.

    Parameters
    ----------
    s : array_like of complex
        Laplace variable (``2j*pi*f`` for a frequency response), last axis.
    m1, m2, k1, k2, c1, c2, ks : float or ndarray
        Parameters (SI); leading axes broadcast (e.g. a population).

    Returns
    -------
    ndarray of complex
        Shape ``broadcast(params) + s.shape``.
    """
    (m1, m2, k1, k2, c1, c2, ks), s = _params((m1, m2, k1, k2, c1, c2, ks), s)
    d = _delta(s, characteristic_coefficients(m1, m2, k1, k2, c1, c2, ks))
    return -ks * (k1 + c1 * s) * (k2 + c2 * s) / d


def torso_transmissibility(s, m1, m2, k1, k2, c1, c2, ks):
    """``X2/Xr`` of the reduced model (paper Eq. 5); see :func:`head_transmissibility`."""
    (m1, m2, k1, k2, c1, c2, ks), s = _params((m1, m2, k1, k2, c1, c2, ks), s)
    d = _delta(s, characteristic_coefficients(m1, m2, k1, k2, c1, c2, ks))
    return -ks * (m1 * s * s + c1 * s + k1) * (k2 + c2 * s) / d


def platform_transmissibility(s, m1, m2, k1, k2, c1, c2, ks):
    """``Y/Xr`` of the massless platform (corrected Eq. 6).

    ``Y/Xr = (ks + Z2 X2/Xr) / (ks + Z2)``, ``Z2 = k2 + c2 s``; the paper's
    printed Eq. 6 has a numerator of higher degree than Delta and is not used.
    """
    t2 = torso_transmissibility(s, m1, m2, k1, k2, c1, c2, ks)
    (m1, m2, k1, k2, c1, c2, ks), s = _params((m1, m2, k1, k2, c1, c2, ks), s)
    z2 = k2 + c2 * s
    return (ks + z2 * t2) / (ks + z2)
