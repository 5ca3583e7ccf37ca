"""The half and full car with tires as contacts and stops at each corner: their linear
car bit for bit where nothing switches, the half car over the 80 mm bump against
hand-written equations (solve_ivp with events, rtol 1e-10), events reported per wheel."""

import json

import numpy as np
import pytest
from helpers import linear_car_dict, reduced_body_on_seat, run_cli, solve_switching
from test_regimes import BUMP, SPEED, H, bump_road

from bodyvib.models import load_model
from bodyvib.runtime.modelfile import network_from_dict
from bodyvib.runtime.network import GRAVITY, linear_model, static_preloads
from bodyvib.vehicle.quarter_car import load_car, wheel_offsets
from bodyvib.vehicle.reference import ReferenceStream, reference_run
from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs
from bodyvib.vehicle.signals import WHEEL_SIGNALS, car_wheels, wheel_columns

CARS = ("half-car", "full-car")


@pytest.mark.parametrize("name", CARS)
def test_linear_option_is_the_car_with_tire_springs_and_no_stops(name):
    by_hand = linear_model(network_from_dict(linear_car_dict(name)))
    mine = linear_model(load_car(name, linear=True))
    for m in "ABCD":
        assert np.array_equal(getattr(mine, m), getattr(by_hand, m)), m
    assert mine.outputs == by_hand.outputs


@pytest.mark.parametrize("name", CARS)
def test_static_tire_loads_are_the_weights_on_each_wheel(name):
    """Each axle's tires carry its unsprung masses and its share of the body and of the
    occupant (m_occupant on the seat point), by the lever rule."""
    car = load_car(name)
    p = car.parameters
    lf, lr, sx, L = p["lf"], p["lr"], p["seat_x"], p["lf"] + p["lr"]
    pre = static_preloads(car)
    share = {
        "front": p["ms"] * lr / L + p["m_occupant"] * (lr + sx) / L,
        "rear": p["ms"] * lf / L + p["m_occupant"] * (lf - sx) / L,
    }
    for axle in ("front", "rear"):
        tires = {k: f for k, f in pre.items() if k.startswith(f"tire_{axle}")}
        m = share[axle] + len(tires) * p["mu" + axle[0]]
        assert sum(tires.values()) == pytest.approx(m * GRAVITY, rel=1e-12)


@pytest.mark.parametrize("name", CARS)
def test_where_nothing_switches_the_outputs_are_the_linear_cars_bit_for_bit(name):
    """Class C at 20 m/s: no lift-off, no stop; every signal equals --linear's."""
    car = load_car(name)
    road = driven_road(RunSettings("C", 20.0, 2.0, H))
    t = np.arange(2001) * H
    z, v = wheel_inputs(road, 20.0, t, wheel_offsets(car))
    body = load_model("reduced-paper")
    stream = ReferenceStream(car, body, H)
    nl = stream.advance(z, v)
    lin = reference_run(car, body, z, v, H, linear=True)
    assert not stream.stepper.log.events
    for k, x in nl.items():
        assert np.array_equal(x, lin[k], equal_nan=True), k


def test_the_wheel_columns_follow_one_rule():
    half = {o["name"] for o in load_car("half-car").fmu_outputs}
    full = {o["name"] for o in load_car("full-car").fmu_outputs}
    assert car_wheels(half) == ("front", "rear")
    assert car_wheels(full) == ("front_left", "front_right", "rear_left", "rear_right")
    assert set(wheel_columns(car_wheels(full))) <= full
    assert car_wheels({o["name"] for o in load_car("half-car", linear=True).fmu_outputs}) == ()
    assert len(WHEEL_SIGNALS) == 3


# -- the half car over the bump: an independent solution ----------------------------------


