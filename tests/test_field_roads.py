"""Roads as they come from the field: a scanned cobblestone OpenCRG surface, a profilometer's
text export, damaged OpenCRG files, and the unit check that tells a wrong unit from a joint.

The files are synthetic stand-ins made here (tests/field_roads.py), shaped as real ones are.
"""

import math
import re

import numpy as np
import pytest
from field_roads import (
    PROFILER_DATUM,
    PROFILER_GRADE,
    write_cobblestone_crg,
    write_profilometer_txt,
)

from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.road.measured import MAX_MEDIAN_SLOPE, load_profile, median_slope
from bodyvib.vehicle.road.synthetic import N0, N_BAND, class_psd_n0, random_road

pycrg = pytest.importorskip("pycrg")


@pytest.fixture(scope="module")
def cobbles(tmp_path_factory):
    path = tmp_path_factory.mktemp("field") / "cobbles.crg"
    u, v, z = write_cobblestone_crg(path)
    return str(path), u, v, z


# -- the unit check ---------------------------------------------------------------------


def test_median_slope_of_a_random_road_is_its_structure_function():
    """For an ISO 8608 road the height change over a step b is Gaussian with variance
    ``D(b) = 2 int Gd(n) (1 - cos 2 pi n b) dn`` over the synthesized band; its median modulus
    is 0.6745 sqrt(D). 2000 m hold ~2000 independent 1 m steps: the sample median is within
    ~3 % (1.25 / sqrt(2000)); 8 % is 2.5 of its standard errors."""
    from scipy.integrate import quad

    gd0 = class_psd_n0("A")
    var, _ = quad(
        lambda n: 2 * gd0 * (n / N0) ** -2 * (1 - math.cos(2 * math.pi * n)),
        *N_BAND,
        limit=400,
    )
    x = np.arange(0, 2000.0, 0.05)
    z = random_road("A", 2000.05, seed=5).displacement(x)
    assert median_slope(z, 0.05) == pytest.approx(0.6745 * math.sqrt(var), rel=0.08)
    # the smoothest class in mm read as m: a thousand times steeper, far above the limit
    assert median_slope(1e3 * z, 0.05) > 2 * MAX_MEDIAN_SLOPE


def test_scanned_cobblestones_are_read_and_their_joints_kept(cobbles):
    """The scan's joints are 10-20 mm steps within 1 cm: slopes of 1-2 at every joint,
    which no unit check may take for a unit error; the grid comes back as written
    (single precision: 1e-7 relative of 20 mm)."""
    path, u, v, z = cobbles
    for track in (0.0, -0.3, 0.25):
        road = load_profile(path, track_m=track)
        j = int(np.argmin(np.abs(v - track)))
        centre = int(np.argmin(np.abs(v)))
        expect = z[:, j] - z[0, centre]  # OpenCRG puts the reference line's start at z = 0
        np.testing.assert_allclose(road.elevation, expect, atol=1e-8)
        assert road.spacing == pytest.approx(0.01, rel=1e-12)
        assert np.max(np.abs(np.diff(road.elevation))) / road.spacing > 1.0
        assert median_slope(road.elevation, road.spacing) < 0.1 * MAX_MEDIAN_SLOPE


def test_a_profile_in_mm_read_as_metres_is_still_refused(tmp_path):
    x = np.arange(0, 100.0, 0.05)
    z_mm = 1e3 * random_road("B", 100.05, seed=2).displacement(x)
    path = tmp_path / "mm.csv"
    path.write_text(
        "distance_m,elevation_m\n" + "".join(f"{a:.2f},{b:.4f}\n" for a, b in zip(x, z_mm))
    )
    with pytest.raises(
        BodyvibError,
        match=r"median \d\.\d+ m per m over 1 m steps \(grade removed\), where roads stay "
        r"below 0.5: the units look wrong \(mm read as m\?\)",
    ):
        load_profile(path)
    path.write_text("distance_m,elevation_mm\n" + path.read_text().split("\n", 1)[1])
    assert load_profile(path).length == pytest.approx(99.95)


# -- files as the field writes them ----------------------------------------------------


