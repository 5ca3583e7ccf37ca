"""Road profiles: the ISO 8608 PSD of a generated profile, bump and sweep shapes."""

import numpy as np
import pytest
from scipy.signal import welch

from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.road.synthetic import (
    BumpRoad,
    SweepRoad,
    class_psd_n0,
    displacement_psd,
    make_road,
    random_road,
    road_input,
)


def test_class_levels_follow_iso8608():
    # ISO 8608: Gd(n0) geometric means 16, 64, 256, ... 262144 x 1e-6 m^3 for A ... H
    assert [class_psd_n0(c) / 1e-6 for c in "ABCDEFGH"] == pytest.approx(
        [16, 64, 256, 1024, 4096, 16384, 65536, 262144]
    )
    assert displacement_psd(0.2, "C") == pytest.approx(256e-6 / 4)


@pytest.mark.parametrize("road_class, seed", [("C", 3), ("A", 11), ("F", 5)])
def test_generated_profile_has_the_class_psd(road_class, seed):
    """Welch estimate of a 3 km profile against Gd(n) = Gd(n0) (n/n0)^-2, averaged
    over octave bands 0.1-2 cycle/m. Tolerance: 5 standard deviations of the band
    average, from the estimator's variance (each Welch bin of K Hann segments with
    50 % overlap has relative variance about 1/(0.95 K)... taken as 1/K; a band of
    M bins averages about M/1.5 independent bins for the Hann window's 1.5-bin
    width), plus 3 % for the Hann window's bias on the curved n^-2 spectrum."""
    L, dx = 3000.0, 0.05
    road = random_road(road_class, length=L, seed=seed)
    x = np.arange(0, L, dx)
    z = road.displacement(x)
    nperseg = 4096
    n, G = welch(z, fs=1 / dx, nperseg=nperseg)  # one-sided PSD, m^2/(cycle/m) = m^3
    K = 2 * len(x) // nperseg - 1
    edges = 0.1 * 2.0 ** np.arange(0, 5)  # 0.1-0.2-0.4-0.8-1.6 cycle/m
    for lo, hi in zip(edges[:-1], edges[1:]):
        sel = (n >= lo) & (n < hi)
        ratio = np.mean(G[sel] / displacement_psd(n[sel], road_class))
        sigma = 1 / np.sqrt(K * sel.sum() / 1.5)
        assert abs(ratio - 1) <= 5 * sigma + 0.03, (lo, hi, ratio, sigma)
    # and the whole-band level is within the class limits (factor 2 about the mean)
    sel = (n >= 0.1) & (n < 2.0)
    gd_n0 = np.exp(np.mean(np.log(G[sel] * (n[sel] / 0.1) ** 2)))
    assert 0.5 < gd_n0 / class_psd_n0(road_class) < 2.0


def test_variance_is_the_integral_of_the_psd():
    """sum a_i^2 / 2 is the midpoint rule of int Gd dn over the harmonics' cells;
    for Gd = Gd(n0) n0^2 / n^2 that integral is Gd(n0) n0^2 (1/a - 1/b), and the
    midpoint rule's error on the first cell, (dn/n)^2 / 4, is below 0.05 % here."""
    road = random_road("D", length=2000.0, seed=2)
    dn = 1 / 2000.0
    a, b = road.n[0] - dn / 2, road.n[-1] + dn / 2
    expected = class_psd_n0("D") * 0.1**2 * (1 / a - 1 / b)
    assert np.sum(road.amplitude**2) / 2 == pytest.approx(expected, rel=5e-4)
    z = road.displacement(np.arange(0, 2000.0, 0.05))
    # over whole periods on a uniform grid the cross terms vanish: sum a_i^2 / 2 exactly
    assert np.var(z) == pytest.approx(np.sum(road.amplitude**2) / 2, rel=1e-9)


def test_seed_reproduces_and_differs():
    a = random_road("C", 100.0, seed=1).displacement(np.arange(0, 100, 0.5))
    b = random_road("C", 100.0, seed=1).displacement(np.arange(0, 100, 0.5))
    c = random_road("C", 100.0, seed=2).displacement(np.arange(0, 100, 0.5))
    assert np.array_equal(a, b)
    assert not np.allclose(a, c)


