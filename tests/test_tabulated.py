"""The tabulated signal source (bodyvib.runtime.tabulated) and the road table of Road.fmu.

Cubic Hermite interpolation with exact slopes reproduces any cubic exactly (the
tolerance is rounding); its error for a harmonic of wavenumber k on rows dx apart
is at most (k dx)^4 / 384 of the amplitude for the value (the classical bound
h^4 max|f''''| / 384), and of order (k dx)^3 for the slope.
"""

import json

import numpy as np
import pytest

from bodyvib.models import load_model
from bodyvib.runtime.engine import FmuCore
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.tabulated import HermiteTable, SourceCore, read_source, write_source
from bodyvib.vehicle.reference import nrmse
from bodyvib.vehicle.road.synthetic import BumpRoad, make_road, road_input, road_source, road_table


def test_hermite_reproduces_cubics_and_its_slope_is_the_derivative():
    x = np.linspace(-1.0, 2.0, 13)
    f = lambda s: 0.3 * s**3 - s**2 + 2 * s - 1  # noqa: E731
    df = lambda s: 0.9 * s**2 - 2 * s + 2  # noqa: E731
    tab = HermiteTable(x, f(x), df(x))
    p = np.linspace(-1.0, 2.0, 1001)
    z, dz = tab.evaluate(p)
    np.testing.assert_allclose(z[:, 0], f(p), rtol=0, atol=1e-13)
    np.testing.assert_allclose(dz[:, 0], df(p), rtol=0, atol=1e-12)


def test_rate_is_the_derivative_of_the_value_between_rows_for_any_profile():
    """Not a cubic: value and slope still come from one interpolant. Central difference
    with e = 1e-6: rounding ~1e-10; across a row the second derivative may jump (the
    interpolant is C1), adding up to e |jump z''| / 2 ~ 1e-8 here."""
    x = np.linspace(0, 10, 41)
    tab = HermiteTable(x, np.sin(x) ** 3, 3 * np.sin(x) ** 2 * np.cos(x))
    p, e = np.linspace(0.1, 9.9, 777), 1e-6
    fd = (tab.evaluate(p + e)[0] - tab.evaluate(p - e)[0]) / (2 * e)
    np.testing.assert_allclose(tab.evaluate(p)[1], fd, rtol=0, atol=1e-7)


def test_periodic_wraps_and_non_periodic_holds():
    x = np.linspace(0, 2 * np.pi, 65)
    per = HermiteTable(x, np.sin(x), np.cos(x), periodic=True)
    a, b = per.evaluate(1.0), per.evaluate(1.0 + 3 * 2 * np.pi)
    np.testing.assert_allclose(a, b, atol=1e-12)
    hold = HermiteTable(x, x, np.ones_like(x))
    z, dz = hold.evaluate([-1.0, 7.0])
    assert z[:, 0].tolist() == [0.0, x[-1]] and dz[:, 0].tolist() == [0.0, 0.0]
    with pytest.raises(BodyvibError, match="end where it starts"):
        HermiteTable(x, x, np.ones_like(x), periodic=True)
    with pytest.raises(BodyvibError, match="uniformly spaced"):
        HermiteTable([0.0, 1.0, 3.0], [0, 1, 2], [1, 1, 1])


def test_road_table_against_the_library_road():
    """ISO 8608 class C at 20 m/s and, off the rows, at 17.3 m/s: the value within the
    bound above for the band's shortest wavelength (0.35 m), times the r.m.s.; measured
    NRMSE 6e-7 (height) and 1e-4 (velocity, docs/tutorials/fmu_hosts.md, "FMUs"); at 20 m/s and 1 ms every sample
    falls on a row, where the table holds the library's values."""
    road = make_road("C", 20.0, 30.0, seed=0)
    tab = road_table(road, road.length)
    assert tab.periodic
    t = np.arange(30001) * 1e-3
    for speed in (20.0, 17.3):
        z, v = road_input(road, speed, t)
        zt, dzt = tab.evaluate(speed * t)
        k_dx = 2 * np.pi * 2.83 * 0.02
        assert nrmse(zt[:, 0], z) < k_dx**4 / 384 * 0.1
        assert nrmse(speed * dzt[:, 0], v) < 5e-4
        if speed == 20.0:
            assert nrmse(zt[:, 0], z) < 1e-12 and nrmse(speed * dzt[:, 0], v) < 1e-12


def test_bump_table_holds_zero_beyond_and_source_files_round_trip(tmp_path):
    meta, tab = road_source(BumpRoad(), 30.0, speed=10.0)
    assert not tab.periodic
    paths = write_source(tmp_path, meta, tab)
    meta2, tab2 = read_source(paths[0])
    assert (
        meta2["signals"] == meta["signals"]
        and json.loads(open(paths[0]).read())["periodic"] is False
    )
    np.testing.assert_array_equal(tab2.value, tab.value)
    np.testing.assert_array_equal(tab2.slope, tab.slope)
    core = SourceCore(meta2, tab2, "Road")
    core.initialize()
    names = [v.name for v in core.variables]
    assert names == ["road_displacement", "road_velocity", "speed"]
    core.do_step(0.0, 1.05)  # 10.5 m: inside the bump (10-11 m)
    z, v = core.get_real([0, 1])
    zr, vr = road_input(BumpRoad(), 10.0, [1.05])
    assert z == pytest.approx(zr[0], rel=1e-6) and v == pytest.approx(vr[0], rel=1e-4)
    core.do_step(1.05, 10.0)
    assert core.get_real([0, 1]) == [0.0, 0.0]


