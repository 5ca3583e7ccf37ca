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
