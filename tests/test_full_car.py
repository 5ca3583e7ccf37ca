"""The full car: a body that bounces, pitches and rolls on four corners, two road tracks.

Independent references: the half car (the shipped full car is it, split into its left
and right sides), the exact symmetry of anti-phase tracks, and scipy's solve_ivp (rtol
1e-10) on the 7-DOF full-car and occupant equations written out here by hand.
"""

import copy
import json

import numpy as np
import pytest
from helpers import (
    SINE_AMPLITUDE_M,
    SINE_WAVELENGTH_M,
    car_dict,
    nrmse_against_ode,
    reduced_body_on_seat,
    sine_road,
)

from bodyvib.models import load_model
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import load_car, wheel_offsets
from bodyvib.vehicle.reference import nrmse, reference_run
from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs

STEP = 1e-3


def full_car_dict():
    return car_dict("full-car")


def half_car_road(speed=15.0, duration=3.0):
    """An ISO 8608 class C road under the half car's two axles: (z, v), a column each."""
    t = np.arange(0.0, duration, STEP)
    behind = wheel_offsets(load_car("half-car"))
    return wheel_inputs(driven_road(RunSettings("C", speed, duration)), speed, t, behind)


def four_wheels(front_rear, sign=1.0):
    """The four corners' columns from (front, rear) columns: left as given, right times sign."""
    z = np.asarray(front_rear)
    return np.stack([z[:, 0], sign * z[:, 0], z[:, 1], sign * z[:, 1]], axis=1)


def test_the_full_car_is_the_half_car_split_in_two():
    """Each corner holds half an axle; the body, the axles and the seat's x as the half car."""
    full, half = load_car("full-car").parameters, load_car("half-car").parameters
    for name in ("muf", "mur", "ksf", "ksr", "csf", "csr", "ktf", "ktr"):
        assert full[name] == half[name] / 2
    for name in ("ms", "Iy", "lf", "lr", "seat_x"):
        assert full[name] == half[name]
    assert wheel_offsets(load_car("full-car")) == (0.0, 0.0, 2.8, 2.8)


def test_centreline_seat_on_identical_tracks_is_the_half_car():
    """Seat on the centreline, left track = right track: head acceleration = the half
    car's to 1e-9 relative (both exact discretizations of their own state spaces)."""
    body = load_model("reduced-paper")
    z, v = half_car_road()
    half = reference_run(load_car("half-car"), body, z, v, STEP)
    car = load_car("full-car").with_parameters(seat_y=0.0)
    full = reference_run(car, body, four_wheels(z), four_wheels(v), STEP)
    scale = np.max(np.abs(half["head_acceleration"]))
    assert scale > 0.1
    err = np.max(np.abs(full["head_acceleration"] - half["head_acceleration"])) / scale
    assert err <= 1e-9, err


def _seated_response(car, z, v):
    from bodyvib.runtime.discretize import Discretization, input_rates
    from bodyvib.vehicle.quarter_car import seated_system

    lm = linear_model(seated_system(car, load_model("reduced-paper")))
    d = Discretization(lm)
    u = np.zeros((z.shape[0], len(lm.inputs)))
    u[:, 0:8:2], u[:, 1:8:2] = z, v
    du = input_rates(lm, u)
    x, xs = d.zero_state(), []
    for k in range(z.shape[0]):
        xs.append(x)
        x = d.step(x, u[k], du[k], STEP)
    y = np.array(xs) @ lm.C.T + u @ lm.D.T
    return {name: y[:, lm.output_index(name)] for name in ("body.x", "body.theta", "body.phi")}


def test_anti_phase_tracks_move_roll_alone():
    """Right track = - left track, seat on the centreline: bounce and pitch stay zero to
    rounding, roll moves."""
    z, v = half_car_road()
    car = load_car("full-car").with_parameters(seat_y=0.0)
    out = _seated_response(car, four_wheels(z, -1.0), four_wheels(v, -1.0))
    roll = np.max(np.abs(out["body.phi"]))
    assert roll > 1e-3  # rad: several mm of road lift one side against the other
    # rounding of a 14-state exact discretization: ~1e-15 of the motion it carries
    assert np.max(np.abs(out["body.x"])) <= 1e-12
    assert np.max(np.abs(out["body.theta"])) <= 1e-12


