"""Measured roads: OpenCRG, CSV and ERD readers, the profile interpolant, refusals, and
the same profile driven from each format (cosim, sweep, Road.fmu)."""

import os
import re
import shutil
import tempfile

import numpy as np
import pytest

from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.road.base import RoadWarning
from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road
from bodyvib.vehicle.road.measured import load_profile
from bodyvib.vehicle.road.profile import ProfileRoad, envelope
from bodyvib.vehicle.road.synthetic import random_road, road_input

pycrg = pytest.importorskip("pycrg")

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "opencrg")
DX = 0.05  # m, profile spacing
LENGTH = 250.0  # m


@pytest.fixture(scope="module")
def folder():
    d = tempfile.mkdtemp(prefix="bodyvib-roads-")
    yield d
    shutil.rmtree(d, ignore_errors=True)


def profile_heights():
    """A class C profile on a 1 % grade, 3 mm above the datum: what the files hold."""
    x = np.arange(0.0, LENGTH + DX / 2, DX)
    return x, random_road("C", 300.0, seed=3).displacement(x) + 0.01 * x + 0.003


def write_csv(path, x, z, header="distance_m,elevation_mm", scale=1e3):
    with open(path, "w") as f:
        f.write(header + "\n")
        for a, b in zip(x, z):
            f.write(f"{float(a)!r},{float(b * scale)!r}\n")


def write_erd(path, z, dx=DX, units=("m", "mm"), nsamp=None, fmt="%.9f"):
    with open(path, "w") as f:
        f.write("ERDFILEV2.00\n")
        f.write(f"1, {nsamp or z.size}, 1, -1, 1, {dx!r}, 0.0\n")
        f.write("TITLE, test profile\nSHORTNAME, left\n")
        if units:
            f.write(f"XUNITS, {units[0]}\nYUNITS, {units[1]}\n")
        f.write("END\n")
        for v in z * 1e3:
            f.write(fmt % v + "\n")


@pytest.fixture(scope="module")
def files(folder):
    x, z = profile_heights()
    paths = {k: os.path.join(folder, f"profile.{k}") for k in ("crg", "csv", "erd")}
    # the grade as the reference line's slope, the rest in the grid (which OpenCRG keeps in
    # single precision: 6e-8 of the grid's 3 cm, 2e-9 m)
    grid = z - 0.01 * x
    pycrg.write(
        paths["crg"],
        np.column_stack([grid, grid, grid]),
        DX,
        [-1.0, 0.0, 1.0],
        slope=0.01,
        fmt="KDBI",
    )
    write_csv(paths["csv"], x, z)
    write_erd(paths["erd"], z)
    return paths


# -- readers ---------------------------------------------------------------------------


def test_three_formats_read_the_same_profile(files):
    """Heights relative to the first sample equal the ones written: exactly for CSV (repr), to
    the 1e-9 mm printed in the ERD file, to single precision of the grid in the CRG file."""
    x, z = profile_heights()
    tol = {"crg": 5e-9, "csv": 1e-15, "erd": 1e-12}
    for kind, path in files.items():
        p = load_profile(path)
        assert p.spacing == pytest.approx(DX, rel=1e-12) and p.length == pytest.approx(LENGTH)
        np.testing.assert_allclose(
            p.elevation - p.elevation[0], z - z[0], rtol=0, atol=tol[kind], err_msg=kind
        )
        assert p.grade == pytest.approx((z[-1] - z[0]) / LENGTH, abs=1e-12)
        assert isinstance(p, ProfileRoad) and p.describe()["format"] in ("opencrg", "csv", "erd")


def test_crg_track_is_the_lateral_interpolation(folder):
    """OpenCRG interpolates linearly across the long sections: at v = 0.25 m between
    sections at 0 and 1 m the height is 3/4 of one plus 1/4 of the other."""
    x, z = profile_heights()
    z = z - 0.01 * x  # grid values of 3 cm: single precision 2e-9 m
    zl = 0.5 * z
    path = os.path.join(folder, "track.crg")
    pycrg.write(path, np.column_stack([z, z, zl]), DX, [-1.0, 0.0, 1.0], fmt="KDBI")
    p = load_profile(path, track_m=0.25)
    want = 0.75 * z + 0.25 * zl
    np.testing.assert_allclose(p.elevation - p.elevation[0], want - want[0], rtol=0, atol=5e-9)
    with pytest.raises(BodyvibError, match=r"off the road .* -1 to 1 m"):
        load_profile(path, track_m=1.5)