def test_profilometer_text_export_with_bom_crlf_and_upper_case_units(tmp_path):
    path = tmp_path / "profiler.txt"
    x, z = write_profilometer_txt(path)
    road = load_profile(path)
    assert road.spacing == 0.25 and road.length == pytest.approx(400.0)
    np.testing.assert_allclose(road.elevation, z, atol=5e-6)  # printed to 10 um
    assert road.grade == pytest.approx(PROFILER_GRADE, abs=1e-4)
    assert road.info["format"] == "text" and road.elevation[0] > PROFILER_DATUM - 0.1


@pytest.mark.parametrize(
    "text",
    [
        "distance;elevation\n0,00;1,5\n0,25;2,0\n0,50;1,0\n0,75;0,5\n1,00;0,0\n",
        "\ufeffDistance (M)\tElevation (MM)\r\n0\t1.5\r\n0.25\t2\r\n0.5\t1\r\n0.75\t0.5\r\n1\t0\r\n",
        "DISTANCE_M, ELEVATION_MM\n0,1.5\n0.25,2\n0.5,1\n0.75,0.5\n1,0\n",
        "0 1.5\n0.25 2\n0.5 1\n0.75 0.5\n1 0\n",
    ],
    ids=["semicolon-decimal-comma", "bom-tab-crlf", "upper-case", "no-header"],
)
def test_column_files_in_every_separator(tmp_path, text):
    path = tmp_path / "p.txt"
    path.write_text(text, encoding="utf-8", newline="")
    road = load_profile(path, units="m,mm" if text.startswith(("0", "distance;")) else None)
    np.testing.assert_allclose(road.elevation, [1.5e-3, 2e-3, 1e-3, 0.5e-3, 0.0])
    assert road.spacing == 0.25


def test_erd_with_upper_case_units_crlf_and_bom(tmp_path):
    path = tmp_path / "p.erd"
    z = 1e3 * random_road("C", 60.0, seed=4).displacement(np.arange(200) * 0.25)
    head = "ERDFILEV2.00\r\n1, 200, 1, -1, 1, 0.25, 0.0\r\nXUNITS, M\r\nYUNITS, MM\r\nEND\r\n"
    body = "".join(f"{v:.6f}\r\n" for v in z)
    path.write_bytes(b"\xef\xbb\xbf" + (head + body).encode())
    np.testing.assert_allclose(load_profile(path).elevation, z / 1e3, atol=1e-9)


# -- damaged OpenCRG files -------------------------------------------------------------


def test_truncated_and_corrupt_crg_are_named_with_the_offset(cobbles, tmp_path):
    path = cobbles[0]
    data = open(path, "rb").read()
    start = data.index(b"$$$$")
    start = data.index(b"\n", start) + 1
    cut = tmp_path / "cut.crg"
    cut.write_bytes(data[: start + 5000] + data[start + 5005 :])  # five bytes gone
    # 977 x 101 single-precision heights, 394708 bytes, filled to whole 80-byte records
    assert len(data) - start == 394720
    with pytest.raises(
        BodyvibError,
        match=rf"truncated: its header declares 977 samples of 101 channel\(s\), 394720 bytes "
        rf"of data from byte offset {start}; the file ends at byte offset {start + 394715}, "
        "5 bytes short",
    ):
        load_profile(cut)
    bad = bytearray(data)
    bad[start + 4000 : start + 4004] = b"\x7f\x00\x00\x00"  # a float of 1.7e38
    (tmp_path / "bad.crg").write_bytes(bytes(bad))
    with pytest.raises(
        BodyvibError, match=rf"corrupt: a value of 1.7e\+38 m at byte offset {start + 4000}"
    ):
        load_profile(tmp_path / "bad.crg")


def test_crg_without_its_road_block_is_refused(cobbles, tmp_path):
    data = open(cobbles[0], "rb").read()
    i = data.index(b"$ROAD_CRG")
    j = data.index(b"\n$", i + 1)
    (tmp_path / "noroad.crg").write_bytes(data[:i] + data[j + 1 :])
    with pytest.raises(BodyvibError, match=r"has no \$ROAD_CRG block"):
        load_profile(tmp_path / "noroad.crg")