def test_seat_offset_adds_the_roll_the_occupant_excites():
    """The shipped seat, 0.37 m left of the centreline, on identical tracks: the occupant's
    force also rolls the body, so the head differs from the half car's by a small amount."""
    body = load_model("reduced-paper")
    z, v = half_car_road()
    half = reference_run(load_car("half-car"), body, z, v, STEP)
    car = load_car("full-car")
    full = reference_run(car, body, four_wheels(z), four_wheels(v), STEP)
    err = nrmse(full["head_acceleration"], half["head_acceleration"])
    # measured 4.2 % NRMSE (r.m.s. 0.45 % lower) on class C at 15 m/s: the seat force
    # at y = 0.37 m rolls the body (3 mrad), which moves the seat point by y phi
    assert 0.02 <= err <= 0.08, err
    # the full car's own rolling: identical tracks roll the body only through the seat
    roll = _seated_response(car, four_wheels(z), four_wheels(v))["body.phi"]
    assert np.max(np.abs(roll)) > 1e-6


def test_full_car_round_trips_through_the_file_format():
    car = load_car("full-car")
    again = network_from_dict(json.loads(json.dumps(network_to_dict(car))))
    np.testing.assert_array_equal(linear_model(again).A, linear_model(car).A)


def test_seat_horizontal_accelerations_follow_pitch_and_roll():
    """seat.ax = -seat_h theta'', seat.ay = -seat_h phi'' (x ahead, y left, roll left up)."""
    lm = linear_model(load_car("full-car"))
    h = load_car("full-car").parameters["seat_h"]
    for out, rot in (("seat.ax", "body.alpha"), ("seat.ay", "body.phi_acceleration")):
        i, j = lm.output_index(out), lm.output_index(rot)
        np.testing.assert_allclose(lm.C[i], -h * lm.C[j], rtol=0, atol=1e-12)
        np.testing.assert_allclose(lm.D[i], -h * lm.D[j], rtol=0, atol=1e-12)


def _anti_roll_car(karf):
    data = full_car_dict()
    data["parameters"].update(karf=karf)
    data["units"]["karf"] = "N.m/rad"
    data["elements"].append(
        {
            "name": "anti_roll_bar_front",
            "kind": "anti_roll_bar",
            "from": "front_left_wheel",
            "to": "front_left",
            "from_right": "front_right_wheel",
            "to_right": "front_right",
            "k": "karf",
            "track": "tf",
        }
    )
    return network_from_dict(data, source="full-car.json")


def test_anti_roll_bar_forces():
    """Forces +-(k/t^2) [(z_bL - z_uL) - (z_bR - z_uR)] on the body points and wheels: the
    stiffness matrix gains exactly that rank-one term, and nothing in bounce."""
    karf = 20000.0
    bar, plain = linear_model(_anti_roll_car(karf)), linear_model(load_car("full-car"))
    car = load_car("full-car")
    p = car.parameters
    k = karf / p["tf"] ** 2
    # the generalized displacement difference d over the states
    states = bar.states
    d = np.zeros(len(states))
    d[states.index("body.phi")] = p["tf"]  # z_bL - z_bR = tf phi
    d[states.index("front_left_wheel.x")] = -1.0
    d[states.index("front_right_wheel.x")] = 1.0
    # force on each degree of freedom: -k d times its generalized direction of d
    masses = {"body.x": p["ms"], "body.theta": p["Iy"], "body.phi": p["Ix"]}
    masses.update({w: p["muf"] for w in ("front_left_wheel.x", "front_right_wheel.x")})
    masses.update({w: p["mur"] for w in ("rear_left_wheel.x", "rear_right_wheel.x")})
    extra = bar.A - plain.A
    n = len(states) // 2
    for name, m in masses.items():
        row = n + states.index(name)
        np.testing.assert_allclose(
            extra[row, :n], -k * d[states.index(name)] * d[:n] / m, atol=1e-9
        )
    assert np.all(extra[:, n:] == 0.0)


def test_anti_roll_bar_needs_its_right_hand_points():
    data = full_car_dict()
    data["parameters"]["karf"] = 1000.0
    data["elements"].append(
        {
            "name": "bar",
            "kind": "anti_roll_bar",
            "from": "front_left_wheel",
            "to": "front_left",
            "k": "karf",
            "track": "tf",
        }
    )
    with pytest.raises(BodyvibError, match="from_right"):
        network_from_dict(data, source="full-car.json")