def _crg_columns(path):
    """The data section of an LRFI sample, parsed here (*missing* -> NaN): rows x channels."""
    text = open(path).read().split("$$$$$$$$10")[1].splitlines()[1:]
    rows = []
    for ln in text:
        if not ln.strip():
            continue
        fields = [ln[i : i + 10] for i in range(0, len(ln.rstrip()), 10)]
        rows.append([np.nan if "*" in f else float(f) for f in fields])
    return np.array(rows)


def test_opencrg_samples_along_the_reference_line():
    """The project's own samples: on the reference line (v = 0) the straight road's height is its
    v = 0 column; the sloped road's adds the reference line's elevation, the running sum of the
    segment slopes times the 1 m increment."""
    straight = _crg_columns(os.path.join(DATA, "handmade_straight.crg"))
    p = load_profile(os.path.join(DATA, "handmade_straight.crg"))
    assert p.spacing == 1.0 and p.length == 22.0
    np.testing.assert_allclose(
        p.elevation - p.elevation[0], straight[:, 3] - straight[0, 3], atol=1e-6
    )  # the file's 7 digits, single precision
    sloped = _crg_columns(os.path.join(DATA, "handmade_sloped.crg"))
    slope = np.nan_to_num(sloped[:, 0])  # the first row's slope is unused
    ref_z = np.cumsum(slope) * 1.0
    p = load_profile(os.path.join(DATA, "handmade_sloped.crg"))
    want = ref_z + sloped[:, 4]  # the v = 0 long section
    np.testing.assert_allclose(p.elevation - p.elevation[0], want - want[0], atol=1e-6)
    p = load_profile(os.path.join(DATA, "handmade_sloped.crg"), track_m=1.25)
    want = ref_z + sloped[:, 6]
    np.testing.assert_allclose(p.elevation - p.elevation[0], want - want[0], atol=1e-6)


# -- the interpolant -------------------------------------------------------------------


def test_interpolant_error_is_bounded_and_velocity_is_its_derivative():
    """A sine of 0.5 m wavelength sampled every 5 cm. The cubic Hermite with exact slopes errs
    by at most dx^4/384 max|z''''|; the central-difference slopes err by dx^2/6 max|z'''| and
    enter through basis functions of at most 4/27 dx each. Between samples the slope is the
    derivative of the displacement (central differences of 1e-6 m)."""
    A, lam = 0.01, 0.5
    k = 2 * np.pi / lam
    x = np.arange(0, 20 + DX / 2, DX)
    p = ProfileRoad(A * np.sin(k * x), DX, name="sine")
    xf = np.linspace(0.2, 19.8, 20001) + 0.0123  # between samples (C1 there, C2 between)
    exact = A * np.sin(k * xf)  # no grade: the sine ends where it starts
    bound = DX**4 / 384 * A * k**4 + 2 * (4 / 27) * DX * DX**2 / 6 * A * k**3
    err = np.max(np.abs(p.displacement(xf) - exact))
    assert err <= bound, (err, bound)
    assert err > 0.1 * bound  # the bound is tight enough to mean something
    h = 1e-6
    fd = (p.displacement(xf + h) - p.displacement(xf - h)) / (2 * h)
    between = np.abs(xf / DX - np.round(xf / DX)) * DX > 2 * h  # not straddling a sample
    assert np.max(np.abs(fd - p.slope(xf))[between]) <= 1e-6 * A * k
    np.testing.assert_allclose(p.displacement(x), p.table.value[:, 0], atol=1e-18)


