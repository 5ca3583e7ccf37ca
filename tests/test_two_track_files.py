"""Road files on two tracks: a full car's left and right wheels each on their own profile.

* OpenCRG: the left wheels run on the surface at ``track_m + tf/2``, the right wheels at
  ``track_m - tf/2``. The reference is the surface as pycrg evaluates it at those points,
  read here straight from the file (not through the wheel-road code). The real scanned
  Belgian block (tests/data/real) drives the full car with no option.
* Profiles (CSV and text) with ``elevation_left`` and ``elevation_right`` beside
  ``distance``: each track its column, in the units the header names; a one-track
  profile drives both tracks alike; a column missing, columns of different lengths or a
  NaN are refused with one line each.
"""

import os
import shutil

import numpy as np
import pytest

from bodyvib import BodyvibError
from bodyvib.vehicle.quarter_car import load_car, track_width, wheel_offsets, wheel_sides
from bodyvib.vehicle.road import (
    RoadOptions,
    RunSettings,
    driven_road,
    load_profile,
    roads_input,
    wheel_roads,
)

REAL = os.path.join(os.path.dirname(__file__), "data", "real")
SCAN = os.path.join(REAL, "belgian_block.crg")
SPEED, STEP = 10.0, 1e-3  # every sample lands on the files' 1 cm grid
EXACT = dict(taper_m=0.0, contact="point")  # the profiles as they are, no fade, no tire


def wheel_columns(path, duration, **options):
    """The full car's four wheel inputs on a road file, and the times, from ``tracks.py``."""
    car = load_car("full-car")
    settings = RunSettings(path, SPEED, duration, STEP, road_options=RoadOptions(**options))
    roads = wheel_roads(settings, driven_road(settings), wheel_sides(car), track_width(car))
    t = np.arange(int(round(duration / STEP))) * STEP
    z, _ = roads_input(roads, SPEED, t, wheel_offsets(car))
    return t, z


# -- OpenCRG ------------------------------------------------------------------------------


@pytest.mark.parametrize("track", [0.0, 0.4])
def test_crg_wheels_run_on_the_surface_at_half_the_track_either_side(track):
    """Front left at track + tf/2, front right at track - tf/2, the rears 2.8 m later on
    the same lines: the surface's heights as pycrg gives them at (u0 + x, v), each line's
    grade removed (the straight line from its first to its last height, which every
    profile drops: the car starts level), to 1e-12 m."""
    pycrg = pytest.importorskip("pycrg")
    t, z = wheel_columns(SCAN, 0.9, track_m=track, **EXACT)
    half = load_car("full-car").parameters["tf"] / 2
    x = SPEED * t
    with pycrg.DataSet.open(SCAN) as ds:
        u = np.asarray(ds.grid().u, dtype=float)
        cp = ds.create_contact_point()

        def surface(xs, v):
            """Height at distance xs along the line v, less the line's grade."""
            ends = np.asarray(cp.uv_to_z_many(u[[0, -1]], np.full(2, v)), dtype=float)
            heights = np.asarray(cp.uv_to_z_many(u[0] + xs, np.full_like(xs, v)), dtype=float)
            return heights - ends[0] - (ends[1] - ends[0]) * xs / (u[-1] - u[0])

        left, right = surface(x, track + half), surface(x, track - half)
        late = x >= 2.8
        rear_left = surface(x[late] - 2.8, track + half)
        rear_right = surface(x[late] - 2.8, track - half)
    np.testing.assert_allclose(z[:, 0], left, rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[:, 1], right, rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[late, 2], rear_left, rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[late, 3], rear_right, rtol=0, atol=1e-12)
    assert np.sqrt(np.mean((left - right) ** 2)) > 1e-3  # the blocks differ across the lane


def test_crg_track_off_the_surface_names_the_wheels_and_the_fix():
    pytest.importorskip("pycrg")
    with pytest.raises(BodyvibError, match=r"left wheels run at 2\.25 m .*keeps both"):
        wheel_columns(SCAN, 0.5, track_m=1.5, **EXACT)


