"""The bump library: shapes against their geometry, slopes as derivatives, refusals, a study.

Heights are checked against what defines each shape independently of its formula (the
round top's circle through its ends and top, the trapezoid's and the cosines' areas),
slopes against central differences of the heights, and a slow traverse against quasi-static
physics: far below the car's bounce mode the seat follows the road.
"""

import math

import numpy as np
import pytest
from helpers import run_cli

from bodyvib.models import load_model
from bodyvib.runtime.discretize import Discretization, input_rates
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import load_car, seated_system
from bodyvib.vehicle.reference import reference_run
from bodyvib.vehicle.road.bumps import SHAPES, bump_library, parse_bump
from bodyvib.vehicle.road.driven import RunSettings, driven_road, road_label
from bodyvib.vehicle.road.synthetic import road_input
from bodyvib.vehicle.sweep.engines import case_road_input, run_batched
from bodyvib.vehicle.sweep.spec import expand, grid_spec
from bodyvib.vehicle.sweep.table import FIGURE_UNITS


def _grid(bump, n=200001):
    return np.linspace(bump.start, bump.end, n)


def test_round_top_is_the_circle_through_its_ends_and_top():
    """The circumscribed circle of (0, 0), (l/2, h), (l, 0), found by solving for its centre
    (not the shape's radius formula): every point of the profile lies on it."""
    b = parse_bump("hump:h=0.075,l=3.7,at=0")
    h, l = 0.075, 3.7
    # centre (l/2, c): (l/2)^2 + c^2 = (h - c)^2  ->  c = (h^2 - l^2/4) / (2 h)
    c = (h * h - l * l / 4) / (2 * h)
    radius = h - c
    x = _grid(b)
    z = b.displacement(x)
    np.testing.assert_allclose(np.hypot(x - l / 2, z - c), radius, rtol=1e-12)
    # the ends: sqrt(R^2 - u^2) - (R - h) cancels to a few ulp of R (22.9 m): 1e-13 m
    assert z[0] == pytest.approx(0, abs=1e-13) and z[-1] == pytest.approx(0, abs=1e-13)
    assert z.max() == pytest.approx(h, rel=1e-12)
    # the edge slope of an arc of height h on chord l: tan = (l/2) / |c|
    assert b.slope(0.0) == pytest.approx((l / 2) / -c, rel=1e-12)


@pytest.mark.parametrize(
    "spec, area",
    [
        ("table:h=0.075,l=6,ramp=0.975,at=0", 0.075 * (6 - 0.975)),  # trapezoid
        ("sine:h=0.075,l=3.7,at=0", 0.075 * 3.7 / 2),  # mean of (1 - cos) / 2 is 1/2
        ("halfsine:h=0.075,l=3.7,at=0", 2 * 0.075 * 3.7 / math.pi),
        ("pothole:d=0.05,l=0.6,ramp=0.05,at=0", -0.05 * (0.6 - 0.05)),
    ],
)
def test_shape_areas_and_extremes(spec, area):
    """The profile's area (trapezoid rule on 2e5 intervals: error below 1e-9 relative
    for these shapes, whose second derivative is bounded or zero) and its extreme value."""
    b = parse_bump(spec)
    x = _grid(b)
    z = b.displacement(x)
    assert np.trapezoid(z, x) == pytest.approx(area, rel=1e-8)
    assert np.max(np.abs(z)) == pytest.approx(abs(b.height), rel=1e-12)
    assert b.displacement(b.start - 1e-9) == 0 and b.displacement(b.end + 1e-9) == 0


@pytest.mark.parametrize("shape", SHAPES)
def test_slope_is_the_exact_derivative(shape):
    """Central differences of the height, step 1e-6 m, away from the corners (the
    truncation error is h^2 |z'''| / 6 < 1e-9 here, rounding 1e-16 / 1e-6 = 1e-10):
    agreement to 1e-6 of the largest slope."""
    b = parse_bump(f"{shape}:at=0")
    x = np.linspace(b.start, b.end, 4001)[1:-1]
    if b.ramp:  # skip the ramps' ends
        x = x[(np.abs(x - b.ramp) > 1e-3) & (np.abs(x - (b.end - b.ramp)) > 1e-3)]
    d = 1e-6
    fd = (b.displacement(x + d) - b.displacement(x - d)) / (2 * d)
    s = b.slope(x)
    np.testing.assert_allclose(s, fd, rtol=0, atol=1e-6 * np.max(np.abs(s)))