def test_tire_envelope_is_the_250mm_moving_average():
    """A moving average of k samples dx apart passes a sampled sine of wavelength lam with gain
    sin(pi k dx / lam) / (k sin(pi dx / lam)) (k = 5 samples at 5 cm: 250 mm; the continuous
    average's sin(pi L / lam) / (pi L / lam) as dx -> 0)."""
    lam, L = 1.0, 0.25
    x = np.arange(0, 40 + DX / 2, DX)
    z = np.sin(2 * np.pi * x / lam)
    e = envelope(z, DX)
    assert e.size == z.size - 4
    gain = np.sin(np.pi * L / lam) / (5 * np.sin(np.pi * DX / lam))
    assert np.max(np.abs(e)) == pytest.approx(gain, rel=1e-12)  # 20 samples a period: a peak
    p = ProfileRoad(z, DX, enveloped=True)
    assert p.length == pytest.approx(40 - 4 * DX)


# -- start at rest and repeat ------------------------------------------------------------


def test_measured_road_starts_level_and_repeats_on_request(files):
    road = driven_road(RunSettings(files["csv"], 20.0, 10.0, 1e-3))
    assert float(road.displacement(0.0)) == 0.0 and float(road.slope(0.0)) == 0.0
    with pytest.warns(
        RoadWarning,
        match=r"250 m long and the 30 s run at 20 m/s drives 600 m: it is driven repeated "
        r"\(faded in once; duration=12\.5 drives it once\)",
    ):
        auto = driven_road(RunSettings(files["csv"], 20.0, 30.0, 1e-3))
    rep = driven_road(
        RunSettings(files["csv"], 20.0, 30.0, 1e-3, road_options=RoadOptions(repeat=True))
    )
    xs = np.linspace(0, LENGTH, 5001)
    for x in (xs, xs + LENGTH, xs + 2 * LENGTH):  # repeated unasked as when asked
        np.testing.assert_array_equal(auto.displacement(x), rep.displacement(x))
    # faded in once: every later pass is the profile itself
    profile = rep.road
    np.testing.assert_allclose(rep.displacement(xs + LENGTH), profile.displacement(xs), atol=1e-15)
    np.testing.assert_allclose(rep.slope(xs + 2 * LENGTH), profile.slope(xs), atol=1e-12)


# -- refusals -------------------------------------------------------------------------


def _csv(folder, name, text):
    path = os.path.join(folder, name)
    with open(path, "w") as f:
        f.write(text)
    return path


ROWS = "".join(f"{i * 0.05:.2f},{np.sin(i / 7.0):.4f}\n" for i in range(200))


@pytest.mark.parametrize(
    "name, text, units, match",
    [
        (
            "decreasing.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.05,2\n0.2,1\n0.3,0\n",
            None,
            r"distance goes back at sample 3 .*sort the profile",
        ),
        (
            "repeated.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.1,2\n0.2,1\n0.3,0\n",
            None,
            r"distance repeats at sample 3 .*drop repeated rows",
        ),
        (
            "nan.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.2,nan\n0.3,1\n0.4,0\n",
            None,
            r"sample 3 \(distance 0.2\) is not a number; fill the gap",
        ),
        (
            "empty-field.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.2,\n0.3,1\n0.4,0\n",
            None,
            r"sample 3 .* is not a number",
        ),
        (
            "gap.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.2,2\n0.9,1\n1.0,0\n1.1,0\n",
            None,
            r"a gap of 0.7 between distances 0.2 and 0.9 .*fill the gap or cut",
        ),
        (
            "jitter.csv",
            "distance_m,elevation_mm\n0,0\n0.1,1\n0.22,2\n0.3,1\n0.4,0\n",
            None,
            r"not uniformly spaced .*resample",
        ),
        (
            "nounits.csv",
            "distance,elevation\n" + ROWS,
            None,
            r"names no units; name them \(distance_m,elevation_mm\) or give units=m,mm",
        ),
        (
            "badunit.csv",
            "distance_m,elevation_furlong\n" + ROWS,
            None,
            r"unknown elevation unit 'furlong'",
        ),
        ("wrongunit.csv", "distance_m,elevation_m\n" + ROWS, None, r"units look wrong"),
        # a headerless file is read in metres: mm columns are caught by the unit check
        ("noheader.csv", ROWS, None, r"units look wrong \(mm read as m\?\)"),
        ("clash.csv", "distance_m,elevation_mm\n" + ROWS, "m,m", r"disagrees with the header"),
        (
            "truncated.csv",
            "distance_m,elevation_mm\n" + ROWS + "10.00",
            None,
            r"line 202 has 1 field\(s\), not 2; the file looks truncated",
        ),
        (
            "words.csv",
            "distance_m,elevation_mm\n" + ROWS + "10.00,abc\n",
            None,
            r"is not two numbers",
        ),
        ("road.xyz", "x", None, r"unknown kind of file '.xyz'"),
    ],
)
def test_bad_csv_is_refused_naming_the_fix(folder, name, text, units, match):
    with pytest.raises(BodyvibError, match=match):
        load_profile(_csv(folder, name, text), units=units)