def test_refuses_a_lateral_point_on_a_body_that_does_not_roll():
    data = full_car_dict()
    del data["bodies"]["body"]["roll_inertia"]
    data["parameters"].pop("Ix")
    with pytest.raises(BodyvibError, match="roll_inertia"):
        network_from_dict(copy.deepcopy(data), source="full-car.json")


# -- the full car on a two-track sine road, co-simulated -----------------------------

SPEED, DURATION = 10.0, 6.0
SHIFT_M = SINE_WAVELENGTH_M / 4  # the right track lags the left by a quarter wave: 90 deg


def sine_slope(x):
    """d/dx of the helpers' sine road."""
    x = np.asarray(x, dtype=float)
    k = 2 * np.pi / SINE_WAVELENGTH_M
    return np.where(x >= 0, SINE_AMPLITUDE_M * k * np.sin(k * x), 0.0)


def hand_written_full_car_with_body(car, body):
    """d/dt of [z, theta, phi, zfl, zfr, zrl, zrr, y, x2, x1, then their rates but y's]
    and the head acceleration: the 7-DOF full car (bounce, pitch, roll, four wheels), the
    reduced body on its seat point (seat spring ks to the massless platform y, k2 || c2 to
    the torso x2, k1 || c1 to the head x1); left track sine(x), right sine(x - SHIFT_M),
    rear wheels a wheelbase behind, written out by hand."""
    p, b = car.parameters, body.parameters
    lf, lr, tf, tr = p["lf"], p["lr"], p["tf"], p["tr"]
    sx, sy = p["seat_x"], p["seat_y"]
    # corners: (x, y, ks, cs, kt, mu, road lag behind the front left wheel's x)
    corners = [
        (lf, tf / 2, p["ksf"], p["csf"], p["ktf"], p["muf"], 0.0),
        (lf, -tf / 2, p["ksf"], p["csf"], p["ktf"], p["muf"], SHIFT_M),
        (-lr, tr / 2, p["ksr"], p["csr"], p["ktr"], p["mur"], lf + lr),
        (-lr, -tr / 2, p["ksr"], p["csr"], p["ktr"], p["mur"], lf + lr + SHIFT_M),
    ]

    def rhs(t, q):
        z, th, ph, *zu = q[:7]
        y, x2, x1 = q[7:10]
        vz, om, pr, *vu = q[10:17]
        v2, v1 = q[17:19]
        s = z + sx * th + sy * ph  # the seat point
        yd, a2, a1, f_seat = reduced_body_on_seat(b, s, y, x2, x1, v2, v1)
        Fz, Mth, Mph = f_seat, sx * f_seat, sy * f_seat
        wheel_acc = []
        for (cx, cy, ks, cs, kt, mu, lag), zw, vw in zip(corners, zu, vu):
            f = ks * (zw - z - cx * th - cy * ph) + cs * (vw - vz - cx * om - cy * pr)
            Fz, Mth, Mph = Fz + f, Mth + cx * f, Mph + cy * f
            wheel_acc.append((-f + kt * (sine_road(SPEED * t - lag) - zw)) / mu)
        acc = [Fz / p["ms"], Mth / p["Iy"], Mph / p["Ix"], *wheel_acc]
        return [vz, om, pr, *vu, yd, v2, v1, *acc, a2, a1], a1

    return rhs


@pytest.mark.integration
def test_cosim_full_car_on_a_phase_shifted_two_track_sine_matches_a_hand_solution(tmp_path):
    """FullCar.fmu (pythonfmu) co-simulated with HumanBody3DOF.fmu on a sine road whose
    right track lags a quarter wave: head acceleration within 0.05 % NRMSE of solve_ivp
    (rtol 1e-10) on the hand-written 7-DOF car and occupant equations."""
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.fmus import build_project_fmu

    car_fmu = build_project_fmu("FullCar", tmp_path / "car")
    body_fmu = build_project_fmu("HumanBody3DOF", tmp_path / "body")
    car = load_car("full-car")
    t = np.arange(0.0, DURATION + STEP / 2, STEP)
    lags = np.array([0.0, SHIFT_M, 2.8, 2.8 + SHIFT_M])
    assert wheel_offsets(car) == (0.0, 0.0, 2.8, 2.8)
    x = SPEED * t[:, None] - lags
    z, v = sine_road(x), SPEED * sine_slope(x)
    with open_fmu(car_fmu, "car", "car") as c, open_fmu(body_fmu, "body", "body") as b:
        run = cosimulate(c, b, z, v, STEP)
    rhs = hand_written_full_car_with_body(car, load_model("reduced-paper"))
    err = nrmse_against_ode(rhs, 19, t, run["head_acceleration"], after=2.0)
    assert err <= 5e-4, f"head acceleration NRMSE {100 * err:.4f} %"
    # the tracks' phase shift rolls the body: the seat's sideways acceleration is there
    assert np.sqrt(np.mean(run["seat_acceleration_y"] ** 2)) > 1e-3


