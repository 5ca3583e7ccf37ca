"""The active cars with tires as contacts and suspension stops under the skyhook law: the
wheel leaves the road over the pothole, the linear active car bit for bit where nothing
switches, the lift-off against hand-written equations (solve_ivp with events, rtol 1e-10),
and the linear car's range watched at every wheel."""

import warnings

import numpy as np
import pytest
from helpers import linear_car_dict, solve_switching

from bodyvib.models import load_model
from bodyvib.runtime.modelfile import network_from_dict
from bodyvib.runtime.network import GRAVITY, linear_model
from bodyvib.vehicle.active import compare_laws, lift_offs
from bodyvib.vehicle.control import ClosedLoopPiecewise, SkyhookController, parse_control
from bodyvib.vehicle.events import LinearRangeWarning, linear_ranges
from bodyvib.vehicle.quarter_car import load_car, wheel_offsets
from bodyvib.vehicle.reference import ReferenceStream, reference_run
from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs

H, SPEED = 1e-3, 20.0
POTHOLE = (0.05, 0.6, 0.05, 10.0)  # the "pothole" road: depth, length, ramp, at (m)
ACTIVE_CARS = ["quarter-car-active", "half-car-active", "full-car-active"]


def _road(name, car, duration):
    t = np.arange(int(round(duration / H)) + 1) * H
    road = driven_road(RunSettings(name, SPEED, duration, H))
    return (t, *wheel_inputs(road, SPEED, t, wheel_offsets(car)))


def _seated_preload(car, body):
    """The tires' static loads with this occupant on the seat, by the lever rule (the
    quarter car: all of it on its one tire; the full car, on four corners, by the
    stiffnesses: its body's static deflection)."""
    p, mb = car.parameters, body.total_mass()
    if "lf" not in p:
        return {"tire": (p["ms"] + p["mu"] + mb) * GRAVITY}
    lf, lr, sx = p["lf"], p["lr"], p["seat_x"]
    L = lf + lr
    if "tf" not in p:
        return {
            "tire_front": GRAVITY * (p["muf"] + p["ms"] * lr / L + mb * (lr + sx) / L),
            "tire_rear": GRAVITY * (p["mur"] + p["ms"] * lf / L + mb * (lf - sx) / L),
        }
    # four corners under a rigid body: statically indeterminate; each corner a spring of
    # the suspension and tire in series, the body's (z, theta, phi) from K q = loads
    corners = {
        "front_left": (lf, p["tf"] / 2, "f"),
        "front_right": (lf, -p["tf"] / 2, "f"),
        "rear_left": (-lr, p["tr"] / 2, "r"),
        "rear_right": (-lr, -p["tr"] / 2, "r"),
    }
    K, k = np.zeros((3, 3)), {}
    for name, (x, y, a) in corners.items():
        k[name] = 1.0 / (1.0 / p["ks" + a] + 1.0 / p["kt" + a])
        K += k[name] * np.outer([1, x, y], [1, x, y])
    q = np.linalg.solve(K, GRAVITY * np.array([p["ms"] + mb, mb * sx, mb * p["seat_y"]]))
    return {
        f"tire_{name}": k[name] * (q[0] + x * q[1] + y * q[2]) + GRAVITY * p["mu" + a]
        for name, (x, y, a) in corners.items()
    }


def test_the_active_files_are_the_passive_cars_with_actuators():
    """Same values, tire contacts and stops as the passive files: the actuators aside,
    the same network."""
    for name in ("quarter-car", "half-car", "full-car"):
        passive, active = load_car(name), load_car(f"{name}-active")
        assert active.parameters == passive.parameters
        assert active.elements == passive.elements
        assert active.static_loads == passive.static_loads
        assert {o["name"] for o in passive.fmu_outputs} <= {o["name"] for o in active.fmu_outputs}


@pytest.mark.parametrize("name", ACTIVE_CARS)
def test_linear_option_is_the_active_car_with_tire_springs_and_no_stops(name):
    """``linear=True``: the car file with its contacts as springs and no stops, matrix for
    matrix, and the law comparison of that car bit for bit."""
    by_hand = network_from_dict(linear_car_dict(name))
    mine = load_car(name, linear=True)
    for m in "ABCD":
        assert np.array_equal(getattr(linear_model(mine), m), getattr(linear_model(by_hand), m))
    body, settings = load_model("reduced-paper"), RunSettings("C", SPEED, 2.0, H)
    laws = ["passive", "skyhook", "groundhook"]
    a = compare_laws(load_car(name), body, settings, laws, linear=True)
    b = compare_laws(by_hand, body, settings, laws)
    assert a.linear and b.linear
    for fa, fb in zip(a.laws, b.laws):  # the by-hand car has no range to warn of
        assert {**fa.to_dict(), "warnings": ()} == fb.to_dict()
    for law in laws:
        assert np.array_equal(a.head[law], b.head[law])