@pytest.mark.integration
def test_belgian_block_drives_the_full_car_with_no_option(tmp_path, capsys):
    """``bodyvib cosim --car full-car --road belgian_block.crg``: nothing but the car and the
    road; the run's JSON names the two tracks it drove, at plus and minus tf/2."""
    import json

    pytest.importorskip("pycrg")
    from bodyvib.cli.main import main

    scan = str(tmp_path / "belgian_block.crg")
    shutil.copy(SCAN, scan)
    out = tmp_path / "run.json"
    argv = ["cosim", "--car", "full-car", "--road", scan, "--duration", "2", "--json", str(out)]
    assert main(argv) == 0
    capsys.readouterr()
    doc = json.loads(out.read_text())
    assert [track["track_m"] for track in doc["road"]["tracks"]] == [0.75, -0.75]
    assert doc["bodies"]["HumanBody3DOF"]["seat_aw_y"] > 0


# -- profiles with a column per track ------------------------------------------------------

LENGTH_M = 12.0


def track_heights(x):
    """Two tracks' heights in mm: a 3 m and a 1.3 m wave, the right track's shifted."""
    left = 8.0 * np.sin(2 * np.pi * x / 3.0) + 2.0 * np.sin(2 * np.pi * x / 1.3)
    right = 8.0 * np.sin(2 * np.pi * (x - 0.7) / 3.0) - 3.0 * np.cos(2 * np.pi * x / 1.3)
    return left, right


def write_two_track(path, header, sep):
    x = np.round(np.arange(0.0, LENGTH_M + 1e-9, 0.01), 2)
    left, right = track_heights(x)
    rows = [sep.join(f"{v:.12g}" for v in row) for row in zip(x, left, right)]
    path.write_text("\n".join([header, *rows]) + "\n")
    return str(path)


TWO_TRACK_FILES = {
    "csv": ("road.csv", "distance_m,elevation_left_mm,elevation_right_mm", ","),
    "text": ("road.txt", "distance [m]  elevation_left [mm]  elevation_right [mm]", "  "),
}


def without_grade(x, heights_mm):
    """A track as every profile is driven: in m, its first-to-last straight line removed."""
    z = heights_mm / 1000.0
    return z - z[0] - (z[-1] - z[0]) * x / LENGTH_M


@pytest.mark.parametrize("kind", list(TWO_TRACK_FILES))
def test_two_track_profile_gives_each_track_its_column(tmp_path, kind):
    """The left wheels drive elevation_left, the right wheels elevation_right (mm read as
    the header says), the rears 2.8 m later: the file's numbers at the wheels' distances
    (all on the 1 cm grid), to 1e-12 m."""
    name, header, sep = TWO_TRACK_FILES[kind]
    path = write_two_track(tmp_path / name, header, sep)
    t, z = wheel_columns(path, 0.9, **EXACT)
    x = SPEED * t
    grid = np.arange(0.0, LENGTH_M + 1e-9, 0.01)
    left, right = (without_grade(grid, h) for h in track_heights(grid))
    k = np.rint(x / 0.01).astype(int)
    np.testing.assert_allclose(z[:, 0], left[k], rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[:, 1], right[k], rtol=0, atol=1e-12)
    late = k >= 280
    np.testing.assert_allclose(z[late, 2], left[k[late] - 280], rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[late, 3], right[k[late] - 280], rtol=0, atol=1e-12)
    # a car without sides (a quarter or half car) drives the left track
    settings = RunSettings(path, SPEED, 0.9, STEP, road_options=RoadOptions(**EXACT))
    np.testing.assert_array_equal(driven_road(settings).displacement(x), z[:, 0])
    assert load_profile(path, side=-1).name == f"{name}, right track"