def _half_car_switches(p, f0, q, rf, rr):
    """Tire forces front, rear; bump and rebound stop forces front, rear (engaged > 0)."""
    z, th, zf, zr = q[:4]
    vz, om, vf, vr = q[7:11]
    out = [f0[0] + p["ktf"] * (rf - zf), f0[1] + p["ktr"] * (rr - zr)]
    for a, (x, w, vw) in (("f", (p["lf"], zf, vf)), ("r", (-p["lr"], zr, vr))):
        d, dd = z + x * th - w, vz + x * om - vw  # body point above its wheel, + extension
        k, c = p[f"k_stop{a}"], p[f"c_stop{a}"]
        out += [
            k * (-d - p[f"gap_compression{a}"]) - c * dd,
            k * (d - p[f"gap_rebound{a}"]) + c * dd,
        ]
    return np.array(out)


def hand_written_half_car(p, b):
    """d/dt of [z, theta, zf, zr, y, x2, x1, vz, omega, vf, vr, v2, v1] with tire
    contacts and stops (perturbations about static equilibrium, z up), the reduced body
    on the seat point; its switching functions and the tires' static loads."""
    ms, Iy, lf, lr, sx = p["ms"], p["Iy"], p["lf"], p["lr"], p["seat_x"]
    L = lf + lr
    mb = b["m1"] + b["m2"]  # the occupant on the seat point
    f0 = (
        GRAVITY * (p["muf"] + ms * lr / L + mb * (lr + sx) / L),
        GRAVITY * (p["mur"] + ms * lf / L + mb * (lf - sx) / L),
    )

    def roads(t):
        return bump_road(t)[0], bump_road(t - L / SPEED)[0]

    def switches(t, q):
        return _half_car_switches(p, f0, q, *roads(t))

    def rhs(t, q, mode):
        z, th, zf, zr, y, x2, x1, vz, om, vf, vr, v2, v1 = q
        tf, tr, bf, rbf, br, rbr = np.where(mode, switches(t, q), 0.0)
        yd, a2, a1, f_seat = reduced_body_on_seat(b, z + sx * th, y, x2, x1, v2, v1)
        # suspension and stops on each wheel, + pushing it down (and the body up)
        f_front = p["ksf"] * (zf - z - lf * th) + p["csf"] * (vf - vz - lf * om) + bf - rbf
        f_rear = p["ksr"] * (zr - z + lr * th) + p["csr"] * (vr - vz + lr * om) + br - rbr
        az = (f_front + f_rear + f_seat) / ms
        alpha = (lf * f_front - lr * f_rear + sx * f_seat) / Iy
        af = (-f_front + tf - f0[0]) / p["muf"]  # the tires' total force less their static
        ar = (-f_rear + tr - f0[1]) / p["mur"]
        return [vz, om, vf, vr, yd, v2, v1, az, alpha, af, ar, a2, a1]

    return rhs, switches, f0


def half_car_solution(t_end):
    """The hand-written half car integrated by scipy with an event at each switching:
    the grid, the head acceleration on it, the events ``(t, index, on)``, the static loads."""
    rhs, switches, f0 = hand_written_half_car(
        load_car("half-car").parameters, load_model("reduced-paper").parameters
    )
    pieces, events = solve_switching(rhs, switches, np.zeros(13), [True, True] + [False] * 4, t_end)
    grid = np.arange(int(round(t_end / H)) + 1) * H
    head = np.empty(grid.size)
    for fn, a, b, m in pieces:
        for j in np.flatnonzero((grid >= a) & (grid <= b)):
            head[j] = rhs(grid[j], fn(grid[j]), m)[12]
    return grid, head, events, f0


def _nrmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b**2)))


@pytest.mark.integration  # a few seconds: the event-locating ODE solution
def test_half_car_over_the_bump_matches_hand_written_equations():
    """The library's exact stepping with located events (the monolithic reference):
    both wheels leave the road, head within 0.2 % NRMSE, each lift-off and landing within
    one step of the ODE solver's."""
    grid, head, events, _ = half_car_solution(1.5)
    car = load_car("half-car")
    z, v = _wheels(grid, car)
    stream = ReferenceStream(car, load_model("reduced-paper"), H)
    out = stream.advance(z, v)
    assert _nrmse(out["head_acceleration"], head) < 0.002
    for k, tire in enumerate(("tire_front", "tire_rear")):
        mine = [t for t, n, _ in stream.stepper.log.events if n == tire]
        theirs = [t for t, i, _ in events if i == k]
        assert len(mine) == len(theirs) >= 2
        assert np.all(np.abs(np.array(mine) - theirs) <= H)