def test_defaults_name_their_sources():
    """Every default dimension of every shape names where it comes from (or says chosen)."""
    lib = bump_library()["shapes"]
    assert tuple(lib) == SHAPES
    for shape, entry in lib.items():
        assert set(entry["sources"]) == set(entry["defaults"]), shape
        assert all(text.strip() for text in entry["sources"].values())
    assert lib["hump"]["defaults"]["l"] == 3.7 and "TRL Report 377" in lib["hump"]["sources"]["l"]


def test_slow_traverse_is_quasi_static():
    """A 20 m long sine hump at 1 m/s (0.05 Hz, 1/25 of the car's 1.2 Hz bounce mode):
    the seat (sprung mass) and the head follow the road within the quasi-static error
    ~ (f/f_n)^2 = 1.7e-3 of the height (measured 1.8e-3 and 1.9e-3); asserted to 0.5 %."""
    v, h = 1.0, 0.075
    road = driven_road(RunSettings(f"sine:h={h},l=20,at=10", v, 35.0))
    lm = linear_model(seated_system(load_car(), load_model("reduced-paper")))
    step = 1e-2
    t = np.arange(0, 35.0, step)
    z, zv = road_input(road, v, t)
    u = np.zeros((t.size, len(lm.inputs)))
    u[:, 0], u[:, 1] = z, zv
    x = Discretization(lm).run(u, input_rates(lm, u), step)
    y = x @ lm.C.T + u @ lm.D.T
    for out in ("sprung.x", "body.head.x"):
        err = np.max(np.abs(y[:, lm.output_index(out)] - z))
        assert err < 0.005 * h, out


@pytest.mark.parametrize(
    "spec, match",
    [
        ("hump:h=-0.075", "h=-0.075 must be a positive number of metres"),
        ("hump:l=0", "l=0 must be a positive number"),
        ("pothole:d=-0.05", "a pothole's depth d is positive"),
        ("hump:w=2", "bump 'hump' has no key 'w'; its keys are h, l, at"),
        ("hump:h", "bump 'hump': key 'h' needs a value in m, e.g. hump:h=0.075"),
        ("hump:h=0.1,h=0.2", "bump 'hump' gives h twice"),
        ("table:ramp=4", "two ramps of 4 m do not fit in l=6 m"),
        ("hump:h=3,l=4", "more than a half circle"),
        ("hump:at=100", "ends 103.7 m down the road, but the road is 20 m long"),
        ("hump:at=2", "inside the road's 5 m fade-in"),
        ("humps:h=0.1", "unknown road 'humps:h=0.1'"),
    ],
)
def test_bad_bumps_are_refused_in_one_line(spec, match):
    with pytest.raises(BodyvibError, match=match) as e:
        driven_road(RunSettings(spec, 5.0, 4.0))
    assert "\n" not in str(e.value)


def test_grid_items_and_labels():
    spec = grid_spec(["road=hump:h=0.075,l=3.7,hump:h=0.1,l=3.7,table", "speed=2,4"])
    assert spec["road"] == ["hump:h=0.075,l=3.7", "hump:h=0.1,l=3.7", "table"]
    assert road_label(" Hump:l=3.7 ") == "hump:h=0.075,l=3.7,at=10"


@pytest.mark.integration
def test_cli_refuses_a_bump_longer_than_the_road_in_one_line():
    r = run_cli("cosim", "--road", "hump:h=0.075,l=3.7", "--speed", "2", "--duration", "5")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "ends 13.7 m down the road" in r.stderr


def _bump_rows():
    spec = grid_spec(
        ["road=sine:h=0.05,l=3.7,sine:h=0.1,l=3.7", "speed=3,6", "body=reduced-paper"],
        duration=8.0,
    )
    cases = expand({**spec, "linear": True})  # the linear car: figures scale with the height
    rows, _ = run_batched(cases)
    return cases, rows