def test_a_two_channel_erd_file_is_the_left_and_right_tracks(tmp_path):
    """An ERD file of two channels (a profiler's left and right lines, in that order, as
    ProVAL writes them): the wheels drive their channel, as a CSV file's columns; a channel
    named in the call drives both sides."""
    x = np.round(np.arange(0.0, LENGTH_M + 1e-9, 0.01), 2)
    left, right = track_heights(x)
    head = f"ERDFILEV2.00\n2, {x.size}, 1, -1, 1, 0.01, 0.0\nXUNITS, m\nYUNITS, mm, mm\nEND\n"
    path = tmp_path / "road.erd"
    path.write_text(head + "".join(f"{a:.12g} {b:.12g}\n" for a, b in zip(left, right)))
    t, z = wheel_columns(str(path), 0.9, **EXACT)
    k = np.rint(SPEED * t / 0.01).astype(int)
    np.testing.assert_allclose(z[:, 0], without_grade(x, left)[k], rtol=0, atol=1e-12)
    np.testing.assert_allclose(z[:, 1], without_grade(x, right)[k], rtol=0, atol=1e-12)
    assert load_profile(str(path), side=-1).name == "road.erd, right track"
    both = load_profile(str(path), side=-1, channel=1)
    np.testing.assert_array_equal(both.elevation, load_profile(str(path)).elevation)


def test_one_track_profile_drives_both_tracks_alike(tmp_path):
    path = tmp_path / "one.csv"
    x = np.round(np.arange(0.0, LENGTH_M + 1e-9, 0.01), 2)
    rows = "\n".join(f"{xi:.2f},{h:.12g}" for xi, h in zip(x, track_heights(x)[0]))
    path.write_text("distance_m,elevation_mm\n" + rows + "\n")
    _, z = wheel_columns(str(path), 0.9)
    np.testing.assert_array_equal(z[:, 0], z[:, 1])
    np.testing.assert_array_equal(z[:, 2], z[:, 3])
    assert np.ptp(z[:, 0]) > 1e-3


def _edit(text, kind):
    """Break a two-track file: the header's right column renamed, the last rows' right
    heights dropped, a right height made NaN, or the right column in another unit."""
    lines = text.splitlines()
    if kind == "missing":
        lines[0] = lines[0].replace("elevation_right", "elevation")
    elif kind == "shorter":
        lines[-3:] = [ln.rsplit(",", 1)[0] for ln in lines[-3:]]
    elif kind == "nan":
        lines[400] = lines[400].rsplit(",", 1)[0] + ",nan"
    elif kind == "units":
        lines[0] = lines[0].replace("elevation_right_mm", "elevation_right_m")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    "kind, message",
    [
        (
            "missing",
            r"road 'bad.csv': the header names elevation_left but no elevation_right column; "
            r"a two-track profile needs both",
        ),
        (
            "shorter",
            r"road 'bad.csv': elevation_right_mm has 1198 values and elevation_left_mm 1201; "
            r"both tracks need a value at every distance",
        ),
        (
            "nan",
            r"road 'bad.csv': elevation_right_mm is not a number at line 401 \(distance 3\.99\); "
            r"fill the gap",
        ),
        ("units", r"elevation_left_mm and elevation_right_m name different units"),
    ],
)
def test_a_broken_two_track_file_is_refused_in_one_line(tmp_path, kind, message):
    """Whichever track is asked for: the file is checked whole, both columns alike."""
    good = write_two_track(tmp_path / "good.csv", TWO_TRACK_FILES["csv"][1], ",")
    bad = tmp_path / "bad.csv"
    bad.write_text(_edit(open(good).read(), kind))
    for side in (1, -1, 0):
        with pytest.raises(BodyvibError, match=message) as err:
            load_profile(str(bad), side=side)
        assert "\n" not in str(err.value)


def test_a_broken_two_track_text_file_is_refused_as_a_csv_is(tmp_path):
    name, header, sep = TWO_TRACK_FILES["text"]
    good = write_two_track(tmp_path / name, header, sep)
    lines = open(good).read().splitlines()
    lines[-1] = lines[-1].rsplit(sep, 1)[0]  # its last right height dropped
    (tmp_path / name).write_text("\n".join(lines) + "\n")
    with pytest.raises(BodyvibError, match=r"elevation_right\[mm\] has 1200 values and"):
        load_profile(good, side=-1)