@pytest.mark.parametrize(
    "road",
    [
        random_road("C", 50.0, seed=4),
        BumpRoad(start=2.0),
        SweepRoad(length=50.0, n_start=0.1, n_stop=2.0),
    ],
)
def test_slope_is_the_derivative_of_the_profile(road):
    """Central differences with h = 1e-4 m: truncation error h^2/6 |z'''| < 1e-6 of the slope scale."""
    x = np.linspace(0.5, 45.0, 997)
    h = 1e-4
    fd = (road.displacement(x + h) - road.displacement(x - h)) / (2 * h)
    scale = np.max(np.abs(road.slope(x)))
    assert np.max(np.abs(fd - road.slope(x))) <= 1e-4 * scale


def test_bump_shape():
    b = BumpRoad(height=0.04, bump_length=2.0, start=5.0)
    z = b.displacement([4.9, 5.0, 5.5, 6.0, 7.0, 7.1])
    assert z == pytest.approx([0, 0, 0.02, 0.04, 0, 0], abs=1e-15)
    t = np.linspace(0, 2, 2001)
    zt, vt = road_input(b, 5.0, t)  # at 5 m/s: on the bump from 1.0 to 1.4 s
    assert np.max(zt) == pytest.approx(0.04)
    assert t[np.argmax(zt)] == pytest.approx(1.2, abs=1e-3)
    assert np.max(vt) == pytest.approx(0.02 * np.pi / 2.0 * 2 * 5.0, rel=1e-5)


def test_sweep_frequency_rises_as_specified():
    """Zero crossings of the sweep give the local frequency n(x) = n0 (n1/n0)^(x/L)."""
    s = SweepRoad(amplitude=0.01, n_start=0.1, n_stop=1.0, length=200.0)
    x = np.linspace(0, 200, 400001)
    z = s.displacement(x)
    zc = x[:-1][np.sign(z[:-1]) != np.sign(z[1:])]
    mid = 0.5 * (zc[1:] + zc[:-1])
    n_est = 0.5 / np.diff(zc)
    n_th = 0.1 * 10 ** (mid / 200)
    assert np.max(np.abs(n_est / n_th - 1)) < 0.01
    assert np.max(np.abs(z)) == pytest.approx(0.01, rel=1e-3)


def test_make_road_and_errors():
    assert make_road("c", 20.0, 10.0).length >= 200.0
    assert isinstance(make_road("bump", 20.0, 10.0), BumpRoad)
    sweep = make_road("sweep", 20.0, 10.0)
    assert sweep.n_start * 20 == pytest.approx(0.5) and sweep.n_stop * 20 == pytest.approx(20)
    with pytest.raises(BodyvibError, match="road class|unknown road"):
        make_road("Z", 20.0, 10.0)
    with pytest.raises(BodyvibError, match="speed"):
        make_road("C", -1.0, 10.0)
    with pytest.raises(BodyvibError, match="duration"):
        make_road("C", 20.0, 0.0)
    with pytest.raises(BodyvibError, match="seed must be a non-negative integer"):
        make_road("C", 20.0, 10.0, seed=-1)  # numpy's default_rng raised a bare ValueError
    with pytest.raises(BodyvibError, match="road class"):
        class_psd_n0("I")


@pytest.mark.parametrize("spec", ["C", "F", "bump", "sweep"])
def test_every_driven_road_starts_level_and_joins_the_road_smoothly(spec):
    """driven_road fades every road in from level over 5 m: height and slope 0 at x = 0, the
    road itself from 5 m on (and until 5 m before the end), and the slope continuous across
    the fade's end (central differences of 1e-6 m agree with the exact slope to 1e-6 of its
    scale: the product rule w' z + w z' is the derivative)."""
    from bodyvib.vehicle.road.driven import RoadOptions, driven_road

    road = driven_road(RunSettings(spec, 20.0, 10.0))
    assert float(road.displacement(0.0)) == 0.0 and float(road.slope(0.0)) == 0.0
    inner = road.road
    x = np.linspace(5.0, road.length - 5.0 if np.isfinite(road.length) else 150.0, 3001)
    np.testing.assert_array_equal(road.displacement(x), inner.displacement(x))
    xs = np.linspace(0.001, 9.999, 4001)
    h = 1e-6
    fd = (road.displacement(xs + h) - road.displacement(xs - h)) / (2 * h)
    scale = max(np.max(np.abs(road.slope(xs))), 1e-12)
    assert np.max(np.abs(fd - road.slope(xs))) <= 1e-5 * scale + 1e-12
    untapered = driven_road(RunSettings(spec, 20.0, 10.0, road_options=RoadOptions(taper_m=0.0)))
    np.testing.assert_array_equal(untapered.displacement(xs), inner.displacement(xs))