def test_bump_sweep_rows_carry_force_peaks_that_scale_with_the_height():
    """A small bump study (2 heights x 2 speeds) of the linear car: the models are linear
    and a sine hump's profile is proportional to its height (a round top's is not: its
    radius changes), so
    every figure of the 10 cm hump is twice the 5 cm one's (to 1e-9: rounding only; VDV
    and peaks are homogeneous of degree 1); the neck-force peak
    is the largest |F| of the monolithic reference's neck force history (to 1e-9, another
    code path over the same exact step) and, the head hanging on the neck alone, m1 times
    the largest |a_head| of that history."""
    cases, rows = _bump_rows()
    assert all(r["error"] is None for r in rows)
    by = {(c.road, c.speed): r for c, r in zip(cases, rows)}
    for v in (3.0, 6.0):
        lo, hi = by[("sine:h=0.05,l=3.7,at=10", v)], by[("sine:h=0.1,l=3.7,at=10", v)]
        for key in ("head_peak", "head_vdv", "neck_force_peak", "lumbar_force_peak"):
            assert hi[key] == pytest.approx(2 * lo[key], rel=1e-9), key
    body = load_model("reduced-paper")
    m1 = body.mass_values()["m1"]
    for c, r in zip(cases, rows):
        z, zv = case_road_input(c)
        ref = reference_run(load_car(linear=True), body, z, zv, c.step)  # the sweep's
        neck = np.max(np.abs(ref["neck_force"]))
        assert r["neck_force_peak"] == pytest.approx(neck, rel=1e-9)
        assert r["neck_force_peak"] == pytest.approx(
            m1 * np.max(np.abs(ref["head_acceleration"])), rel=1e-9
        )
        assert r["lumbar_force_peak"] == pytest.approx(
            np.max(np.abs(ref["lumbar_force"])), rel=1e-9
        )
    # faster over the same hump: harder on the neck (3 -> 6 m/s)
    assert (
        by[("sine:h=0.1,l=3.7,at=10", 6.0)]["neck_force_peak"]
        > by[("sine:h=0.1,l=3.7,at=10", 3.0)]["neck_force_peak"]
    )
    assert FIGURE_UNITS["neck_force_peak"] == FIGURE_UNITS["lumbar_force_peak"] == "N"


@pytest.mark.integration
def test_bump_sweep_from_the_command_line_with_its_plot(tmp_path):
    r = run_cli(
        "sweep",
        "--grid",
        "road=hump:h=0.075,l=3.7,table",
        "speed=3,6",
        "body=reduced-paper",
        "--duration",
        "8",
        "--out",
        "t.parquet",
        "--plot",
        "p.png",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    import pyarrow.parquet as pq

    t = pq.read_table(tmp_path / "t.parquet")
    assert t.schema.field("neck_force_peak").metadata[b"unit"] == b"N"
    df = t.to_pandas()
    assert set(df["road"]) == {"hump:h=0.075,l=3.7,at=10", "table:h=0.075,l=6,ramp=0.975,at=10"}
    assert (df["neck_force_peak"] > 0).all() and (df["lumbar_force_peak"] > 0).all()
    assert (tmp_path / "p.png").stat().st_size > 10000


def test_road_fmu_tabulates_the_bump_and_refuses_one_in_its_fade_in():
    """Road.fmu's road is the run's: the same bump heights, and the same refusals."""
    from bodyvib.vehicle.fmus import fmu_road

    tab = fmu_road("hump:h=0.075,l=3.7", length=40.0)
    run = driven_road(RunSettings("hump:h=0.075,l=3.7", 20.0, 2.0))
    x = np.linspace(0, 40, 4001)
    np.testing.assert_array_equal(tab.displacement(x), run.displacement(x))
    with pytest.raises(BodyvibError, match="inside the road's 5 m fade-in"):
        fmu_road("hump:at=2", length=40.0)
    with pytest.raises(BodyvibError, match="ends 53.7 m down the road, but the road is 40 m"):
        fmu_road("hump:at=50", length=40.0)