@pytest.mark.parametrize("name", ACTIVE_CARS)
def test_where_nothing_switches_the_controlled_car_is_the_linear_one_bit_for_bit(name):
    """Class C at 20 m/s for 5 s under the skyhook: no lift-off, no stop; every signal,
    the actuator forces too, equals the linear active car's. (The 2 s road of seed 0 lifts
    the half car's rear wheel for 4 ms under this law: a case that switches.)"""
    car, body = load_car(name), load_model("reduced-paper")
    law = parse_control("skyhook", car)
    _, z, v = _road("C", car, 5.0)
    stream = ReferenceStream(car, body, H, law)
    out = stream.advance(z, v)
    lin = ReferenceStream(car, body, H, law, linear=True).advance(z, v)
    assert not stream.stepper.log.events
    assert set(out) == set(lin)
    for k, x in lin.items():
        assert np.array_equal(out[k], x, equal_nan=True), k
    # the law comparison: the same figures to rounding (its linear run forms the forcing of
    # 4096 steps at once)
    c = compare_laws(car, body, RunSettings("C", SPEED, 5.0, H), ["skyhook"])
    c_lin = compare_laws(car, body, RunSettings("C", SPEED, 5.0, H), ["skyhook"], linear=True)
    assert lift_offs(c.laws[0]) == (0, 0)
    assert c.laws[0].head_wk_rms == pytest.approx(c_lin.laws[0].head_wk_rms, rel=1e-12)
    assert c.laws[0].tire_force_rms == pytest.approx(c_lin.laws[0].tire_force_rms, rel=1e-12)


@pytest.mark.parametrize("name", ACTIVE_CARS)
def test_the_controlled_wheel_leaves_the_road_over_the_pothole(name):
    """The 50 mm pothole at 20 m/s under the skyhook: the total tire force never below 0,
    the wheel in the air, the contact flag 0 exactly while the tire carries nothing."""
    car, body = load_car(name), load_model("reduced-paper")
    law = parse_control("skyhook", car)
    _, z, v = _road("pothole", car, 2.0)
    stream = ReferenceStream(car, body, H, law)
    out = stream.advance(z, v)
    f0 = _seated_preload(car, body)
    front = next(iter(f0))  # the quarter car's tire, the front (left) one
    total = out["tire_force"] + f0[front]
    assert np.min(total) >= -1e-9 * f0[front]
    if name == "quarter-car-active":  # the table's contact flag: the quarter car's tire
        assert np.min(out["tire_contact"]) == 0.0
        assert np.array_equal(out["tire_contact"] == 0, total <= 1e-9 * f0[front])
    events = stream.events()
    for tire in f0:
        assert events[tire]["lift_offs"] >= 1 and events[tire]["time_in_air_s"] > 0.005
        assert events[tire]["smallest_load_ratio"] == 0.0
    # the law still acts in the air: the skyhook force is -c_sky times the body velocity
    if name == "quarter-car-active":
        force = -law.c_sky * out["seat_velocity"]
        np.testing.assert_allclose(out["actuator_force"], force, rtol=1e-12, atol=1e-9)
    c = compare_laws(car, body, RunSettings("pothole", SPEED, 2.0, H), ["passive", "skyhook"])
    assert all(lift_offs(f)[0] >= len(f0) for f in c.laws)
    assert not c.linear


def test_a_semi_active_law_has_no_closed_loop_regimes():
    car = load_car("quarter-car-active")
    with pytest.raises(Exception, match="semi-active law is not linear"):
        ClosedLoopPiecewise(car, car, SkyhookController(c_sky=1000.0, semi_active=True))


# -- the lift-off against an independent solution -----------------------------------------


def pothole(t):
    """The pothole's depth under the wheel at time t (m), written out: ramps of ``r`` down
    to ``-d`` and up again over its length ``l``, starting ``at`` m down the road."""
    d, length, r, at = POTHOLE
    s = SPEED * t - at
    if s <= 0.0 or s >= length:
        return 0.0
    return -d * min(s / r, 1.0, (length - s) / r)