def test_csv_units_from_the_option_and_header_forms(folder):
    a = load_profile(_csv(folder, "opt.csv", "distance,elevation\n" + ROWS), units="m,mm")
    b = load_profile(_csv(folder, "brackets.csv", "distance [m], elevation (mm)\n" + ROWS))
    c = load_profile(_csv(folder, "feet.csv", "distance_ft,elevation_in\n" + ROWS))
    np.testing.assert_array_equal(a.elevation, b.elevation)
    assert c.spacing == pytest.approx(0.05 * 0.3048)
    np.testing.assert_allclose(c.elevation, a.elevation * 25.4, rtol=1e-12)
    with pytest.raises(BodyvibError, match="must name two units"):
        load_profile(os.path.join(folder, "opt.csv"), units="mm")


def test_bad_erd_is_refused(folder):
    _, z = profile_heights()
    z = z[:400]
    path = os.path.join(folder, "bad.erd")
    write_erd(path, z, nsamp=500)
    with pytest.raises(
        BodyvibError, match=r"truncated: the header promises 500 samples .* holds 400"
    ):
        load_profile(path)
    write_erd(path, z, units=None)
    with pytest.raises(BodyvibError, match=r"names no units \(XUNITS and YUNITS\)"):
        load_profile(path)
    assert load_profile(path, units="m,mm").elevation.size == 400
    with open(path, "w") as f:
        f.write("ERDFILEV2.00\n1, 4, 1, -1, 1, 0.1, 0.0\nXUNITS, m\nYUNITS, mm\n0\n1\n2\n3\n")
    with pytest.raises(BodyvibError, match="no END line"):
        load_profile(path)
    with open(path, "w") as f:
        f.write("distance,elevation\n")
    with pytest.raises(BodyvibError, match="first line must be ERDFILEV2.00"):
        load_profile(path)


def test_erd_fixed_column_header_as_profilers_write_it(folder):
    """The layout line with NCHAN, NSAMP, three fields and DELTA, keys in 8 columns
    (UNITSNAM per channel), three channels; the second one read."""
    path = os.path.join(folder, "ltpp.erd")
    prof = np.sin(np.arange(500)[:, None] / np.array([5.0, 6.0, 7.0]))
    with open(path, "w") as f:
        f.write("ERDFILEV2.00\n      3,    500,     -1,      1,      5,       0.0250,     -1,\n")
        f.write("TITLE   a test section: Run 1\nUNITSNAMmm      mm      mm\nXUNITS  m\n")
        f.write("DATE    01/Dec/2026\n\nEND\n")
        for row in prof:
            f.write(" ".join(f"{float(v):.6f}" for v in row) + "\n")
    p = load_profile(path)
    assert p.spacing == pytest.approx(0.025) and p.elevation.size == 500
    np.testing.assert_allclose(p.elevation, np.round(prof[:, 0], 6) * 1e-3, atol=1e-15)
    np.testing.assert_allclose(
        load_profile(path, channel=2).elevation, np.round(prof[:, 1], 6) * 1e-3, atol=1e-15
    )


def test_erd_keyword_header_and_channels(folder):
    """The header as keyword lines (NCHAN, NSAMP, DELTA), two channels, feet and inches."""
    path = os.path.join(folder, "two.erd")
    left = np.sin(np.arange(300) / 9.0)
    right = np.cos(np.arange(300) / 9.0)
    with open(path, "w") as f:
        f.write("ERDFILEV2.00\nNCHAN, 2\nNSAMP, 300\nDELTA, 0.1\nXUNITS, ft\nYUNITS, in, in\nEND\n")
        for a, b in zip(left, right):
            f.write(f"{float(a)!r}, {float(b)!r}\n")
    assert load_profile(path).spacing == pytest.approx(0.1 * 0.3048)
    np.testing.assert_allclose(load_profile(path).elevation, left * 0.0254)
    np.testing.assert_allclose(load_profile(path, channel=2).elevation, right * 0.0254)


