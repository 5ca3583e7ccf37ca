"""The half car: rigid bodies in the model format, the wheelbase delay, the half-car runs.

Independent references: the textbook mass, damping and stiffness matrices of the
bounce-pitch half car written out here by hand; the exact in-phase and
anti-phase wheel inputs of a road whose wavelength is the wheelbase or twice it.
"""

import copy
import json

import numpy as np
import pytest
from bodyvib.vehicle.quarter_car import CAR_DIR, load_car

from bodyvib.frequency.response import frequency_response
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict
from bodyvib.runtime.network import linear_model


def half_car_dict():
    with open(f"{CAR_DIR}/half-car.json", encoding="utf-8") as f:
        return json.load(f)


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
        d["elements"] = [e for e in d["elements"] if not e["name"].startswith("suspension")]

    _refused(edit, "not connected to the road_front or road_rear")


def test_point_positions_take_a_sign():
    data = half_car_dict()
    data["bodies"]["body"]["points"]["rear"] = "lr"  # now ahead of the centre of mass
    flipped = network_from_dict(copy.deepcopy(data))
    assert flipped.body_points["rear"] == ("body", 1.5)
    assert load_car("half-car").body_points["rear"] == ("body", -1.5)
