"""The paper's analytic transfer functions against the network's state space."""

import numpy as np
import pytest

from bodyvib.analytic import (characteristic_coefficients, head_transmissibility,
                              platform_transmissibility, torso_transmissibility)
from bodyvib.frequency.response import frequency_response
from bodyvib.models import load_model
from bodyvib.runtime.network import linear_model

NAMES = ("m1", "m2", "k1", "k2", "c1", "c2", "ks")


def random_parameter_sets(rng, n):
    base = load_model("reduced-paper").parameters
    for _ in range(n):
        yield {k: base[k] * 10 ** rng.uniform(-1, 1) for k in NAMES}


def test_delta_is_the_characteristic_polynomial(rng):
    net = load_model("reduced-paper")
    for p in random_parameter_sets(rng, 10):
        A = linear_model(net.with_parameters(**p)).A
        coeffs = characteristic_coefficients(*(p[k] for k in NAMES))
        # Delta(s) = A5 * det(sI - A)
        monic = np.array(coeffs[::-1]) / coeffs[5]
        np.testing.assert_allclose(monic, np.poly(A), rtol=1e-9)


@pytest.mark.parametrize("fn, output", [
    (head_transmissibility, "m1.x"),
    (torso_transmissibility, "m2.x"),
    (platform_transmissibility, "platform.y"),
])
def test_analytic_equals_state_space_at_random_parameters(rng, fn, output):
    net = load_model("reduced-paper")
    f = np.geomspace(0.1, 100, 80)
    s = 2j * np.pi * f
    for p in random_parameter_sets(rng, 20):
        ss = frequency_response(net.with_parameters(**p), f, output)
        an = fn(s, *(p[k] for k in NAMES))
        np.testing.assert_allclose(an, ss, rtol=1e-9)


def test_population_broadcasting(rng):
    sets = list(random_parameter_sets(rng, 7))
    pop = {k: np.array([p[k] for p in sets]) for k in NAMES}
    s = 2j * np.pi * np.linspace(0.5, 31.5, 30)
    T = head_transmissibility(s, *(pop[k] for k in NAMES))
    assert T.shape == (7, 30)
    for i, p in enumerate(sets):
        np.testing.assert_allclose(T[i], head_transmissibility(s, *(p[k] for k in NAMES)),
                                   rtol=1e-14)


def test_printed_eq6_is_not_a_proper_transfer_function():
    """Why we derive Y/Xr: the printed numerator has degree 7 > deg Delta = 5."""
    p = load_model("reduced-paper").parameters
    s = 2j * np.pi * np.array([100.0, 1000.0])
    m1, m2, k1, k2, c1, c2, ks = (p[k] for k in NAMES)
    num = ks * m1 * s**2 * (k1 + c1 * s) * (m1 * s**2 + c1 * s + k1) * (m2 * s**2 + c2 * s + k2)
    from bodyvib.analytic import _delta
    printed = -num / _delta(s, characteristic_coefficients(m1, m2, k1, k2, c1, c2, ks))
    # grows like s^2: x100 per decade, where a transmissibility must fall off
    assert abs(printed[1]) / abs(printed[0]) == pytest.approx(100, rel=0.05)
    assert abs(platform_transmissibility(s, m1, m2, k1, k2, c1, c2, ks)[1]) < 1