def test_left_wheels_see_the_half_cars_road_and_right_wheels_the_other_track():
    """On class C the left wheels' road is the one-track road a half car drives, the right
    wheels' the correlated second track; a bump lies across both tracks alike."""
    from bodyvib.vehicle.quarter_car import track_width, wheel_sides
    from bodyvib.vehicle.road.tracks import roads_input, wheel_roads

    car = load_car("full-car")
    assert wheel_sides(car) == (1, -1, 1, -1)
    assert track_width(car) == car.parameters["tf"]
    t = np.arange(0.0, 3.0, STEP)
    for spec in ("C", "bump"):
        settings = RunSettings(spec, 15.0, 3.0)
        road = driven_road(settings)
        roads = wheel_roads(settings, road, wheel_sides(car), track_width(car))
        z, v = roads_input(roads, 15.0, t, wheel_offsets(car))
        zh, vh = wheel_inputs(road, 15.0, t, wheel_offsets(load_car("half-car")))
        np.testing.assert_array_equal(z[:, [0, 2]], zh)
        np.testing.assert_array_equal(v[:, [0, 2]], vh)
        same = np.array_equal(z[:, 1], z[:, 0])
        assert same == (spec == "bump")
    # the right track's own rear wheel follows its front one a wheelbase later
    k = int(round(2.8 / 15.0 / STEP))
    assert abs(k * STEP * 15.0 - 2.8) > 1e-9 or np.array_equal(z[k:, 3], z[:-k, 1])


