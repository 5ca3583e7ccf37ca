"""Nonlinear elements (contacts, stops, asymmetric dampers) and their exact stepping with
located events, against closed forms and an independent integration of hand-written
equations."""

import math

import numpy as np
import pytest
from helpers import solve_switching

from bodyvib.models import load_model
from bodyvib.runtime.discretize import simulate
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict
from bodyvib.runtime.network import (
    GRAVITY,
    Element,
    Network,
    linear_model,
    linearized,
    static_preloads,
)
from bodyvib.runtime.regimes import EVENT_TOLERANCE, EventStepper
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.reference import ReferenceStream
from bodyvib.vehicle.road.driven import RunSettings, driven_road
from bodyvib.vehicle.road.synthetic import road_input

EPS = np.finfo(float).eps


def drop(m=10.0, k=1e4, c=None):
    """A mass resting on the ground through a contact (spring k, optional damper c)."""
    values = {"k": "k"} | ({"c": "c"} if c else {})
    params = {"m": m, "k": k} | ({"c": c} if c else {})
    return Network(
        "drop",
        params,
        {"m": "m"},
        (Element("floor", "contact", "ground", "m", values),),
        base="ground",
    )


def oscillator(gap, k_stop=1e4, m=1.0, k=1.0):
    """A mass on a spring with an undamped stop at +-gap (no damping anywhere)."""
    return Network(
        "stopped",
        {"m": m, "k": k, "ks": k_stop, "gap": gap},
        {"m": "m"},
        (
            Element("spring", "spring", "ground", "m", {"k": "k"}),
            Element(
                "stop",
                "stop",
                "ground",
                "m",
                {"k": "ks", "gap_compression": "gap", "gap_rebound": "gap"},
            ),
        ),
        base="ground",
    )


def run(net, x0, h, n):
    stepper = EventStepper(net)
    x = np.array(x0, dtype=float)
    stepper.start(x, np.zeros(2))
    xs = [x]
    for k in range(n):
        x = stepper.step(x, np.zeros(2), np.zeros(2), h, k * h)
        xs.append(x)
    return stepper, np.array(xs)


# -- the model format --------------------------------------------------------------


def car_dict(**element_changes):
    return {
        "name": "c",
        "base": "road",
        "parameters": {"m": 300.0, "k": 2e5, "ks": 1e5},
        "masses": {"m": "m"},
        "elements": [
            {"name": "tire", "kind": "contact", "from": "road", "to": "m", "k": "k"},
            {
                "name": "stop",
                "kind": "stop",
                "from": "road",
                "to": "m",
                "k": "ks",
                "gap_compression": 0.05,
                "gap_rebound": 0.05,
            }
            | element_changes,
        ],
    }


def test_a_car_file_with_a_contact_and_a_stop_loads():
    net = network_from_dict(car_dict())
    assert static_preloads(net) == {"tire": pytest.approx(300.0 * GRAVITY, rel=1e-12)}


@pytest.mark.parametrize(
    "change, words",
    [
        ({"gap_compression": -0.01}, "gap_compression = -0.01 m is negative"),
        ({"k": 0}, "a stop with stiffness k = 0 N/m stops nothing"),
    ],
)
def test_bad_stops_are_refused_in_one_line(change, words):
    with pytest.raises(BodyvibError) as e:
        network_from_dict(car_dict(**change))
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_contact_without_a_load_path_to_gravity_is_refused():
    d = car_dict()
    d["base"] = ["road", "rail"]  # a contact between two bases carries no weight
    d["elements"].append({"name": "pad", "kind": "contact", "from": "road", "to": "rail", "k": 1e5})
    with pytest.raises(BodyvibError, match="contact 'pad' carries no static load") as e:
        network_from_dict(d)
    assert "\n" not in str(e.value)


def test_linearized_car_is_the_linear_quarter_car():
    car = load_car()
    lin = load_car(linear=True)
    assert [el.kind for el in lin.elements] == ["spring", "kelvin"]
    assert "k_stop" not in lin.parameters and not lin.nonlinear_elements
    assert [o["name"] for o in lin.fmu_outputs] == [
        "sprung_acceleration",
        "suspension_deflection",
        "tire_force",
    ]
    assert linearized(lin) is lin and car.nonlinear_elements


# -- the method: closed forms ----------------------------------------------------------