# -- the tire contact ------------------------------------------------------------------


def _contour(d, a, b, c):
    """A super-ellipse's lower contour above its lowest point, written out again here."""
    d = np.abs(np.asarray(d, dtype=float))
    return b - b * np.power(1 - np.power(np.minimum(d / a, 1.0), c), 1 / c)


def test_one_cam_over_a_step_is_the_closed_form_envelope():
    """A cam resting on a step of height H at s = 0 touches its corner until it is on top:
    its lowest point lies at max(0, H - y(-x)) ahead of the step and at H beyond it. With
    c_e = 2 and a_e = b_e = r0 the cam is a rigid wheel: H - r0 + sqrt(r0^2 - x^2)."""
    from bodyvib.vehicle.road.contact import TandemCam, basic_function

    dx, step = 0.001, 0.02
    x = np.arange(-600, 400) * dx
    z = np.where(x >= 0, step, 0.0)
    for order in (1.8, 2.0):
        tire = TandemCam(radius_m=0.313, footprint_m=0.111, order=order)
        w = basic_function(z, dx, tire)
        expect = np.where(x >= 0, step, np.maximum(0.0, step - _contour(x, 0.313, 0.313, order)))
        np.testing.assert_allclose(w, expect, atol=1e-15)
    wheel = step - 0.313 + np.sqrt(np.clip(0.313**2 - x**2, 0.0, None))
    ahead = (x < 0) & (wheel > 0)
    np.testing.assert_allclose(w[ahead], wheel[ahead], atol=1e-15)  # the rigid wheel
    # it leaves the ground where the wheel's circle meets the corner: x = -sqrt(2 r0 H - H^2)
    first = x[np.argmax(w > 0)]
    assert first == pytest.approx(-math.sqrt(2 * 0.313 * step - step**2), abs=dx)


def test_tandem_is_the_mean_of_two_cams_a_base_apart():
    """Footprint 0.1 m: base 0.8 x 0.05 = 0.04 m, two samples either side at 1 cm, so the
    tandem is the exact mean of the closed form at x -+ 0.02 m; it reaches the step's height
    H at x = +l_s/2, when the rear cam is on top."""
    from bodyvib.vehicle.road.contact import TandemCam, effective_road

    dx, step = 0.01, 0.018
    tire = TandemCam(radius_m=0.3, footprint_m=0.1)
    assert tire.base == pytest.approx(0.04)
    x = np.arange(-100, 100) * dx
    z = np.where(x >= -1e-12, step, 0.0)

    def one(s):
        return np.where(s >= -1e-12, step, np.maximum(0.0, step - _contour(s, 0.3, 0.3, 1.8)))

    w = effective_road(z, dx, tire)
    inside = (x > x[0] + 0.35) & (x < x[-1] - 0.35)
    expect = 0.5 * (one(x - 0.02) + one(x + 0.02))
    np.testing.assert_allclose(w[inside], expect[inside], atol=1e-15)
    assert np.all(w[x >= 0.02 - 1e-9] == step) and np.all(w[x < 0.02 - 1e-9] < step)


def test_tandem_cam_bridges_the_cobble_joints_and_keeps_long_waves(cobbles):
    """On the scan, the 1-2 cm joints vanish under a cam 0.63 m long: the effective road's
    steepest slope falls below 0.5 (point contact: above 1). A class C road at 5 cm, whose
    content lies at wavelengths far above the footprint, passes within 3 % of its r.m.s."""
    from bodyvib.vehicle.road.contact import default_tire, effective_road

    path = cobbles[0]
    point = load_profile(path)
    cam = load_profile(path, contact="tandem-cam")
    assert point.steepest()[0] > 1.0 and cam.steepest()[0] < 0.5
    x = np.arange(0, 200, 0.05)
    z = random_road("C", 210.0, seed=1).displacement(x)
    e = effective_road(z, 0.05, default_tire())
    assert np.std((e - z)[200:-200]) < 0.03 * np.std(z)


