"""The half car: rigid bodies in the model format, the wheelbase delay, the half-car runs.

Independent references: the textbook mass, damping and stiffness matrices of the
bounce-pitch half car written out here by hand; the exact in-phase and
anti-phase wheel inputs of a road whose wavelength is the wheelbase or twice it;
scipy's solve_ivp (rtol 1e-10) on the hand-written equations of car and occupant
with the rear road delayed by hand; the monolithic reference (exact discretization)
for the native FMU, the sweep engine and the SSP hosts.
"""

import copy
import json

import numpy as np
import pytest
from helpers import (
    car_dict,
    nrmse_against_ode,
    read_run_csv,
    reduced_body_on_seat,
    sine_road,
    write_sine_road,
)

from bodyvib.frequency.response import frequency_response
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import load_car


def half_car_dict():
    return car_dict("half-car")


def textbook_matrices(p):
    """M, C, K, the road input matrix and the seat-force vector of q = [z, theta, zf, zr].

    Small-angle bounce-pitch half car, z up, theta nose up, front axle lf ahead of
    the centre of mass, rear axle lr behind, the seat seat_x ahead.
    """
    ms, Iy, lf, lr = p["ms"], p["Iy"], p["lf"], p["lr"]
    ksf, ksr, csf, csr = p["ksf"], p["ksr"], p["csf"], p["csr"]
    M = np.diag([ms, Iy, p["muf"], p["mur"]])

    def suspension(kf, kr):
        return np.array(
            [
                [kf + kr, kf * lf - kr * lr, -kf, -kr],
                [kf * lf - kr * lr, kf * lf**2 + kr * lr**2, -kf * lf, kr * lr],
                [-kf, -kf * lf, kf, 0.0],
                [-kr, kr * lr, 0.0, kr],
            ]
        )

    K = suspension(ksf, ksr) + np.diag([0.0, 0.0, p["ktf"], p["ktr"]])
    C = suspension(csf, csr)
    road = np.zeros((4, 2))  # forces from the front and rear road displacement
    road[2, 0], road[3, 1] = p["ktf"], p["ktr"]
    seat = np.array([1.0, p["seat_x"], 0.0, 0.0])  # an upward force at the seat point
    return M, C, K, road, seat