def test_lift_off_and_landing_are_located_to_the_stated_tolerance():
    """A mass on a contact spring, thrown up: lift-off where k x = m g on the harmonic
    solution, landing after the free flight 2 v1 / g; both in closed form."""
    m, k, v0, h = 10.0, 1e4, 2.0, 1e-3
    stepper, _ = run(drop(m, k), [0.0, v0], h, 500)
    w = math.sqrt(k / m)
    t1 = math.asin(m * GRAVITY * w / (k * v0)) / w
    v1 = v0 * math.cos(w * t1)
    t2 = t1 + 2 * v1 / GRAVITY
    (ta, _, a), (tb, _, b) = stepper.log.events[:2]
    assert (a, b) == ("lift-off", "landing")
    # the tolerance of the root, plus the rounding of the closed forms' times
    assert abs(ta - t1) <= EVENT_TOLERANCE * h + 100 * EPS * t1
    assert abs(tb - t2) <= EVENT_TOLERANCE * h + 100 * EPS * t2


def test_free_flight_is_a_parabola_under_gravity():
    m, k, v0, h = 10.0, 1e4, 2.0, 1e-3
    stepper, xs = run(drop(m, k), [0.0, v0], h, 500)
    w = math.sqrt(k / m)
    t1 = math.asin(m * GRAVITY * w / (k * v0)) / w
    x1, v1 = m * GRAVITY / k, v0 * math.cos(w * t1)
    t = np.arange(xs.shape[0]) * h
    air = (t > t1 + h) & (t < stepper.log.events[1][0] - h)
    tau = t[air] - t1
    parabola = x1 + v1 * tau - 0.5 * GRAVITY * tau**2
    # exact steps: rounding only, a few ulps of the flight's height per step
    assert np.max(np.abs(xs[air, 0] - parabola)) < 1e-12
    assert np.max(np.abs(xs[air, 1] - (v1 - GRAVITY * tau))) < 1e-11


def test_a_stop_at_infinite_gap_is_the_linear_model_bit_for_bit():
    net = oscillator(gap=1e6)
    t = np.arange(0, 5.0, 1e-3)
    u = np.c_[0.3 * np.sin(7 * t), 2.1 * np.cos(7 * t)]
    _, y = simulate(net, t, u)
    _, y_lin = simulate(linearized(net), t, u)
    names = linear_model(linearized(net)).outputs
    mine = EventStepper(net).regime.model.outputs
    for j, name in enumerate(names):
        assert np.array_equal(y[:, mine.index(name)], y_lin[:, j]), name


@pytest.mark.integration  # a few seconds
def test_energy_is_conserved_through_a_thousand_impacts():
    """Undamped mass on a spring, hitting a stop at +-gap each half period.

    Each exact step is a 2x2 matrix-vector product (error <= 2 ulps of the state per
    component); the energy, quadratic, moves by at most 4 ulps of itself per step, and
    by a random walk rather than a drift. A switching located to EVENT_TOLERANCE h
    changes the energy by the stop's force there (zero at the root) times the motion:
    second order. Bound: 4 eps per step over all steps."""
    m, k, ks, gap, h = 1.0, 1.0, 1e2, 0.5, 0.1
    net = oscillator(gap, ks, m, k)
    n = 14000
    stepper, xs = run(net, [0.0, 1.0], h, n)
    impacts = stepper.log.summary()["stop"]["contacts"]
    assert impacts >= 1000
    x, v = xs[:, 0], xs[:, 1]
    pen = np.maximum(np.abs(x) - gap, 0.0)
    energy = 0.5 * m * v**2 + 0.5 * k * x**2 + 0.5 * ks * pen**2
    drift = np.max(np.abs(energy - energy[0])) / energy[0]
    assert drift <= 4 * EPS * n, (drift, impacts)


def test_two_crossings_inside_one_step_are_found():
    """A crest that enters the stop and leaves it again within one step: both step ends
    are off the stop, the guard finds the visit; against a run at a step 100 times
    shorter."""
    net = oscillator(gap=0.9999, k_stop=1e4)
    coarse, xc = run(net, [0.0, 1.0], 0.1, 40)
    fine, xf = run(net, [0.0, 1.0], 0.001, 4000)
    assert coarse.log.summary()["stop"]["contacts"] == fine.log.summary()["stop"]["contacts"] >= 1
    assert np.max(np.abs(xc[-1] - xf[-1])) < 1e-8