def test_a_repeated_profile_is_enveloped_across_its_join():
    """A repeated profile: the cams at its ends rest on the next repetition, exactly as on the
    profile laid end to end (for a period longer and one shorter than the cam)."""
    from bodyvib.vehicle.road.contact import default_tire, effective_road

    tire, rng = default_tire(), np.random.default_rng(0)
    for n in (300, 20):
        z = rng.normal(0.0, 0.003, n)
        z[-1] = z[0]
        k = 40 // n + 3
        laid = np.concatenate([np.tile(z[:-1], k), z])
        i = (k // 2) * (n - 1)
        np.testing.assert_allclose(
            effective_road(z, 0.01, tire, periodic=True),
            effective_road(laid, 0.01, tire)[i : i + n],
            atol=1e-15,
        )


def test_contact_auto_follows_the_footprint(cobbles, tmp_path):
    x, _ = write_profilometer_txt(tmp_path / "p.txt", length=100.0)
    assert load_profile(tmp_path / "p.txt", contact="auto").contact is None  # 0.25 m
    assert load_profile(cobbles[0], contact="auto").contact is not None  # 0.01 m
    with pytest.raises(BodyvibError, match="unknown road contact 'soft'"):
        load_profile(cobbles[0], contact="soft")


# -- short roads and what a run states ---------------------------------------------------


def test_short_road_repeats_faded_in_once_and_joined_smoothly(cobbles):
    """The 9.76 m scan repeated: faded in over the first 5 m only, then the profile again and
    again; at each join height and slope are continuous (the slope's jump across the join is
    no larger than between two samples anywhere)."""
    from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road

    road = driven_road(
        RunSettings(cobbles[0], 10.0, 5.0, 1e-3, road_options=RoadOptions(repeat=True))
    )
    profile = road.road
    L = profile.length
    xs = np.linspace(0.0, L, 3001)
    for k in (1, 2, 5):
        np.testing.assert_allclose(
            road.displacement(xs + k * L), profile.displacement(xs), atol=1e-15
        )
    eps = 1e-9
    for k in (1, 3):
        j = k * L
        assert abs(road.displacement(j - eps) - road.displacement(j + eps)) < 1e-9
        assert abs(road.slope(j - eps) - road.slope(j + eps)) < 1e-6
    d = road.describe()
    assert d["repeats"] and d["tapered_length_m"] is None and d["contact"]["model"] == "tandem-cam"


def test_default_fade_on_a_short_road_is_shortened_with_a_warning(cobbles):
    from bodyvib.vehicle.road.base import RoadWarning
    from bodyvib.vehicle.road.driven import RunSettings, driven_road, road_handling

    with pytest.warns(RoadWarning, match=r"is 9.76 m long: faded in and out over 2.44 m"):
        road = driven_road(RunSettings(cobbles[0], 5.0, 1.9, 1e-3))
    assert road.taper == pytest.approx(2.44)
    assert road_handling(road.describe()) == (
        "faded in and out over 2.44 m, tandem-cam contact (r0 0.313 m, footprint 0.111 m)"
    )


def test_point_contact_on_a_joint_warns_where(tmp_path):
    from bodyvib.vehicle.road.base import RoadWarning
    from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road

    path = tmp_path / "joint.csv"
    x = np.arange(0, 30.0, 0.01)
    z = np.where((x > 12.0) & (x < 12.015), -15.0, 0.0)  # a 15 mm deep joint at 12 m
    with open(path, "w") as f:
        f.write("distance_m,elevation_mm\n" + "".join(f"{a:.2f},{b}\n" for a, b in zip(x, z)))
    with pytest.warns(
        RoadWarning, match=r"its slope reaches 1.5 m per m at 12 m \(a step, a joint or an edge\)"
    ):
        driven_road(RunSettings(path, 10.0, 2.0, 1e-3, road_options=RoadOptions(contact="point")))


# -- bodyvib road on field files --------------------------------------------------------


def golden_car_iri(x, z):
    """ASTM E1926's IRI written out again: the 250 mm moving average, the Golden Car stepped
    from sample to sample by the matrix exponential of the car augmented with the profile
    (linear between samples), started on the mean slope of the first 11 m, and the plain
    mean of the rectified slope at the n - 1 step ends."""
    from scipy.linalg import expm

    dx, speed = x[1] - x[0], 80 / 3.6
    k = max(1, int(round(0.25 / dx)))
    zr = np.convolve(z, np.ones(k) / k, mode="valid")
    m = np.zeros((6, 6))  # states: z_s, z_s', z_u, z_u', z_r, dz_r/dt
    m[0, 1] = m[2, 3] = m[4, 5] = 1.0
    m[1, :4] = [-63.3, -6.0, 63.3, 6.0]
    m[3, :5] = [63.3 / 0.15, 6.0 / 0.15, -(63.3 + 653.0) / 0.15, -6.0 / 0.15, 653.0 / 0.15]
    h = dx / speed
    step = expm(m * h)
    j = min(zr.size - 1, int(round(11.0 / dx)))
    v0 = (zr[j] - zr[0]) / (j * dx) * speed
    s = np.array([zr[0], v0, zr[0], v0])
    total = 0.0
    for i in range(zr.size - 1):
        s = (step @ np.r_[s, zr[i], (zr[i + 1] - zr[i]) / h])[:4]
        total += abs(s[1] - s[3]) / speed
    return 1000 * total / (zr.size - 1)


def test_iri_of_field_files_is_the_independent_golden_cars(cobbles, tmp_path):
    """Both implementations are exact for a profile linear between samples, so they agree to
    rounding (1e-9; the old half weights at the ends differ by 5e-4 on the 9.76 m scan)."""
    from bodyvib.vehicle.road.iri import international_roughness_index

    txt = tmp_path / "p.txt"
    write_profilometer_txt(txt)
    for path in (txt, cobbles[0]):
        road = load_profile(path)
        x = road.distance
        got = international_roughness_index(x, road.elevation).iri_m_per_km
        assert got == pytest.approx(golden_car_iri(x, road.elevation), rel=1e-9)


def test_road_command_on_field_files(cobbles, tmp_path, capsys):
    from bodyvib.cli.main import main

    txt = tmp_path / "p.txt"
    write_profilometer_txt(txt)
    assert main(["road", str(txt)]) == 0
    out = capsys.readouterr().out
    assert "spacing 0.25 m (1601 samples)" in out
    assert "grade +2.000 %" in out and "no moving average at a 0.25 m spacing" in out
    assert "moving average at a" in out and "250 mm" not in out
    assert main(["road", cobbles[0]]) == 0
    out = capsys.readouterr().out
    assert "spacing 0.01 m (977 samples)" in out
    assert "held: the band 0.409-2.83 cycle/m does not reach n0" in out
    assert "25-sample 250 mm moving average" in out and "warning" not in out


def test_road_command_warns_when_the_line_does_not_fit(tmp_path, capsys):
    from bodyvib.cli.main import main

    x = np.arange(0, 200, 0.05)
    path = tmp_path / "sine.csv"
    path.write_text("".join(f"{a:.2f},{5 * np.sin(2 * np.pi * a / 5):.6f}\n" for a in x))
    assert main(["road", str(path), "--units", "mm"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"warning: the ISO 8608 line fits this profile badly \(misfit \d+", out)
    assert main(["road", str(path), "--units", "m,m"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "or give --units" in err and "--road-units" not in err


def test_sweep_grid_on_a_road_file_takes_cosims_body_and_car(cobbles):
    """``sweep --grid road=FILE speed=10,20``: no body, no car, as ``cosim`` needs none.
    (The 9.76 m scan is faded over 2.44 m at each end, with a warning.)"""
    from bodyvib.vehicle.fmus import FMUS
    from bodyvib.vehicle.road.base import RoadWarning
    from bodyvib.vehicle.sweep.spec import expand, grid_spec

    with pytest.warns(RoadWarning, match="faded in and out over 2.44 m"):
        cases = expand(grid_spec([f"road={cobbles[0]}", "speed=10,20"], duration=0.4))
    assert [c.speed for c in cases] == [10.0, 20.0]
    assert {c.body_model for c in cases} == {FMUS["HumanBody3DOF"][1]} == {"reduced-paper"}
    assert {c.car for c in cases} == {"quarter-car"}


# -- the stand-ins through the commands ----------------------------------------------------


@pytest.mark.integration
def test_field_files_run_through_cosim_check_and_sweep(cobbles, tmp_path, capsys):
    """No --road-* option: the scan drives through the tandem cam (its fade shortened to fit
    it), the 0.25 m profile point by point with the 40 Hz band stated; the header and the JSON
    say so. (Short runs: the figures themselves are checked elsewhere.)"""
    import json

    from bodyvib.cli.main import main

    txt = tmp_path / "p.txt"
    write_profilometer_txt(txt, length=120.0)
    js = tmp_path / "cob.json"
    assert (
        main(
            [
                "cosim",
                "--road",
                cobbles[0],
                "--speed",
                "10",
                "--duration",
                "0.9",
                "--quiet",
                "--json",
                str(js),
            ]
        )
        == 0
    )
    out, err = capsys.readouterr()
    assert "faded in and out over 2.44 m, tandem-cam contact (r0 0.313 m" in out
    assert "warning: road 'cobbles.crg at 0 m' is 9.76 m long" in err
    road = json.load(open(js))["road"]
    assert road["contact"]["model"] == "tandem-cam" and road["taper_m"] == pytest.approx(2.44)
    assert main(["check", "--road", str(txt), "--duration", "2", "--quiet"]) == 0
    out, err = capsys.readouterr()
    assert "point contact" in out and "carries nothing above 40 Hz" in err
    csv = tmp_path / "sweep.csv"
    assert (
        main(
            [
                "sweep",
                "--grid",
                f"road={txt}",
                "speed=10,20",
                "--duration",
                "2",
                "--csv",
                str(csv),
                "--quiet",
            ]
        )
        == 0
    )
    assert len(open(csv).read().strip().splitlines()) == 3
    err = capsys.readouterr().err  # checked, then run: each warning printed once
    assert err.count("nothing above 20 Hz") == 1 == err.count("nothing above 40 Hz")


def test_road_command_describes_both_wheel_paths(cobbles, tmp_path, capsys):
    """``--track 0.3 -0.3``: one summary per wheel path, each that of the grid's column
    at that offset (as the scan was written), in the text, the JSON and one plot."""
    import json

    from scipy.signal import detrend

    from bodyvib.cli.main import main

    path, u, v, z = cobbles
    js, png = tmp_path / "t.json", tmp_path / "t.png"
    assert (
        main(["road", path, "--track", "0.3", "-0.3", "--json", str(js), "--plot", str(png)]) == 0
    )
    out = capsys.readouterr().out
    assert out.count("road cobbles.crg at ") == 2 and "\n\nroad cobbles.crg at -0.3 m" in out
    tracks = json.load(open(js))["tracks"]
    for doc, offset in zip(tracks, (0.3, -0.3)):
        column = z[:, int(np.argmin(np.abs(v - offset)))]
        assert doc["name"] == f"cobbles.crg at {offset:g} m"
        assert doc["elevation_m"]["rms"] == pytest.approx(np.std(detrend(column)), rel=1e-5)
    assert png.stat().st_size > 10000
    assert main(["road", "C", "--track", "0.3"]) == 2
    assert "--track applies to OpenCRG (.crg) surfaces" in capsys.readouterr().err


def test_contact_is_a_road_option_of_specs_and_commands(cobbles):
    from bodyvib.vehicle.road.base import RoadWarning
    from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road
    from bodyvib.vehicle.sweep.spec import expand, grid_spec

    with pytest.warns(RoadWarning, match="its slope reaches 2.08 m per m at 3.26 m"):
        (case,) = expand(
            grid_spec(
                [f"road={cobbles[0]}", "speed=10"], 0.4, 1e-3, {"contact": "point", "taper_m": 2}
            )
        )
    assert dict(case.road_options) == {"contact": "point", "taper_m": 2.0}
    with pytest.raises(BodyvibError, match="road option 'contact' must be one of auto, tandem-cam"):
        expand(grid_spec([f"road={cobbles[0]}", "speed=10"], 0.4, 1e-3, {"contact": "soft"}))
    with pytest.raises(BodyvibError, match="and 'contact' apply to road files; road 'C'"):
        driven_road(RunSettings("C", 10.0, 1.0, road_options=RoadOptions(contact="point")))