def test_state_space_equals_the_textbook_half_car():
    car = load_car("half-car")
    lm = linear_model(car)
    M, C, K, road, seat = textbook_matrices(car.parameters)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((4, 4)), np.eye(4)], [-Minv @ K, -Minv @ C]])
    B = np.zeros((8, 5))
    B[4:, [0, 2]] = Minv @ road
    B[4:, 4] = Minv @ seat
    # the model's state and input order, by name
    q = ["body.x", "body.theta", "front_wheel.x", "rear_wheel.x"]
    qd = ["body.v", "body.omega", "front_wheel.v", "rear_wheel.v"]
    order = [lm.states.index(n) for n in q + qd]
    inputs = ["road_front_displacement", "road_front_velocity", "road_rear_displacement"]
    inputs += ["road_rear_velocity", "seat.force"]
    cols = [lm.inputs.index(n) for n in inputs]
    scale = np.max(np.abs(A))
    np.testing.assert_allclose(lm.A[np.ix_(order, order)], A, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(lm.B[np.ix_(order, cols)], B, rtol=0, atol=1e-12 * scale)
    # the seat point moves z + seat_x theta
    row = lm.C[lm.output_index("seat.x")]
    assert row[lm.states.index("body.x")] == 1.0
    assert row[lm.states.index("body.theta")] == car.parameters["seat_x"]


def symmetric_half_car():
    """The shipped half car made symmetric front to rear: bounce and pitch uncouple."""
    car = load_car("half-car")
    p = car.parameters
    return car.with_parameters(
        lr=p["lf"], ksr=p["ksf"], csr=p["csf"], mur=p["muf"], ktr=p["ktf"], seat_x=1e-6
    )


@pytest.mark.parametrize("speed", [10.0, 25.0])
def test_wheelbase_filtering(speed):
    """A wavelength of one wheelbase moves both wheels together: bounce, no pitch;
    of two wheelbases, in opposition: pitch, no bounce (a symmetric car)."""
    car = symmetric_half_car()
    wheelbase = car.parameters["lf"] + car.parameters["lr"]
    delays = [0.0, wheelbase / speed]
    for wavelength, still, moving in [
        (wheelbase, "body.theta", "body.x"),
        (2 * wheelbase, "body.x", "body.theta"),
    ]:
        f = speed / wavelength
        T = frequency_response(car, [f], [still, moving, "seat.x"], delays=delays)[:, 0]
        scale = abs(T[1]) * (wheelbase if moving == "body.theta" else 1.0)
        assert scale > 1e-3
        # rounding of exp(-2 pi i f tau) and of the solve: far below 1e-9 of the motion
        assert abs(T[0]) * (wheelbase if still == "body.theta" else 1.0) < 1e-9 * scale
    # the seat at the centre of mass does not move on the twice-wheelbase road
    T = frequency_response(car, [speed / (2 * wheelbase)], "seat.x", delays=delays)
    assert abs(T[0]) < 1e-5


def test_frequency_response_needs_one_delay_per_base():
    with pytest.raises(BodyvibError, match="one delay"):
        frequency_response(load_car("half-car"), [1.0], "body.x", delays=[0.0])


def test_half_car_round_trips_through_the_file_format():
    car = load_car("half-car")
    again = network_from_dict(json.loads(json.dumps(network_to_dict(car))))
    for k in "ABCD":
        assert np.array_equal(getattr(linear_model(again), k), getattr(linear_model(car), k))


def _refused(edit, message):
    data = half_car_dict()
    edit(data)
    with pytest.raises(BodyvibError, match=message) as err:
        network_from_dict(data, source="half-car.json")
    assert "\n" not in str(err.value)


def test_refuses_a_point_outside_the_body():
    def edit(d):
        d["parameters"]["seat_x"] = 3.0

    _refused(edit, r"point 'seat' at x = 3 m is outside the body's extent -2.5 to 2.3 m")


def test_refuses_an_element_naming_an_unknown_point():
    def edit(d):
        d["elements"][1]["to"] = "nose"

    _refused(edit, "element 'suspension_front' connects unknown point 'nose'")


def test_refuses_a_body_without_inertia():
    def edit(d):
        del d["bodies"]["body"]["inertia"]

    _refused(edit, r"body 'body': missing field\(s\) inertia")


def test_refuses_a_body_with_one_point():
    def edit(d):
        d["bodies"]["body"]["points"] = {"front": "lf"}

    _refused(edit, "at least two points")


def test_refuses_a_loose_body():
    def edit(d):
        d["elements"] = [
            e for e in d["elements"] if not e["name"].startswith(("suspension", "stops"))
        ]

    _refused(edit, "not connected to the road_front or road_rear")


def test_point_positions_take_a_sign():
    data = half_car_dict()
    points = data["bodies"]["body"]["points"]
    points["rear"], points["front"] = "lr", "-lf"  # the axles swapped: the car turned round
    flipped = network_from_dict(copy.deepcopy(data))
    assert flipped.body_points["rear"] == ("body", 1.5)
    assert flipped.body_points["front"] == ("body", -1.3)
    assert load_car("half-car").body_points["rear"] == ("body", -1.5)


@pytest.mark.parametrize("speed, step", [(10.0, 1e-3), (23.0, 5e-4)])
def test_a_road_pulse_reaches_the_rear_axle_a_wheelbase_later(speed, step):
    """The rear wheel's road: the front's, wheelbase / speed later, to one step."""
    from bodyvib.vehicle.quarter_car import wheel_offsets
    from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs

    car = load_car("half-car")
    behind = wheel_offsets(car)
    wheelbase = car.parameters["lf"] + car.parameters["lr"]
    assert behind == (0.0, wheelbase)
    road = driven_road(RunSettings("bump", speed, 4.0))
    t = np.arange(0.0, 4.0, step)
    z, v = wheel_inputs(road, speed, t, behind)
    first = [int(np.argmax(np.abs(z[:, j]) > 1e-9)) for j in range(2)]
    assert first[0] > 0
    assert abs((first[1] - first[0]) - wheelbase / speed / step) <= 1.0
    # the rear wheel's signal is the front's, shifted: exactly where the shift is whole
    k = int(round(wheelbase / speed / step))
    shift = speed * k * step - wheelbase  # the rear wheel is this far ahead of the sample
    if abs(shift) < 1e-9:
        np.testing.assert_allclose(z[k:, 1], z[:-k, 0], atol=1e-12)
    # before the rear wheel reaches the road's start, level
    assert np.all(z[t * speed < wheelbase, 1] == 0.0)


# -- the half car on a sine road, co-simulated from the command line ------------------

SPEED, DURATION = 10.0, 6.0


def hand_written_half_car_with_body(car, body):
    """d/dt of [z, theta, zf, zr, y, x2, x1, vz, omega, vf, vr, v2, v1] and the head
    acceleration: the half car, the reduced body on its seat point (seat spring ks to the
    massless platform y, k2 || c2 to the torso x2, k1 || c1 to the head x1)."""
    p, b = car.parameters, body.parameters
    ms, Iy, lf, lr, sx = p["ms"], p["Iy"], p["lf"], p["lr"], p["seat_x"]
    wheelbase = lf + lr

    def rhs(t, q):
        z, th, zf, zr, y, x2, x1, vz, om, vf, vr, v2, v1 = q
        rf, rr = sine_road(SPEED * t), sine_road(SPEED * t - wheelbase)
        s = z + sx * th  # the seat point
        yd, a2, a1, f_seat = reduced_body_on_seat(b, s, y, x2, x1, v2, v1)
        f_front = p["ksf"] * (zf - z - lf * th) + p["csf"] * (vf - vz - lf * om)
        f_rear = p["ksr"] * (zr - z + lr * th) + p["csr"] * (vr - vz + lr * om)
        return [
            vz,
            om,
            vf,
            vr,
            yd,
            v2,
            v1,
            (f_front + f_rear + f_seat) / ms,
            (lf * f_front - lr * f_rear + sx * f_seat) / Iy,
            (-f_front + p["ktf"] * (rf - zf)) / p["muf"],
            (-f_rear + p["ktr"] * (rr - zr)) / p["mur"],
            a2,
            a1,
        ], a1

    return rhs


@pytest.mark.integration
def test_cosim_half_car_on_a_sine_road_matches_an_independent_solution(tmp_path):
    """bodyvib cosim --car half-car: head acceleration within the coupling error of
    solve_ivp (rtol 1e-10) on the hand-written equations, rear road delayed by hand."""
    import subprocess
    import sys

    from bodyvib.models import load_model

    road = write_sine_road(tmp_path / "sine.csv", SPEED * DURATION + 5.0)
    out, js = tmp_path / "run.csv", tmp_path / "run.json"
    cmd = [sys.executable, "-m", "bodyvib.cli", "cosim", "--car", "half-car"]
    cmd += ["--road", str(road), "--road-taper", "0", "--speed", str(SPEED)]
    cmd += ["--duration", str(DURATION), "--step", "0.001", "--csv", str(out), "--quiet"]
    done = subprocess.run(cmd + ["--json", str(js)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    run = read_run_csv(out)
    car = load_car("half-car")
    rhs = hand_written_half_car_with_body(car, load_model("reduced-paper"))
    # after the start-up transient
    err = nrmse_against_ode(rhs, 13, run["time"], run["head_acceleration"], after=2.0)
    assert err <= 5e-4, f"head acceleration NRMSE {100 * err:.4f} %"
    # the seat's forward acceleration: -h times the hand-written pitch acceleration
    h = car.parameters["seat_h"]

    def seat_x(t, q):
        dq, _ = rhs(t, q)
        return dq, -h * dq[8]

    err = nrmse_against_ode(seat_x, 13, run["time"], run["seat_acceleration_x"], after=2.0)
    assert err <= 5e-4, f"seat x acceleration NRMSE {100 * err:.4f} %"
    assert np.all(run["seat_acceleration_y"] == 0.0)  # the half car does not roll
    _check_seat_figures(json.loads(js.read_text())["bodies"]["HumanBody3DOF"], run, h)


def _check_seat_figures(body, run, h):
    """The run's seat figures are ISO 2631-1's of its CSV columns, the pitch -a_x / h."""
    from bodyvib.comfort import vibration_totals

    x, z = run["seat_acceleration_x"], run["seat_acceleration"]
    tot = vibration_totals({"seat_x": x, "seat_z": z, "seat_ry": -x / h}, 1000.0)
    assert body["seat_aw_x"] == pytest.approx(tot.axes["seat_x"].weighted_rms, rel=1e-6)
    assert body["seat_aw_ry"] == pytest.approx(tot.axes["seat_ry"].weighted_rms, rel=1e-6)
    assert body["seat_aw_y"] == 0.0 and "seat_aw_rx" not in body
    assert body["seat_av"] == pytest.approx(tot.points["seat"], rel=1e-6)
    assert body["seat_rotation_av"] == pytest.approx(0.4 * body["seat_aw_ry"], rel=1e-12)


def test_batched_sweep_engine_sums_the_wheels_as_the_reference_drives_them():
    """The sweep's batched engine (one state, each road point's input columns added) gives the
    monolithic reference's head acceleration of the half car driven at both wheels."""
    from bodyvib.models import load_model
    from bodyvib.vehicle.quarter_car import wheel_offsets
    from bodyvib.vehicle.reference import reference_run
    from bodyvib.vehicle.sweep.engines import case_wheel_inputs, run_batched
    from bodyvib.vehicle.sweep.spec import expand

    case = expand(
        {"road": "C", "speed": 15, "duration": 2, "body": "reduced-paper", "car": "half-car"}
    )[0]
    _, hist = run_batched([case], record=True)
    car = load_car("half-car")
    z, v = case_wheel_inputs(case, wheel_offsets(car))
    assert np.any(z[:, 1] != 0.0)
    ref = reference_run(car, load_model("reduced-paper"), z, v, case.step)
    head = hist[0]["head_acceleration"]
    scale = np.max(np.abs(ref["head_acceleration"]))
    np.testing.assert_allclose(head, ref["head_acceleration"], rtol=0, atol=1e-9 * scale)


@pytest.mark.integration
def test_native_half_car_with_moved_axles_matches_the_reference(tmp_path):
    """The native HalfCar.fmu assembles the products of positions and stiffnesses: with
    lf, lr and seat_x changed through its parameters it co-simulates within the coupling
    error of the reference of the changed model."""
    from helpers import cosim_changed_car

    from bodyvib.models import load_model
    from bodyvib.vehicle.fmus import build_project_fmu
    from bodyvib.vehicle.quarter_car import wheel_offsets
    from bodyvib.vehicle.reference import nrmse, reference_run
    from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs

    changed = {"lf": 1.1, "lr": 1.7, "seat_x": 0.4}
    car = load_car("half-car").with_parameters(**changed)
    body = load_model("reduced-paper")
    native = build_project_fmu("HalfCar", tmp_path / "car", native=True, platforms=("linux64",))
    pyfmu = build_project_fmu("HumanBody3DOF", tmp_path / "body")
    step, speed = 1e-3, 15.0
    t = np.arange(0.0, 3.0, step)
    z, v = wheel_inputs(driven_road(RunSettings("C", speed, 3.0)), speed, t, wheel_offsets(car))
    assert wheel_offsets(car) == (0.0, 2.8)
    _, ref = cosim_changed_car(native, pyfmu, changed, car, body, z, v, step)
    # the unchanged car differs by far more: the parameters did reach the C assembly
    base = reference_run(load_car("half-car"), body, z, v, step)
    assert nrmse(base["head_acceleration"], ref["head_acceleration"]) > 1e-2


@pytest.mark.integration
@pytest.mark.parametrize("host", ["fmpy.ssp", "libcosim", "ecos"])
def test_half_car_ssp_runs_in_ssp_hosts(tmp_path, host):
    """bodyvib build writes HalfCarWithOccupant.ssp (RoadFrontRear -> HalfCar <-> body);
    fmpy's SSP runner, libcosim and Ecos run it within the target of the quarter car's
    package (0.06 % head-acceleration NRMSE at 1 ms) of the monolithic reference on the
    road table the package carries."""
    import subprocess
    import sys

    from test_ssp import HOSTS, TARGET, host_run

    from bodyvib.vehicle.reference import nrmse
    from bodyvib.vehicle.ssp import HALF_CAR_SSP_NAME, ssp_reference

    if host == "ecos":
        pytest.importorskip("ecospy")
    names = ["HalfCar", "RoadFrontRear", "HumanBody3DOF"]
    cmd = [sys.executable, "-m", "bodyvib.cli", "build", "--dest", str(tmp_path), "--fmus"]
    done = subprocess.run(cmd + names, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert f"{HALF_CAR_SSP_NAME}.ssp (RoadFrontRear -> HalfCar <-> HumanBody3DOF" in done.stdout
    signals = [["Body", "head_acceleration"], ["Road", "road_displacement_rear"]]
    kwargs = {
        "libcosim": {"signals": signals},
        "ecos": {"signals": signals, "parameter_set": HALF_CAR_SSP_NAME},
    }.get(host, {})
    res, _ = host_run(HOSTS[host], tmp_path / f"{HALF_CAR_SSP_NAME}.ssp", duration=3.0, **kwargs)
    ref = ssp_reference(3.0, 1e-3, car="half-car")
    head = res["Body.head_acceleration"]
    assert head.size == ref["head_acceleration"].size
    assert nrmse(head, ref["head_acceleration"]) <= TARGET


def test_cosim_help_names_the_cars_it_drives():
    """``bodyvib cosim`` drives any shipped car; its help once said "quarter-car" alone."""
    import argparse

    from bodyvib.cli.main import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    listed = next(c for c in sub._choices_actions if c.dest == "cosim").help
    description = sub.choices["cosim"].description
    assert "quarter-car" not in listed and "a car" in listed
    assert "half-car" in description and "quarter car" in description