def test_bad_crg_is_refused(folder, files):
    x, z = profile_heights()
    path = os.path.join(folder, "text.crg")
    pycrg.write(path, np.column_stack([z, z, z])[:400], DX, [-1.0, 0.0, 1.0], fmt="LDFI")
    text = open(path).read()
    with open(path, "w") as f:
        f.write(text[: len(text) * 2 // 3])
    with pytest.raises(
        BodyvibError,
        match=r"truncated: its header declares 400 samples of 3 channel\(s\), its data from "
        r"byte offset \d+ hold \d+ numbers of 1200",
    ):
        load_profile(path)
    with open(path, "w") as f:
        f.write("$CT\nnot a road\n$\n")
    with pytest.raises(BodyvibError, match="not a readable OpenCRG file"):
        load_profile(path)
    with pytest.raises(BodyvibError, match="OpenCRG file is in metres"):
        load_profile(files["crg"], units="m,mm")
    with pytest.raises(BodyvibError, match="track_m applies to OpenCRG files only"):
        load_profile(files["csv"], track_m=0.5)


@pytest.mark.parametrize(
    "key,value",
    [
        ("REFERENCE_LINE_INCREMENT", "NaN"),
        ("REFERENCE_LINE_START_U", "NaN"),
        ("REFERENCE_LINE_END_U", "nan"),
        ("REFERENCE_LINE_INCREMENT", "inf"),
    ],
)
def test_crg_header_number_that_is_not_finite_is_refused(folder, capsys, key, value):
    """``REFERENCE_LINE_INCREMENT = NaN`` ended ``bodyvib road`` in a traceback
    (cannot convert float NaN to integer): the header's extent is checked finite."""
    from bodyvib.cli.main import main

    text = open(os.path.join(DATA, "handmade_straight.crg")).read()
    text, n = re.subn(rf"(?m)^{key}\s*=.*$", f"{key} = {value}", text)
    assert n == 1
    path = os.path.join(folder, f"nan-{key}-{value}.crg")
    with open(path, "w") as f:
        f.write(text)
    assert main(["road", path]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert f"{key} = {value.lower()}" in err and "not a finite number" in err


def test_spacing_too_coarse_for_the_speed_and_step_is_stated(files):
    """The 1 m OpenCRG sample at 20 m/s: wavelengths down to 2 m pass at 10 Hz, far below the
    80 Hz of ISO 2631-1's range; a 5 cm profile reaches 200 Hz. A 10 ms step resolves 50 Hz
    only, so it asks less. The run goes on; a warning names the frequency."""
    import warnings

    from bodyvib.vehicle.road.base import RoadWarning

    with pytest.warns(
        RoadWarning,
        match=r"at 20 m/s its 1 m spacing carries nothing above 10 Hz .* up to 80 Hz.*"
        r"\(a profile every 0.125 m would carry it\)",
    ):
        driven_road(RunSettings(os.path.join(DATA, "handmade_straight.crg"), 20.0, 1.0, 1e-3))
    with pytest.warns(
        RoadWarning, match=r"at 5 m/s its 0.05 m spacing carries nothing above 50 Hz"
    ):
        driven_road(RunSettings(files["crg"], 5.0, 1.0, 1e-3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        driven_road(RunSettings(files["crg"], 20.0, 1.0, 1e-3))
        driven_road(RunSettings(files["crg"], 5.0, 1.0, 1e-2))  # 50 Hz: what a 10 ms step resolves


def test_missing_file_and_options_on_a_synthetic_road(folder):
    with pytest.raises(BodyvibError, match="road file .*nothere.crg' does not exist"):
        driven_road(RunSettings(os.path.join(folder, "nothere.crg"), 20.0, 1.0))
    with pytest.raises(BodyvibError, match="apply to road files; road 'C' is synthetic"):
        driven_road(RunSettings("C", 20.0, 1.0, road_options=RoadOptions(repeat=True)))


def test_cli_refuses_a_bad_road_in_one_line(folder, capsys):
    from bodyvib.cli.main import main

    path = _csv(folder, "cli-nounits.csv", "distance,elevation\n" + ROWS)
    assert main(["cosim", "--road", path, "--duration", "1", "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "names no units" in err and err.startswith("bodyvib cosim")
    assert err.endswith("or give --road-units m,mm")  # the flag, and only where it is one


# -- driven: cosim, sweep, Road.fmu ------------------------------------------------------


@pytest.fixture(scope="module")
def fmus(folder):
    from bodyvib.vehicle.fmus import build_fmus

    built = build_fmus(os.path.join(folder, "fmus"), names=["HumanBody3DOF", "QuarterCar"])
    return {k: str(v) for k, v in built.items()}


@pytest.mark.integration
def test_same_head_figures_from_crg_csv_and_erd(files, fmus):
    """10 s at 20 m/s in cosim. The three files hold the same samples (to 1e-12 m in the ERD
    file) and go through the same interpolant, so the figures agree to 1e-9 relative; the
    coupling error against the monolithic reference stays at its synthetic-road level."""
    from bodyvib.vehicle.study import run_study

    figs = {}
    for kind, path in files.items():
        st = run_study(
            {"body": fmus["HumanBody3DOF"]},
            fmus["QuarterCar"],
            RunSettings(road=path, speed=20.0, duration=10.0),
        )
        b = st.bodies["body"]
        figs[kind] = b.figures
        assert b.coupling_nrmse < 6e-4, (kind, b.coupling_nrmse)
        assert st.road["format"] in ("opencrg", "csv", "erd") and st.road["taper_m"] == 5.0
    for kind in ("csv", "erd"):
        for name in ("weighted_rms", "vdv", "peak"):
            a, b = getattr(figs[kind], name), getattr(figs["crg"], name)
            assert a == pytest.approx(b, rel=1e-9), (kind, name, a, b)
    assert 0.1 < figs["crg"].weighted_rms < 3.0  # a class C road at 20 m/s: about 0.5 m/s^2


@pytest.mark.integration
def test_cosim_command_drives_a_crg_road(files, folder):
    import json

    from bodyvib.cli.main import main

    out = os.path.join(folder, "crg.json")
    assert main(["cosim", "--road", files["crg"], "--duration", "2", "--quiet", "--json", out]) == 0
    data = json.load(open(out))
    assert data["road"]["format"] == "opencrg" and data["road"]["track_m"] == 0.0


def test_sweep_takes_road_files(files):
    """The batched engine on the CRG and CSV files: the same figures; the spectral engine,
    which needs a stationary ISO 8608 road, refuses them."""
    from bodyvib.vehicle.sweep.engines import check_engine, run_batched
    from bodyvib.vehicle.sweep.spec import expand, spec_hash

    spec = {
        "road": [files["crg"], files["csv"]],
        "speed": 20,
        "duration": 2,
        "body": "reduced-paper",
    }
    cases = expand(spec)
    assert [c.road for c in cases] == [os.path.abspath(files["crg"]), os.path.abspath(files["csv"])]
    assert cases[0].case_key != cases[1].case_key
    rows, _ = run_batched(cases)
    assert rows[0]["error"] is None
    assert rows[0]["head_weighted_rms"] == pytest.approx(rows[1]["head_weighted_rms"], rel=1e-6)
    assert rows[0]["head_weighted_rms"] > 0.05
    with pytest.raises(BodyvibError, match="spectral engine needs stationary ISO 8608 roads"):
        check_engine("spectral", cases)
    opts = expand(dict(spec, road_options={"repeat": True, "taper_m": 2}))
    assert opts[0].road_settings() == RoadOptions(taper_m=2.0, repeat=True)
    assert opts[0].case_key != cases[0].case_key and spec_hash(spec) != spec_hash(
        dict(spec, road_options={"repeat": True})
    )
    with pytest.raises(BodyvibError, match="unknown road option"):
        expand(dict(spec, road_options={"trak": 1}))


def table_bounds(profile, taper, h):
    """Bounds of Road.fmu's re-tabulation error (cubic Hermite, exact slopes, rows h apart,
    h = the profile's spacing over a whole number) of a faded-in profile. Every row interval
    lies within one cubic segment of the profile's interpolant, which the table reproduces
    exactly; over the fade, w z is not cubic: Hermite's h^4/384 M4 on the height and
    sqrt(3)/216 h^3 M4 on the slope, with M4 <= sum_j C(4, j) |w^(j)| |z^(4-j)| (z^(4) = 0 on
    the segments, |w^(j)| <= (pi/d)^j / 2), plus rounding."""
    from math import comb

    t = profile.table
    dx = profile.spacing
    z0, z1 = t.value[:-1, 0], t.value[1:, 0]
    m0, m1 = t.slope[:-1, 0] * dx, t.slope[1:, 0] * dx
    a3 = 2 * (z0 - z1) + m0 + m1
    a2 = -3 * z0 + 3 * z1 - 2 * m0 - m1
    z3 = 6 * a3 / dx**3  # third derivative on each segment
    z2 = np.maximum(np.abs(2 * a2), np.abs(6 * a3 + 2 * a2)) / dx**2
    xs = np.linspace(0, profile.length, 200001)
    zm = [
        np.max(np.abs(profile.displacement(xs))),
        1.01 * np.max(np.abs(profile.slope(xs))),
        np.max(z2),
        np.max(np.abs(z3)),
        0.0,
    ]
    wm = [1.0] + [(np.pi / taper) ** j / 2 for j in range(1, 5)]
    m4 = sum(comb(4, j) * wm[j] * zm[4 - j] for j in range(1, 5))
    return h**4 / 384 * m4 + 1e-15, np.sqrt(3) / 216 * h**3 * m4 + 1e-13


@pytest.mark.integration
def test_road_fmu_of_a_file_is_the_driven_road(files, folder):
    """Road.fmu built from the CSV profile, run in fmpy at 17.3 m/s from t = 0: its outputs are
    the library's driven road (faded in), sample for sample, within the bounds of its table's
    interpolation error (table_bounds; rows every 5/3 cm, a third of the profile's spacing:
    measured 3.4e-9 m and 1.3e-5 m/s in the fade, half the bounds, and 1e-15 m, 2e-12 m/s
    beyond it, where the table reproduces the profile's cubics)."""
    from fmpy import simulate_fmu

    from bodyvib.vehicle.fmus import build_project_fmu
    from bodyvib.vehicle.road.synthetic import table_spacing

    speed = 17.3
    fmu = build_project_fmu("Road", os.path.join(folder, "roadfmu"), files["csv"])
    res = simulate_fmu(
        str(fmu), stop_time=10.0, output_interval=1e-3, start_values={"speed": speed}
    )
    road = driven_road(RunSettings(files["csv"], speed, 10.0, 1e-3))
    z, v = road_input(road, speed, res["time"])
    assert res["road_displacement"][0] == 0.0 and res["road_velocity"][0] == 0.0
    h = table_spacing(road)
    assert h == pytest.approx(DX / 3, rel=1e-12)
    bz, bs = table_bounds(road.road, road.taper, h)
    dz = np.abs(res["road_displacement"] - z)
    dv = np.abs(res["road_velocity"] - v)
    assert dz.max() <= bz and dv.max() <= speed * bs, (dz.max(), bz, dv.max(), speed * bs)
    beyond = speed * res["time"] > road.taper
    assert dz[beyond].max() <= 1e-14 and dv[beyond].max() <= 1e-11  # the cubics, to rounding


@pytest.mark.integration
def test_sweep_engines_drive_a_road_file_as_cosim_does(files, folder, capsys):
    """A sweep case on the ERD file: its road input is bodyvib cosim's, sample for sample from
    t = 0 (the CSV's 10 digits); the cosim engine gives cosim's head acceleration, the batched
    engine the same within the coupling error."""
    from helpers import assert_csv_is_the_cosim_engine

    from bodyvib.cli.main import main
    from bodyvib.vehicle.reference import nrmse
    from bodyvib.vehicle.sweep.engines import case_road_input, run_batched
    from bodyvib.vehicle.sweep.spec import expand, grid_spec

    csv = os.path.join(folder, "erd-run.csv")
    assert (
        main(
            [
                "cosim",
                "--road",
                files["erd"],
                "--road-taper",
                "3",
                "--duration",
                "2",
                "--csv",
                csv,
                "--quiet",
            ]
        )
        == 0
    )
    capsys.readouterr()
    spec = grid_spec(
        [f"road={files['erd']}", "speed=20", "body=reduced-paper"],
        duration=2.0,
        road_options={"taper_m": 3.0},
    )
    (case,) = expand(spec)
    z, v = case_road_input(case)
    assert z[0] == 0.0 and v[0] == 0.0
    _, a = assert_csv_is_the_cosim_engine(csv, case)
    ba, ba_hist = run_batched([case], record=True)
    assert nrmse(a, ba_hist[0]["head_acceleration"]) < 5e-4
    assert (
        main(
            [
                "sweep",
                str(os.path.join(folder, "x.json")),
                "--road-taper",
                "3",
                "--out",
                os.path.join(folder, "x.parquet"),
            ]
        )
        == 2
    )
    assert "--road-* options go with --grid" in capsys.readouterr().err


def test_build_refuses_a_length_for_a_road_file(files, folder, capsys):
    from bodyvib.cli.main import main

    dest = os.path.join(folder, "dist-refused")
    assert (
        main(
            [
                "build",
                "--dest",
                dest,
                "--fmus",
                "Road",
                "--road",
                files["crg"],
                "--road-length",
                "100",
            ]
        )
        == 2
    )
    assert "tabulates a road file over its own length" in capsys.readouterr().err
    assert main(["build", "--dest", dest, "--fmus", "Road", "--road", "C", "--road-repeat"]) == 2
    assert "apply to road files; road 'C' is synthetic" in capsys.readouterr().err
    assert not os.path.exists(os.path.join(dest, "Road.fmu"))


@pytest.mark.integration
def test_guide_worked_example(folder):
    """docs/guide/roads.md, Worked example: examples/write_crg_road.py, then bodyvib cosim on
    it at a 0.875 m track for 10 s prints the figures the guide shows (to their printed
    digits)."""
    import json
    import sys

    from bodyvib.cli.main import main

    sys.path.insert(0, os.path.join(os.path.dirname(DATA), "..", "..", "examples"))
    try:
        from write_crg_road import write
    finally:
        sys.path.pop(0)
    crg = write(os.path.join(folder, "road.crg"))
    out = os.path.join(folder, "example.json")
    assert (
        main(
            [
                "cosim",
                "--road",
                crg,
                "--road-track",
                "0.875",
                "--duration",
                "10",
                "--quiet",
                "--json",
                out,
            ]
        )
        == 0
    )
    (body,) = json.load(open(out))["bodies"].values()
    guide = open(os.path.join(os.path.dirname(DATA), "..", "..", "docs", "guide", "roads.md"))
    example = guide.read().split("## Worked example", 1)[1]
    printed = {
        k: float(re.search(pat, example).group(1))
        for k, pat in (
            ("weighted_rms", r"Wk-weighted r\.m\.s\. \[m/s2\]\s+([\d.]+)"),
            ("vdv", r"VDV \[m/s\^1\.75\]\s+([\d.]+)"),
            ("peak", r"weighted peak \[m/s2\]\s+([\d.]+)"),
        )
    }
    for k, v in printed.items():
        assert body[k] == pytest.approx(v, abs=5e-5), (k, body[k], v)
    assert body["coupling_nrmse"] < 5e-4


def test_build_help_names_every_road_file_format(capsys):
    """``bodyvib build --road`` lists the extensions the reader takes, all of them."""
    from bodyvib.cli.main import main
    from bodyvib.vehicle.road.measured import PROFILE_EXTENSIONS

    with pytest.raises(SystemExit):
        main(["build", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a road file (" + ", ".join(PROFILE_EXTENSIONS) + ")" in text
    assert ".txt" in PROFILE_EXTENSIONS