def test_source_refuses_bad_speed_and_step():
    meta, tab = road_source(BumpRoad(), 30.0)
    core = SourceCore(meta, tab, "Road")
    core.set_real([2], [-1.0])
    with pytest.raises(BodyvibError, match="speed = -1.0 m/s is invalid"):
        core.initialize()
    with pytest.raises(BodyvibError, match="refuses to step"):
        core.do_step(0.0, 1e-3)
    core.set_real([2], [5.0])
    core.initialize()
    with pytest.raises(BodyvibError, match="step size must be positive"):
        core.do_step(0.0, 0.0)
    state = core.get_state()
    core.do_step(0.0, 1.0)
    core.set_state(state)
    assert core.time == 0.0


def test_road_slave_in_plain_python(tmp_path):
    """The rendered slave script of kind "source" (Road.fmu's), without building the FMU:
    it reads the table from its resources, starts at the experiment's start time, refuses
    a bad step by returning False (pythonfmu's fmi2Discard), never raises."""
    pytest.importorskip("pythonfmu")
    import types

    from bodyvib.fmu.pythonfmu import render_slave_script
    from bodyvib.vehicle.fmus import FMUS

    mod = types.ModuleType("slave_Road")
    exec(
        compile(
            render_slave_script("Road", "source", FMUS["Road"][2], "bodyvib.runtime"),
            "<Road slave>",
            "exec",
        ),
        mod.__dict__,
    )
    meta, tab = road_source(BumpRoad(), 30.0, speed=10.0)
    write_source(tmp_path, meta, tab)
    slave = mod.Road(instance_name="unit", resources=str(tmp_path))
    assert [v.name for v in slave.vars.values()] == ["road_displacement", "road_velocity", "speed"]
    slave.setup_experiment(1.0)
    slave.exit_initialization_mode()
    assert slave.do_step(1.0, 0.05) is True  # 10.5 m: inside the bump
    z, v = slave.get_real([0, 1])
    zr, vr = road_input(BumpRoad(), 10.0, [1.05])
    assert z == pytest.approx(zr[0], rel=1e-6) and v == pytest.approx(vr[0], rel=1e-4)
    assert slave.do_step(1.05, -1.0) is False
    assert "step size must be positive" in slave.log_queue[-1].msg


def _body_core():
    core = FmuCore("body", load_model("reduced-paper"), "Core")
    return core, [v.name for v in core.variables].index("m1"), 4.88, "set valid parameters"


def _source_core():
    meta, tab = road_source(BumpRoad(), 30.0)
    return SourceCore(meta, tab, "Core"), 2, 5.0, "set a valid value"


@pytest.mark.parametrize("make", [_body_core, _source_core])
def test_both_cores_refuse_a_step_in_the_same_words(make):
    """One life cycle (bodyvib.runtime.lifecycle) for the network and the source core: the
    same refusals, word for word, and a refused step leaves the instance as it was."""
    core, vr, good, fix = make()
    with pytest.raises(
        BodyvibError,
        match=r"^Core: do_step before initialization; "
        r"call fmi2ExitInitializationMode first$",
    ):
        core.do_step(0.0, 1e-3)
    core.set_real([vr], [-1.0])
    with pytest.raises(BodyvibError) as failed:
        core.initialize()
    with pytest.raises(BodyvibError) as refused:
        core.do_step(0.0, 1e-3)
    assert str(refused.value) == f"{failed.value}; the instance refuses to step (reset and {fix})"
    core.set_real([vr], [good])
    core.initialize()
    for h in (0.0, -1e-3, float("nan"), float("inf")):
        with pytest.raises(BodyvibError) as bad:
            core.do_step(0.0, h)
        assert (
            str(bad.value)
            == f"Core: communication step size must be positive and finite, got {h!r} s"
        )
    assert core.time == 0.0
    core.do_step(0.0, 1e-3)
    assert core.time == pytest.approx(1e-3, abs=1e-15)


def test_a_lead_in_is_driven_once_then_the_loop_repeats(tmp_path):
    """Rows 0-1 a lead-in, rows 1-3 the repeating part: past the end the position wraps by the
    loop's length (2), not the table's (3); before the start the first row is held; the loop
    row survives a write and a read of the source files."""
    x = np.arange(4.0)
    t = HermiteTable(x, [0.0, 1.0, 2.0, 1.0], [0.0, 1.0, 0.0, 1.0], periodic=True, loop=1)
    p = np.array([0.5, 1.5, 2.5, 3.5, 5.5, 7.5, 2.25 + 20.0])
    z, dz = t.evaluate(p)
    z0, dz0 = t.evaluate(np.array([0.5, 1.5, 2.5, 1.5, 1.5, 1.5, 2.25]))
    np.testing.assert_array_equal(z, z0)
    np.testing.assert_array_equal(dz, dz0)
    z, dz = t.evaluate(-1.0)
    assert z.tolist() == [0.0] and dz.tolist() == [0.0]
    meta = {"coordinate": {"name": "distance"}, "signals": [{"name": "z"}]}
    paths = write_source(tmp_path, meta, t)
    meta2, t2 = read_source(paths[0])
    assert meta2["loop_row"] == 1 and t2.loop == 1 and t2.periodic
    with pytest.raises(
        BodyvibError, match=r"end where its repeating part starts \(last row = row 2"
    ):
        HermiteTable(x, [0.0, 1.0, 2.0, 1.0], [0.0, 1.0, 0.0, 1.0], periodic=True, loop=2)
    with pytest.raises(BodyvibError, match="does not repeat has no loop row"):
        HermiteTable(x, x, x, loop=1)
    with pytest.raises(BodyvibError, match=r"loop row 3 is off the table \(0 to 2\)"):
        HermiteTable(x, x, x, periodic=True, loop=3)
