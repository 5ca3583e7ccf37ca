"""Real measured roads that no one here made, with their sources and licences beside them
in tests/data/real/: a photogrammetric scan of a Belgian-block track as an OpenCRG file
(1 cm grid, 10 m by 3.4 m) and a 544 m longitudinal profile every 0.25 m in a bare
two-column text file with absolute elevations. Both go through ``bodyvib road``, ``cosim``,
``check`` and ``sweep`` with no option beyond the road, and their IRI is computed again here
by a Golden Car integrated as an ODE.
"""

import os
import re
import shutil

import numpy as np
import pytest

from bodyvib.vehicle.road.iri import international_roughness_index
from bodyvib.vehicle.road.measured import load_profile

pycrg = pytest.importorskip("pycrg")

REAL = os.path.join(os.path.dirname(__file__), "data", "real")
SCAN = os.path.join(REAL, "belgian_block.crg")
PROFILE = os.path.join(REAL, "profile_1.txt")


def ode_golden_car_iri(x, z):
    """IRI by the Golden Car (ASTM E1926's constants) integrated with an adaptive Runge-Kutta
    method (DOP853, rtol 1e-8) over the profile taken as linear between its samples, after
    the 250 mm moving average, started on the mean slope of the first 11 m; the rectified
    suspension-travel rate is averaged over the ends of the n - 1 steps, as the standard
    reports it."""
    from scipy.integrate import solve_ivp

    kt, ks, cs, mu = 653.0, 63.3, 6.0, 0.15  # per unit sprung mass
    v = 80 / 3.6
    dx = x[1] - x[0]
    k = max(1, int(round(0.25 / dx)))
    zr = np.convolve(z, np.ones(k) / k, mode="valid")
    t = np.arange(zr.size) * dx / v

    def rhs(tt, s):
        road = np.interp(tt, t, zr)
        fs = ks * (s[2] - s[0]) + cs * (s[3] - s[1])
        return [s[1], fs, s[3], (-fs + kt * (road - s[2])) / mu]

    j = min(zr.size - 1, int(round(11.0 / dx)))
    v0 = (zr[j] - zr[0]) / (j * dx) * v
    sol = solve_ivp(
        rhs,
        (0.0, t[-1]),
        [zr[0], v0, zr[0], v0],
        method="DOP853",
        t_eval=t,
        rtol=1e-8,
        atol=1e-11,
        max_step=dx / v,  # one step a sample at most: the input bends at every sample
    )
    assert sol.success
    rate = np.abs(sol.y[1] - sol.y[3])[1:] / v
    return 1000 * rate.mean()


@pytest.mark.parametrize(
    "path",
    [
        pytest.param(SCAN, id="belgian-block"),
        # 2177 samples take the ODE solver 6 s
        pytest.param(PROFILE, id="profile-0.25m", marks=pytest.mark.integration),
    ],
)
def test_iri_of_real_roads_is_an_ode_golden_cars(path):
    """To 0.1 % (the done-when); both solve the same linear ODE, the ODE to 1e-8, so they
    agree far closer (below 1e-7 on both files)."""
    road = load_profile(path)
    got = international_roughness_index(road.distance, road.elevation).iri_m_per_km
    ref = ode_golden_car_iri(road.distance, road.elevation)
    assert got == pytest.approx(ref, rel=1e-3)
    assert got == pytest.approx(ref, rel=1e-7)


def test_road_command_on_real_roads(capsys):
    from bodyvib.cli.main import main

    assert main(["road", SCAN]) == 0
    out = capsys.readouterr().out
    assert "length 10 m, spacing 0.01 m (1001 samples)" in out
    assert "25-sample 250 mm moving average" in out and "-> class F" in out
    assert main(["road", PROFILE]) == 0
    out = capsys.readouterr().out
    assert "length 544 m, spacing 0.25 m (2177 samples)" in out
    assert "(mean elevation 582.398 m)" in out  # absolute elevations, read as metres
    assert "no moving average at a 0.25 m spacing" in out


def test_road_guide_prints_what_the_command_prints(capsys):
    """docs/guide/roads.md, Two real roads: the ``bodyvib road`` output it shows, line for line."""
    from bodyvib.cli.main import main

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with open(os.path.join(root, "docs", "guide", "roads.md"), encoding="utf-8") as f:
        guide = f.read().split("## Two real roads", 1)[1].split("\n## ", 1)[0]
    for path in (SCAN, PROFILE):
        assert main(["road", path]) == 0
        lines = capsys.readouterr().out.strip().splitlines()
        assert len(lines) == 6 and all(line in guide.splitlines() for line in lines), lines