@pytest.mark.integration
def test_cosim_full_car_reports_the_seat_in_three_axes(tmp_path):
    """bodyvib cosim --car full-car: the CSV has the seat's x and y accelerations, the
    JSON their ISO 2631-1 figures as vibration_totals computes them from those columns;
    bodyvib check --car full-car passes."""
    import subprocess
    import sys

    from helpers import read_run_csv

    from bodyvib.comfort import vibration_totals

    out, js = tmp_path / "run.csv", tmp_path / "run.json"
    cmd = [sys.executable, "-m", "bodyvib.cli", "cosim", "--car", "full-car", "--duration", "4"]
    done = subprocess.run(
        cmd + ["--csv", str(out), "--json", str(js), "--quiet"], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    run = read_run_csv(out)
    doc = json.loads(js.read_text())
    assert "two_track_road" in doc["road"]["right_track"]
    body = doc["bodies"]["HumanBody3DOF"]
    axes = {"seat_x": "seat_acceleration_x", "seat_y": "seat_acceleration_y"}
    axes["seat_z"] = "seat_acceleration"
    tot = vibration_totals({k: run[c] for k, c in axes.items()}, 1000.0)
    for a in "xyz":
        assert body[f"seat_aw_{a}"] == pytest.approx(tot.axes[f"seat_{a}"].weighted_rms, rel=1e-6)
    assert body["seat_av"] == pytest.approx(tot.points["seat"], rel=1e-6)
    assert body["seat_aw_y"] > 0.0
    cmd = [sys.executable, "-m", "bodyvib.cli", "check", "--car", "full-car", "--duration", "4"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "verdict: PASS" in done.stdout


@pytest.mark.integration
def test_native_full_car_with_moved_corners_matches_the_reference(tmp_path):
    """The native FullCar.fmu (FMI 2.0 CS, from the same model data) passes fmpy validate
    and, with the track and the seat moved through its parameters, co-simulates a class C
    two-track road within the coupling error of the monolithic reference."""
    from fmpy.validation import validate_fmu
    from helpers import cosim_changed_car

    from bodyvib.vehicle.fmus import build_project_fmu
    from bodyvib.vehicle.quarter_car import track_width, wheel_sides
    from bodyvib.vehicle.road.tracks import roads_input, wheel_roads

    changed = {"tf": 1.6, "tr": 1.6, "seat_y": 0.3, "seat_h": 0.2}
    car = load_car("full-car").with_parameters(**changed)
    body = load_model("reduced-paper")
    native = build_project_fmu("FullCar", tmp_path / "car", native=True, platforms=("linux64",))
    assert validate_fmu(str(native)) == []
    pyfmu = build_project_fmu("HumanBody3DOF", tmp_path / "body")
    speed = 15.0
    settings = RunSettings("C", speed, 3.0)
    roads = wheel_roads(settings, driven_road(settings), wheel_sides(car), track_width(car))
    t = np.arange(0.0, 3.0, STEP)
    z, v = roads_input(roads, speed, t, wheel_offsets(car))
    run, ref = cosim_changed_car(native, pyfmu, changed, car, body, z, v, STEP)
    # the seat's sideways acceleration, -h phi'', within the same coupling error
    assert nrmse(run["seat_acceleration_y"], ref["seat_acceleration_y"]) <= 5e-4
    # the unchanged car differs by far more: the parameters did reach the C assembly
    base = reference_run(load_car("full-car"), body, z, v, STEP)
    assert nrmse(base["seat_acceleration_y"], ref["seat_acceleration_y"]) > 1e-2


def test_batched_sweep_engine_drives_the_full_car_on_two_tracks():
    """The sweep's batched engine gives the monolithic reference's head acceleration of
    the full car driven on the two tracks of a class C road."""
    from bodyvib.vehicle.quarter_car import track_width, wheel_sides
    from bodyvib.vehicle.sweep.engines import case_wheel_inputs, run_batched, run_spectral
    from bodyvib.vehicle.sweep.spec import expand

    spec = {"road": "C", "speed": 15, "duration": 2, "body": "reduced-paper", "car": "full-car"}
    case = expand(spec)[0]
    _, hist = run_batched([case], record=True)
    car = load_car("full-car")
    z, v = case_wheel_inputs(case, wheel_offsets(car), wheel_sides(car), track_width(car))
    assert not np.array_equal(z[:, 0], z[:, 1])  # two tracks
    ref = reference_run(car, load_model("reduced-paper"), z, v, case.step)
    head = hist[0]["head_acceleration"]
    scale = np.max(np.abs(ref["head_acceleration"]))
    np.testing.assert_allclose(head, ref["head_acceleration"], rtol=0, atol=1e-9 * scale)
    # the spectral engine takes the two tracks' cross-spectrum (test_sweep_engines.py)
    row = run_spectral([case])[0]
    assert row["error"] is None and row["seat_aw_y"] > 0


def test_refuses_a_rolling_body_with_every_point_on_its_centreline():
    data = full_car_dict()
    points = data["bodies"]["body"]["points"]
    for name in points:
        points[name] = points[name][0]
    with pytest.raises(BodyvibError, match="roll is not held"):
        network_from_dict(data, source="full-car.json")


def test_frequency_response_of_each_track_adds_to_both_and_anti_phase_rolls_alone():
    """gains choose the bases a frequency response drives: the left wheels' response plus
    the right wheels' is both tracks' together (superposition, to rounding), and tracks in
    anti-phase (gains 1, -1) move neither bounce nor pitch, by the car's left-right
    symmetry, while its roll moves."""
    from bodyvib.frequency import frequency_response
    from bodyvib.runtime.network import linearized

    car = linearized(load_car("full-car"))
    f = np.geomspace(0.3, 30.0, 40)
    delays = [0.0, 0.0, 0.14, 0.14]  # the rear wheels 2.8 m behind at 20 m/s
    names = ["body.x", "body.theta", "body.phi"]
    both = frequency_response(car, f, names, delays=delays)
    left = frequency_response(car, f, names, delays=delays, gains=[1, 0, 1, 0])
    right = frequency_response(car, f, names, delays=delays, gains=[0, 1, 0, 1])
    np.testing.assert_allclose(left + right, both, rtol=1e-12, atol=1e-12 * np.abs(both).max())
    anti = frequency_response(car, f, names, delays=delays, gains=[1, -1, 1, -1])
    assert np.max(np.abs(anti[:2])) <= 1e-12 * np.max(np.abs(both[:2]))
    assert np.min(np.abs(anti[2])) > 0.0
    with pytest.raises(BodyvibError, match="one gain per base"):
        frequency_response(car, f, names, gains=[1.0, 0.0])