def test_asymmetric_damper_switches_at_zero_rate():
    """c_rebound while extending, c_compression while shortening: a free decay loses
    energy faster in rebound; the rate at each event is zero."""
    net = Network(
        "shock",
        {"m": 1.0, "k": 100.0, "cc": 0.5, "cr": 3.0},
        {"m": "m"},
        (
            Element("spring", "spring", "ground", "m", {"k": "k"}),
            Element(
                "shock",
                "asymmetric_damper",
                "ground",
                "m",
                {"c_compression": "cc", "c_rebound": "cr"},
            ),
        ),
        base="ground",
    )
    stepper, xs = run(net, [0.1, 0.0], 1e-3, 2000)
    events = stepper.log.events
    assert len(events) >= 4
    assert {w for _, _, w in events} == {"rebound", "compression"}


# -- the quarter car on the bump: an independent solution --------------------------------

H, SPEED, BUMP = 1e-3, 20.0, (0.08, 1.0, 10.0)


def bump_road(t):
    h, l, at = BUMP
    s = SPEED * np.asarray(t) - at
    on = (s >= 0) & (s <= l)
    w = 2 * np.pi / l
    return (
        np.where(on, 0.5 * h * (1 - np.cos(w * s)), 0.0),
        np.where(on, 0.5 * h * w * np.sin(w * s) * SPEED, 0.0),
    )


def hand_written_solution(t_end):
    """The quarter car with tire contact and stops, carrying the reduced body, written
    out by hand (perturbations about static equilibrium, z up) and integrated by scipy
    with events at each switching (rtol 1e-10)."""
    ms, mu, ks, cs, kt = 290.0, 59.0, 16812.0, 1000.0, 190000.0
    k_stop, c_stop, gc, gr = 168120.0, 1400.0, 0.07, 0.09
    m1, m2, k1, k2, kb, c1, c2 = 4.88, 65.0, 6.18e4, 6.41e4, 8e5, 333.0, 2935.0
    f0 = (ms + mu + m1 + m2) * GRAVITY  # the tire's static load

    def switches(t, q):
        zs, vs, zu, vu = q[:4]
        r = bump_road(t)[0]
        d, dd = zs - zu, vs - vu
        return np.array(
            [
                f0 + kt * (r - zu),  # tire force
                k_stop * (-d - gc) - c_stop * dd,  # bump stop
                k_stop * (d - gr) + c_stop * dd,  # rebound stop
            ]
        )

    def rhs(t, q, mode):
        zs, vs, zu, vu, x1, v1, x2, v2, y = q
        tire, bump, rebound = np.where(mode, switches(t, q), 0.0)
        susp = ks * (zu - zs) + cs * (vu - vs)
        seat = kb * (zs - y)  # the body on the seat, + down
        yd = v2 + (kb * (zs - y) + k2 * (x2 - y)) / c2
        a1 = (k1 * (x2 - x1) + c1 * (v2 - v1)) / m1
        a2 = (kb * (zs - y) + k1 * (x1 - x2) + c1 * (v1 - v2)) / m2
        as_ = (susp + bump - rebound - seat) / ms
        au = (tire - f0 - susp - bump + rebound) / mu
        return [vs, as_, vu, au, v1, a1, v2, a2, yd]

    qs, found = solve_switching(rhs, switches, np.zeros(9), [True, False, False], t_end)
    events = [(t, ["tire", "stops", "stops"][i], on) for t, i, on in found]
    grid = np.arange(0, int(round(t_end / H)) + 1) * H
    head = np.empty(grid.size)
    for sol_fn, a, b, m in qs:
        sel = (grid >= a) & (grid <= b)
        for j in np.flatnonzero(sel):
            head[j] = rhs(grid[j], sol_fn(grid[j]), m)[5]
    return grid, head, events, f0