def hand_written_active_quarter_car(c_sky):
    """d/dt of [zs, vs, zu, vu, x1, v1, x2, v2, y] of the quarter car with tire contact and
    stops carrying the reduced body, an actuator between wheel and body pushing them apart
    with the skyhook force -c_sky vs (perturbations about static equilibrium, z up)."""
    ms, mu, ks, cs, kt = 290.0, 59.0, 16812.0, 1000.0, 190000.0
    k_stop, c_stop, gc, gr = 168120.0, 1400.0, 0.07, 0.09
    m1, m2, k1, k2, kb, c1, c2 = 4.88, 65.0, 6.18e4, 6.41e4, 8e5, 333.0, 2935.0
    f0 = (ms + mu + m1 + m2) * GRAVITY

    def switches(t, q):
        zs, vs, zu, vu = q[:4]
        d, dd = zs - zu, vs - vu
        return np.array(
            [
                f0 + kt * (pothole(t) - zu),
                k_stop * (-d - gc) - c_stop * dd,
                k_stop * (d - gr) + c_stop * dd,
            ]
        )

    def rhs(t, q, mode):
        zs, vs, zu, vu, x1, v1, x2, v2, y = q
        tire, bump, rebound = np.where(mode, switches(t, q), 0.0)
        act = -c_sky * vs  # the skyhook: a damper from the body to the sky
        susp = ks * (zu - zs) + cs * (vu - vs)
        yd = v2 + (kb * (zs - y) + k2 * (x2 - y)) / c2
        a1 = (k1 * (x2 - x1) + c1 * (v2 - v1)) / m1
        a2 = (kb * (zs - y) + k1 * (x1 - x2) + c1 * (v1 - v2)) / m2
        as_ = (susp + bump - rebound - kb * (zs - y) + act) / ms
        au = (tire - f0 - susp - bump + rebound - act) / mu
        return [vs, as_, vu, au, v1, a1, v2, a2, yd]

    return rhs, switches, f0


@pytest.mark.integration  # a few seconds: the event-locating ODE solution
def test_the_controlled_lift_off_matches_hand_written_equations():
    """The pothole at 20 m/s under the skyhook: head acceleration within 0.2 % NRMSE of
    scipy's solution with events, each lift-off and landing within one step of its."""
    car, body = load_car("quarter-car-active"), load_model("reduced-paper")
    law = parse_control("skyhook", car)
    t, z, v = _road("pothole", car, 1.5)
    z, v = z[:, 0], v[:, 0]
    assert np.allclose(z, [pothole(tk) for tk in t], rtol=0, atol=1e-15)  # the same road
    rhs, switches, f0 = hand_written_active_quarter_car(law.c_sky)
    pieces, found = solve_switching(rhs, switches, np.zeros(9), [True, False, False], 1.5)
    head = np.empty(t.size)
    for fn, a, b, m in pieces:
        for j in np.flatnonzero((t >= a) & (t <= b)):
            head[j] = rhs(t[j], fn(t[j]), m)[5]
    stream = ReferenceStream(car, body, H, law)
    out = stream.advance(z, v)
    err = np.sqrt(np.mean((out["head_acceleration"] - head) ** 2) / np.mean(head**2))
    assert err < 0.002, err
    mine = [(tk, w) for tk, n, w in stream.stepper.log.events if n == "tire"]
    theirs = [tk for tk, i, _ in found if i == 0]
    assert [w for _, w in mine][:2] == ["lift-off", "landing"]
    assert len(mine) == len(theirs) >= 2
    assert all(abs(a - b) <= H for (a, _), b in zip(mine, theirs))
    assert np.min(out["tire_force"] + f0) >= -1e-9 * f0


# -- the linear car's range at every wheel ----------------------------------------------


def test_the_linear_half_car_warns_for_each_wheel_that_would_pull():
    """Over the pothole at 20 m/s the linear half car's front and rear tires both pull: a
    warning each, naming the wheel, with the pull against the static load by hand."""
    car, body = load_car("half-car"), load_model("reduced-paper")
    f0 = _seated_preload(car, body)
    ranges = linear_ranges(car, body.total_mass())
    assert [r.wheel for r in ranges] == ["front", "rear"]
    for r in ranges:
        assert r.static_load == pytest.approx(f0[f"tire_{r.wheel}"], rel=1e-12)
        assert (r.gap_compression, r.gap_rebound) == (0.07, 0.09)
    _, z, v = _road("pothole", car, 2.0)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        reference_run(car, body, z, v, H, linear=True)
    lines = [str(w.message) for w in rec if issubclass(w.category, LinearRangeWarning)]
    extra = ("tire_force_front", "tire_force_rear")
    run = ReferenceStream(car, body, H, linear=True, extra=extra).advance(z, v)
    for wheel in ("front", "rear"):
        pull = -(f0[f"tire_{wheel}"] + run[f"tire_force_{wheel}"].min())
        assert pull > 0.0
        words = f"the linear {wheel} tire pulls with up to {pull / 1e3:.1f} kN"
        assert sum(words in line for line in lines) == 1, (words, lines)
    assert len(lines) == 2  # no stop reached
    # the law comparison of the linear active half car (its actuators idle: this car)
    # watches both axles the same way
    active = load_car("half-car-active")
    c = compare_laws(active, body, RunSettings("pothole", SPEED, 2.0, H), ["passive"], linear=True)
    assert list(c.laws[0].warnings) == lines