def _wheels(grid, car):
    """The bump under the front wheel and, a wheelbase later, under the rear one."""
    behind = wheel_offsets(car)
    z = np.column_stack([bump_road(grid - d / SPEED)[0] for d in behind])
    v = np.column_stack([bump_road(grid - d / SPEED)[1] for d in behind])
    return z, v


@pytest.mark.integration  # builds the HalfCar pythonfmu; a few seconds
def test_cosim_half_car_over_the_bump(tmp_path):
    """bodyvib cosim --car half-car over sine:h=0.08,l=1.0,at=10 at 20 m/s: head within
    0.2 % NRMSE of the hand-written solution, each wheel's contact flag changing at the
    communication point after the solver's event, total tire forces never negative,
    events per wheel in the text, the JSON and the CSV."""
    grid, head, events, f0 = half_car_solution(1.5)
    h, l, at = BUMP
    csv, js = tmp_path / "run.csv", tmp_path / "run.json"
    r = run_cli(
        "cosim",
        "--car",
        "half-car",
        "--road",
        f"sine:h={h},l={l},at={at}",
        "--speed",
        str(SPEED),
        "--duration",
        "1.5",
        "--csv",
        str(csv),
        "--json",
        str(js),
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    run = np.genfromtxt(csv, delimiter=",", names=True)
    assert _nrmse(run["head_acceleration_ms2"], head) < 0.002
    doc = json.loads(js.read_text())["bodies"]["HumanBody3DOF"]
    for k, wheel in enumerate(("front", "rear")):
        flag = run[f"tire_contact_{wheel}_1"]
        changes = grid[1:][np.diff(flag) != 0]
        theirs = np.array([t for t, i, _ in events if i == k])
        assert changes.size == theirs.size >= 2
        assert np.all((changes >= theirs) & (changes - theirs <= H))
        assert np.min(run[f"tire_force_{wheel}_N"] + f0[k]) >= -1e-9 * f0[k]
        w = doc["wheel_events"][wheel]
        assert w["lift_offs"] == theirs.size // 2
        assert w["smallest_tire_load_ratio"] == 0.0
    assert doc["events"]["lift_offs"] == sum(e["lift_offs"] for e in doc["wheel_events"].values())
    assert "  rear lift-offs" in r.stdout and "  front stop contacts" in r.stdout


# -- sweeps: the batched engine where nothing switches, events where a case would --------


def _sweep(**spec):
    from bodyvib.vehicle.sweep.engines import run_batched
    from bodyvib.vehicle.sweep.spec import expand

    return run_batched(expand({"body": "reduced-paper", "duration": 2, **spec}), record=True)


def test_a_sweep_steps_on_the_batched_engine_where_nothing_switches():
    """Class C at 20 m/s: the nonlinear cars stay batched, their figures the linear
    spec's bit for bit; the smallest tire-load ratio is the reference's lowest total
    tire force over its static load."""
    cars = ["quarter-car", "half-car"]
    rows, hist = _sweep(road="C", speed=20, car=cars)
    lin, lin_hist = _sweep(road="C", speed=20, car=cars, linear=True)
    for r, h, lr, lh, name in zip(rows, hist, lin, lin_hist, cars):
        assert r["error"] is None and r["stepping"] == "batched"
        assert lr["stepping"] == "linear" and np.isnan(lr["lift_offs"])
        assert r["head_weighted_rms"] == lr["head_weighted_rms"]
        assert np.array_equal(h["head_acceleration"], lh["head_acceleration"])
        assert r["lift_offs"] == r["stop_contacts"] == 0
        # the front (a quarter car's only) tire's total force over its static one
        car = load_car(name)
        run = reference_run(car, load_model("reduced-paper"), *_driven(name, "C", 20.0), H)
        tire = next(e for e in static_preloads(car) if e.startswith("tire"))
        front = 1.0 + np.min(run["tire_force"]) / static_preloads(car)[tire]
        if name == "quarter-car":
            assert r["smallest_tire_load_ratio"] == pytest.approx(front, abs=1e-12)
        else:  # the lowest of the wheels
            assert r["smallest_tire_load_ratio"] <= front + 1e-12
        assert 0.1 < r["smallest_tire_load_ratio"] < 1.0


def _driven(name, road, speed, duration=2.0):
    """The road under each wheel of a car as a sweep case drives it."""
    from bodyvib.vehicle.sweep.engines import case_wheel_inputs
    from bodyvib.vehicle.sweep.spec import expand

    case = expand({"road": road, "speed": speed, "duration": duration, "car": name})[0]
    car = load_car(name)
    return case_wheel_inputs(case, wheel_offsets(car))


def test_a_case_that_would_switch_is_run_again_with_events():
    """The 80 mm bump at 20 m/s lifts the wheels: the case runs with located events and
    its row says what happened, as the car's monolithic reference counts it; over a
    5 mm bump nothing switches and the case stays batched."""
    h, l, at = BUMP
    cars = ["quarter-car", "half-car"]
    roads = [f"sine:h=0.005,l={l},at={at}", f"sine:h={h},l={l},at={at}"]
    rows, _ = _sweep(road=roads, speed=20, car=cars)
    small, fast = rows[:2], rows[2:]
    assert [r["stepping"] for r in small] == ["batched", "batched"]
    for r, name in zip(fast, cars):
        assert r["error"] is None and r["stepping"] == "events"
        stream = ReferenceStream(load_car(name), load_model("reduced-paper"), H)
        stream.advance(*_driven(name, f"sine:h={h},l={l},at={at}", 20.0))
        ev = stream.events().values()
        assert r["lift_offs"] == sum(e.get("lift_offs", 0) for e in ev) >= 2
        assert r["stop_contacts"] == sum(e.get("contacts", 0) for e in ev) >= 1
        assert r["smallest_tire_load_ratio"] == 0.0 and r["time_in_air"] > 0.04


# -- the bump study: the speed from which each bump lifts the wheel -----------------------


def test_the_bump_study_names_and_marks_the_speed_of_the_first_lift_off(tmp_path):
    """The 80 mm, 1 m bump lifts the quarter car's wheel at 6 m/s and not at 4 m/s (as
    the car's monolithic reference counts it); the summary and the plot say so."""
    import pandas as pd

    from bodyvib.vehicle.sweep.engines import run_batched
    from bodyvib.vehicle.sweep.plot import BUMP_PANELS, plot_bump_study
    from bodyvib.vehicle.sweep.spec import expand
    from bodyvib.vehicle.sweep.summary import format_summary, lift_off_speeds

    road = "sine:h=0.08,l=1,at=10"  # as the sweep names it
    cases = expand({"road": road, "speed": [4, 6], "duration": 3, "body": "reduced-paper"})
    for cs in cases:
        stream = ReferenceStream(load_car(), load_model("reduced-paper"), H)
        stream.advance(*_driven("quarter-car", road, cs.speed, 3.0))
        assert (stream.events()["tire"]["lift_offs"] > 0) == (cs.speed == 6)
    rows, _ = run_batched(cases)
    df = pd.DataFrame(
        [
            {
                **r,
                "road": c.road,
                "body": c.body,
                "car": c.car,
                "speed": c.speed,
                "case_id": i,
                "engine": "batched",
            }
            for i, (c, r) in enumerate(zip(cases, rows))
        ]
    )
    assert lift_off_speeds(df) == {(road, "reduced-paper", "quarter-car"): 6.0}
    assert f"{road} (reduced-paper, quarter-car): lift-off from 6 m/s" in format_summary(df)
    svg = tmp_path / "bumps.svg"
    plot_bump_study(df, str(svg))
    assert svg.read_text().count("lift-off from 6 m/s") == len(BUMP_PANELS)  # each legend