@pytest.mark.integration  # a few seconds
def test_quarter_car_over_the_bump_matches_hand_written_equations():
    """sine:h=0.08,l=1.0,at=10 at 20 m/s: the wheel leaves the road twice and the bump
    stop is met; head acceleration within 0.2 % NRMSE, lift-off and landing within one
    step, total tire force never below zero."""
    grid, head, events, f0 = hand_written_solution(1.5)
    z, v = bump_road(grid)
    stream = ReferenceStream(load_car(), load_model("reduced-paper"), H)
    out = stream.advance(z, v)
    err = np.sqrt(np.mean((out["head_acceleration"] - head) ** 2) / np.mean(head**2))
    assert err < 0.002, err
    mine = [(t, n, w) for t, n, w in stream.stepper.log.events if n == "tire"]
    theirs = [(t, n, on) for t, n, on in events if n == "tire"]
    assert [w for _, _, w in mine] == ["lift-off", "landing"] * 2
    assert len(theirs) == 4
    assert all(abs(a[0] - b[0]) <= H for a, b in zip(mine, theirs))
    assert np.min(out["tire_force"] + f0) >= -1e-9 * f0
    assert np.array_equal(out["tire_contact"] == 0, out["tire_force"] + f0 <= 1e-9 * f0)


def test_the_wheel_leaves_the_road_over_the_pothole():
    rs = RunSettings(road="pothole", speed=20.0, duration=2.0, step=H)
    t = np.arange(int(round(2.0 / H)) + 1) * H
    z, v = road_input(driven_road(rs), 20.0, t)
    car, body = load_car(), load_model("reduced-paper")
    stream = ReferenceStream(car, body, H)
    out = stream.advance(z, v)
    f0 = static_preloads(car.with_parameters(m_occupant=body.total_mass()))["tire"]
    tire = stream.events()["tire"]
    assert tire["lift_offs"] >= 1 and tire["time_in_air_s"] > 0.01
    assert np.min(out["tire_force"] + f0) >= -1e-9 * f0
    assert np.min(out["tire_contact"]) == 0.0


@pytest.mark.integration  # a few seconds
def test_class_c_equals_the_linear_car_bit_for_bit_until_the_first_switching():
    """Class C at 20 m/s (seed 0): until the first switching (the bump stop at 6.03 s,
    then the wheel lifts at 7.32 s) every output equals the linear car's bit for bit;
    class B at 20 m/s never switches: equal throughout."""
    body = load_model("reduced-paper")
    for road, n in (("C", 30001), ("B", 10001)):  # a random road depends on its length
        rs = RunSettings(road=road, speed=20.0, duration=(n - 1) * H, step=H)
        t = np.arange(n) * H
        z, v = road_input(driven_road(rs), 20.0, t)
        stream = ReferenceStream(load_car(), body, H)
        out = stream.advance(z, v)
        lin = ReferenceStream(load_car(), body, H, linear=True).advance(z, v)
        events = stream.stepper.log.events
        first = int(events[0][0] / H) if events else n - 1
        assert (road == "C") == bool(events)
        for name, col in out.items():
            if name not in ("tire_contact", "stop_force"):
                assert np.array_equal(col[: first + 1], lin[name][: first + 1], equal_nan=True), (
                    name
                )
        if road == "C":
            assert not np.array_equal(out["tire_force"], lin["tire_force"])


def test_fmu_core_steps_the_regimes_and_restores_them():
    """The car FMU's core over the bump: lift-offs inside doStep, its contact flag output,
    and a snapshot taken in the air that replays the rest bit for bit."""
    from bodyvib.runtime.engine import FmuCore

    core = FmuCore("car", load_car(), "QuarterCar")
    core.initialize()
    t = np.arange(0, 0.8, H)
    z, v = bump_road(t)
    names = [var.name for var in core.variables]
    ins = [names.index(n) for n in ("road_displacement", "road_velocity")]
    flag = names.index("tire_contact")
    flags, snap, rest = [], None, []
    for k in range(t.size):
        core.set_real(ins, [z[k], v[k]])
        core.do_step(t[k], H)
        flags.append(core.get_real([flag])[0])
        if k == 560:  # in the air
            snap = core.get_state()
        if k > 560:
            rest.append(core.get_real(list(range(len(names))))[:8])
    assert flags[560] == 0.0 and min(flags) == 0.0 and flags[-1] == 1.0
    assert core.events()["tire"]["lift_offs"] >= 1
    core.set_state(snap)
    again = []
    for k in range(561, t.size):
        core.set_real(ins, [z[k], v[k]])
        core.do_step(t[k], H)
        again.append(core.get_real(list(range(len(names))))[:8])
    assert again == rest
