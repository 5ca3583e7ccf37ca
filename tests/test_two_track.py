"""Two-track ISO 8608 roads: the right track's coherence with the left against the
isotropic-surface model, within the estimate's statistical bounds."""

import numpy as np
import pytest
from scipy.signal import coherence

from bodyvib import BodyvibError
from bodyvib.vehicle.road import random_road, track_coherence, two_track_road

LENGTH, DX, SEGMENT = 4000.0, 0.05, 2048


@pytest.fixture(scope="module")
def estimate():
    left, right = two_track_road("C", track_width=1.5, length=LENGTH, seed=3)
    x = np.arange(0.0, LENGTH, DX)
    n, gamma2 = coherence(left.displacement(x), right.displacement(x), fs=1 / DX, nperseg=SEGMENT)
    return n[1:], gamma2[1:], x.size / SEGMENT  # independent (non-overlapping) segments


def test_coherence_matches_the_model_where_the_tracks_are_correlated(estimate):
    """Welch's estimate of a coherence g has a normalised random error
    sqrt(2) (1 - g) / (sqrt(g) sqrt(n_d)) (Bendat & Piersol, Random Data, eq. 9.82);
    counting only the non-overlapping segments makes the bound conservative. Every bin
    with g > 0.1 lies within four of these errors."""
    n, gamma2, segments = estimate
    model = track_coherence(n, 1.5) ** 2
    band = (n > 0.02) & (model > 0.1)
    assert band.sum() >= 10
    g = model[band]
    error = np.sqrt(2) * (1 - g) / np.sqrt(g * segments)
    assert np.all(np.abs(gamma2[band] - g) <= 4 * error * g)


def test_coherence_vanishes_where_the_model_does(estimate):
    """Where the model's coherence is below 1e-3, the estimate is its bias alone, about
    1/n_d for n_d independent segments: the mean stays below 2/n_d."""
    n, gamma2, segments = estimate
    model = track_coherence(n, 1.5) ** 2
    zero = (model < 1e-3) & (n < 2.8)
    assert zero.sum() >= 50
    assert np.mean(gamma2[zero]) < 2 / segments


def test_the_left_track_is_the_single_track_road_and_the_right_has_its_power():
    left, right = two_track_road("D", track_width=1.6, length=1000.0, seed=5)
    single = random_road("D", 1000.0, 5)
    np.testing.assert_array_equal(left.amplitude, single.amplitude)
    np.testing.assert_array_equal(left.phase, single.phase)
    # |c_i|^2 = a_i^2 (1 + 2 rho_i sqrt(1 - rho_i^2) cos(phi_i - psi_i)): the right track's
    # power is the left's in expectation, with variance 2 sum a^4 rho^2 (1 - rho^2)
    a2, rho = left.amplitude**2, track_coherence(left.n, 1.6)
    spread = np.sqrt(2 * np.sum(a2**2 * rho**2 * (1 - rho**2)))
    assert abs(np.sum(right.amplitude**2) - np.sum(a2)) <= 4 * spread


def test_coherence_limits():
    """rho is 1 for wavelengths long against the track width and 0 for short ones."""
    rho = track_coherence([1e-4, 50.0], 1.5)
    assert rho[0] == pytest.approx(1.0, abs=1e-5)
    assert rho[1] == pytest.approx(0.0, abs=1e-100)


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: track_coherence([0.1], 1.5, waviness=2.5), "waviness 2 only"),
        (lambda: track_coherence([0.1], 0.0), "track width must be a positive number of m"),
        (lambda: two_track_road("C", track_width=-1.0), "track width"),
    ],
)
def test_bad_input_is_refused(call, match):
    with pytest.raises(BodyvibError, match=match):
        call()


@pytest.mark.parametrize("n", [0.02, 0.1, 0.3, 1.0])
def test_coherence_is_the_isotropic_surfaces(n):
    """An isotropic surface with the 2-D PSD (n^2 + m^2)^(-3/2) has the profile PSD
    n^-2 along any line; two lines B apart have the normalised cross-spectrum
    int S cos(2 pi m B) dm / int S dm, integrated here by quadrature."""
    from scipy.integrate import quad

    B = 1.5
    density = lambda m: (n * n + m * m) ** -1.5  # noqa: E731
    cross = quad(density, 0, np.inf, weight="cos", wvar=2 * np.pi * B)[0]
    assert track_coherence([n], B)[0] == pytest.approx(
        cross / quad(density, 0, np.inf)[0], rel=1e-6
    )