def test_taper_longer_than_half_the_road_is_refused():
    from bodyvib.vehicle.road.driven import RoadOptions, driven_road

    with pytest.raises(BodyvibError, match=r"cannot fade in and out over 6 m .*\(taper_m\)"):
        driven_road(RunSettings("C", 10.0, 1.0, road_options=RoadOptions(taper_m=6.0)))
    with pytest.raises(BodyvibError, match="non-negative"):
        driven_road(RunSettings("C", 10.0, 1.0, road_options=RoadOptions(taper_m=-1.0)))


def test_cosim_and_road_fmu_take_the_same_road():
    """The default cosim road (class C, seed 0, 20 m/s, 30 s) is the road Road.fmu tabulates,
    bit for bit: one road, faded in, for both."""
    from bodyvib.vehicle.fmus import fmu_road
    from bodyvib.vehicle.road.driven import driven_road

    x = np.linspace(0.0, 601.0, 60101)
    a, b = driven_road(RunSettings("C", 20.0, 30.0)), fmu_road()
    np.testing.assert_array_equal(a.displacement(x), b.displacement(x))
    np.testing.assert_array_equal(a.slope(x), b.slope(x))


def test_uniform_profiles_equal_the_direct_harmonic_sum_through_the_shared_transform():
    """On a uniform grid a profile is evaluated by a chirp-z transform whose set-up is kept
    for the next road of the same sizes and step; against the direct sum of cosines (the
    same profile on the grid with one point moved by 1e-3 dx, which takes the direct
    path), for roads that share the kept transform (two seeds, one grid) and roads that
    need another (a second spacing of the same length): they agree to 1e-10 of the
    profile's largest height. Rounding bound: the direct sum's cosine arguments reach
    2 pi n_max x_max = 2 pi 2.83 200, about 3.6e3 rad, so each term carries about
    3.6e3 eps = 8e-13 of its amplitude, and 564 terms of random sign sum to about
    sqrt(564) 8e-13, 2e-11 of the largest height (3e-12 measured); a wrong transform is
    off by the profile itself."""
    L, count = 200.0, 4000
    for dx, seed in ((0.05, 1), (0.05, 2), (0.049, 1)):
        road = random_road("D", length=L, seed=seed)
        x = np.arange(count) * dx
        fast = road.displacement(x)
        bent = x.copy()
        bent[count // 2] += 1e-3 * dx
        direct = road.displacement(bent)
        keep = np.arange(count) != count // 2
        scale = np.max(np.abs(direct))
        assert np.max(np.abs(fast - direct)[keep]) <= 1e-10 * scale, (dx, seed)


def test_a_long_grid_is_summed_in_pieces_that_equal_the_direct_sum():
    """A grid longer than one piece (65536 points: a safe point for a signal after each)
    is three transforms here; at the pieces' first and last points and at random ones it
    equals the direct sum of cosines (those points alone, fewer than 64, take the direct
    path) within 1e-8 of the profile's largest height. The direct sum is good to ~1e-11
    (arguments up to 2 pi 2.83 3000 = 5.3e4 rad, 1.2e-11 of each amplitude); the transform
    loses more to its chirp, whose phase grows with the square of the index (a piece plus a
    harmonic chunk, ~7.5e4): 9e-10 measured here, 5e-9 for a 3000 s road (3e-7 with its
    grid in one piece). A piece started one point off is off by the profile's change over
    a point, ~1e-2 of its height. A half car's rear wheel 2 m behind, whose first samples
    are off the road, sees the front wheel's road 100 samples (2 m at 20 m/s and 1 ms)
    later: the same pieces of the same road, 1e-15 measured, to the same tolerance."""
    from bodyvib.vehicle.road.driven import wheel_inputs

    road = random_road("D", length=3100.0, seed=3)
    n = 150_000
    x = np.arange(n) * 0.02
    fast = road.displacement(x)
    picks = np.r_[
        0, 65535, 65536, 131071, 131072, n - 1, np.random.default_rng(0).integers(0, n, 30)
    ]
    direct = np.array([road.displacement(x[i : i + 1])[0] for i in picks])
    scale = np.max(np.abs(fast))
    assert np.max(np.abs(fast[picks] - direct)) <= 1e-8 * scale

    z, v = wheel_inputs(road, 20.0, np.arange(n) * 1e-3, behind=(0.0, 2.0))
    assert np.all(z[:100, 1] == 0.0) and np.all(v[:100, 1] == 0.0)  # not yet on the road
    assert np.max(np.abs(z[100:, 1] - z[:-100, 0])) <= 1e-8 * np.max(np.abs(z))
    assert np.max(np.abs(v[100:, 1] - v[:-100, 0])) <= 1e-8 * np.max(np.abs(v))


def test_the_road_transform_is_scipys_without_importing_scipy_fft():
    """A sweep task (road synthesis, engine, figures) runs without importing scipy.signal
    or scipy.fft (0.1-0.9 s of a worker's start), and its chirp-z transform is
    scipy.signal.CZT's: the same bits with numpy 2 (numpy.fft and scipy.fft are the same
    pocketfft code), else within a few ulps of the largest output (in a fresh process:
    this one has scipy imported)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "import numpy as np\n"
        "from bodyvib.vehicle.sweep.engines import run_engine\n"
        "from bodyvib.vehicle.sweep.spec import expand\n"
        "from bodyvib.vehicle.road.synthetic import _ChirpZ\n"
        "rows = run_engine('batched', expand({'road': 'C', 'speed': 10, 'duration': 2,"
        " 'body': 'reduced-paper'}))\n"
        "assert rows[0]['error'] is None\n"
        "print('scipy.signal' in sys.modules, 'scipy.fft' in sys.modules)\n"
        "from scipy.signal import CZT\n"
        "rng = np.random.default_rng(3)\n"
        "for n, m, step in ((300, 700, 0.00123), (16384, 30001, 1 / 6000.3), (5, 3, 0.4)):\n"
        "    c = rng.normal(size=n) + 1j * rng.normal(size=n)\n"
        "    w = np.exp(2j * np.pi * step)\n"
        "    mine, ref = _ChirpZ(n, m, w)(c), CZT(n, m=m, w=w, a=1.0)(c)\n"
        "    print(np.array_equal(mine, ref), np.max(np.abs(mine - ref)) / np.max(np.abs(ref)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.split("\n")
    assert lines[0] == "False False", "a sweep task imported scipy.signal or scipy.fft"
    numpy2 = int(np.__version__.split(".")[0]) >= 2
    for line in lines[1:4]:
        same, rel = line.split()
        # the transform's own rounding is ~n eps of its largest output (n <= 5e4 here)
        assert (same == "True") if numpy2 else (float(rel) <= 1e-11), line


def test_profile_of_a_faded_in_road_is_its_height_and_exact_slope():
    """A faded-in random road computes its height and slope together (the inner road's
    height once): beyond the fade-in the inner road's own bits, and over the fade-in a
    slope that is the derivative of the height (central differences of 2 cm)."""
    from bodyvib.vehicle.road.driven import driven_road

    road = driven_road(RunSettings("C", 20.0, 3.0, 1e-3, 4))
    h = 0.02  # m
    x = np.arange(3001) * h
    z, s = road.profile(x)
    assert np.array_equal(z, road.displacement(x))
    inside = (x > road.taper) & (x < road.length - road.taper)
    assert np.array_equal(z[inside], road.road.displacement(x)[inside])
    assert np.array_equal(s[inside], road.road.slope(x)[inside])
    # over the fade-in the central difference errs by h^2 z'''/6: a few per cent of the
    # slope at the shortest wavelength the road holds (0.35 m)
    k = np.arange(1, int(road.taper / h))
    central = (z[k + 1] - z[k - 1]) / (2 * h)
    assert np.max(np.abs(s[k] - central)) < 0.05 * np.max(np.abs(s))