def test_the_real_scan_cut_short_is_refused_with_the_offset(tmp_path, capsys):
    """The scan with five bytes of its binary payload missing (as the file is in the OpenCRG
    repository's current tree) is refused in one line that names the offset."""
    from bodyvib.cli.main import main

    data = open(SCAN, "rb").read()
    cut = tmp_path / "belgian_block.crg"
    cut.write_bytes(data[:20000] + data[20005:])
    assert main(["road", str(cut)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "is truncated: its header declares 1001 samples of 342 channel(s)" in err
    assert "from byte offset 9880" in err and "5 bytes short" in err


@pytest.mark.integration
def test_real_roads_run_through_cosim_check_and_sweep(tmp_path, capsys):
    """Nothing but the road: the 10 m scan and the 544 m profile, both shorter than the 30 s
    run at 20 m/s, are driven repeated (with a warning); the scan through the tandem cam, the
    profile point by point with its 40 Hz band stated."""
    from bodyvib.cli.main import main

    scan = str(tmp_path / "belgian_block.crg")
    shutil.copy(SCAN, scan)
    assert main(["cosim", "--road", scan, "--linear"]) == 0
    out, err = capsys.readouterr()
    assert "tandem-cam contact (r0 0.313 m, footprint 0.111 m), repeated every 10 m" in out
    assert "is driven repeated" in err
    # the figures docs/guide/roads.md quotes (Two real roads, 20 m/s, tandem cam): the
    # linear car's, and the shipped car's, whose wheel leaves the road on the blocks
    assert re.search(r"Wk-weighted r\.m\.s\. \[m/s2\] +9\.9109\n", out), out
    assert main(["cosim", "--road", scan]) == 0
    out, err = capsys.readouterr()
    assert re.search(r"Wk-weighted r\.m\.s\. \[m/s2\] +7\.0806\n", out), out
    assert re.search(r"lift-offs \(air, longest\) +298 ", out), out
    assert main(["check", "--road", PROFILE]) in (0, 1)  # the verdict is the model's
    out, err = capsys.readouterr()
    assert "road profile_1.txt, faded in over 5 m, point contact, repeated every 544 m" in out
    assert "verdict:" in out and "carries nothing above 40 Hz" in err
    csv = tmp_path / "sweep.csv"
    assert main(["sweep", "--grid", f"road={scan},{PROFILE}", "--csv", str(csv)]) == 0
    assert len(open(csv).read().strip().splitlines()) == 3


# -- Road.fmu of a road file driven repeated ---------------------------------------------


def test_road_table_of_a_repeated_file_fades_in_once():
    """The table Road.fmu carries for ``--road-repeat``: the fade-in, then one period that
    repeats; over five periods it is the road a run drives, not the fade again at every
    period: beyond the fade to rounding (rows on the scan's samples reproduce its cubics),
    within it to the Hermite table's error on the faded cubics (measured 2.0e-7 m)."""
    from bodyvib.vehicle.fmus import fmu_road, fmu_road_length
    from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road
    from bodyvib.vehicle.road.synthetic import road_table

    road = fmu_road(SCAN, repeat=True)
    length = fmu_road_length(road, 601.0)
    assert length == pytest.approx(20.0)  # the 5 m fade within the first 10 m period, then one
    table = road_table(road, length)
    assert table.periodic and table.position[table.loop] == pytest.approx(10.0)
    run = driven_road(RunSettings(SCAN, 20.0, 2.5, 1e-3, road_options=RoadOptions(repeat=True)))
    x = np.linspace(0.0, 50.0, 20001)
    z, _ = table.evaluate(x)
    err = np.abs(z[:, 0] - run.displacement(x))
    assert err[x <= 5.0].max() < 1e-6 and err[x > 5.0].max() < 1e-12
    later = x > 10.0  # every later pass is the profile itself, at full height
    assert np.abs(z[later, 0]).max() > 0.04
    np.testing.assert_array_equal(z[(x > 10.0) & (x < 12.0), 0] != 0.0, True)


@pytest.mark.integration
@pytest.mark.parametrize("native", [False, True], ids=["pythonfmu", "native"])
def test_road_fmu_of_a_repeated_scan_fades_in_once(native, tmp_path):
    """Road.fmu built with ``--road-repeat`` from the 10 m scan, run in fmpy for 2.5 s at
    20 m/s (five passes): its height is the road the library drives on every pass, to the
    table's interpolation in the fade (1e-6 m) and to rounding after it."""
    from fmpy import simulate_fmu

    from bodyvib.vehicle.fmus import build_project_fmu
    from bodyvib.vehicle.road.driven import RoadOptions, RunSettings, driven_road

    fmu = build_project_fmu(
        "Road", tmp_path, SCAN, road={"repeat": True}, native=native, platforms=("linux64",)
    )
    res = simulate_fmu(str(fmu), stop_time=2.5, output_interval=1e-3)
    run = driven_road(RunSettings(SCAN, 20.0, 2.5, 1e-3, road_options=RoadOptions(repeat=True)))
    x = 20.0 * res["time"]
    err = np.abs(res["road_displacement"] - run.displacement(x))
    assert err[x <= 5.0].max() < 1e-6 and err[x > 5.0].max() < 1e-12
    assert np.abs(res["road_displacement"][res["time"] > 1.0]).max() > 0.04
