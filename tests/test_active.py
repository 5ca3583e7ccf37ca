"""Actuators in car files, the skyhook/groundhook law and the controlled co-simulation.

Independent references: the textbook mass, damping and stiffness matrices of the
two-mass quarter car written out here by hand (a skyhook gain is a damper from the
body to the sky, a groundhook gain one from the wheel to the ground whose reaction
acts on the body); the static closed form of a constant actuator force (the
suspension extends by F / ks, the tire force is unchanged); the monolithic closed
loop (exact discretization of the closed-loop matrices) for the co-simulation.
"""

import copy

import numpy as np
import pytest
from helpers import car_dict

from bodyvib.runtime.contract import fmu_variables
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.control import (
    SkyhookController,
    closed_loop_model,
    default_gains,
    parse_control,
    skyhook,
)
from bodyvib.vehicle.quarter_car import load_car


def active_dict():
    return car_dict("quarter-car-active")


def textbook(p, c_sky=0.0, c_ground=0.0):
    """State matrix of [xs, xu, vs, vu] with a skyhook and groundhook force F = -c_sky vs +
    c_ground vu pushing sprung up and unsprung down."""
    M = np.diag([p["ms"], p["mu"]])
    K = np.array([[p["ks"], -p["ks"]], [-p["ks"], p["ks"] + p["kt"]]])
    C = np.array([[p["cs"], -p["cs"]], [-p["cs"], p["cs"]]])
    C = C + np.array([[c_sky, -c_ground], [-c_sky, c_ground]])
    Mi = np.linalg.inv(M)
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ K, -Mi @ C]])


def in_textbook_order(lm):
    order = [lm.states.index(s) for s in ("sprung.x", "unsprung.x", "sprung.v", "unsprung.v")]
    return lm.A[np.ix_(order, order)]


def test_actuator_is_the_fmu_input_with_the_stated_sign():
    """A constant actuator force F extends the suspension by F / ks and leaves the tire
    force unchanged (static equilibrium of the two masses, by hand)."""
    car = load_car("quarter-car-active")
    iface, _, _ = fmu_variables("car", car)
    names = [v.name for v in iface.inputs]
    assert names[-2:] == ["actuator_force", "actuator_force_rate"]
    lm = linear_model(car)
    col = names.index("actuator_force")
    static = (
        -lm.C @ np.linalg.solve(lm.A, lm.B @ iface.input_map[:, col])
        + lm.D @ (iface.input_map[:, col])
    )
    F, ks = 1.0, car.parameters["ks"]
    assert static[lm.output_index("suspension.deflection")] == pytest.approx(F / ks, rel=1e-12)
    assert static[lm.output_index("sprung.x")] == pytest.approx(F / ks, rel=1e-12)
    assert abs(static[lm.output_index("tire.force")]) < 1e-12


def test_active_file_is_the_passive_car_with_the_actuator_idle():
    """Same values, elements (tire contact, stops), states, road and seat columns: with no
    actuator force, the passive car; linearized, the linearized passive car."""
    passive, active = load_car("quarter-car"), load_car("quarter-car-active")
    assert active.parameters == passive.parameters
    assert active.elements == passive.elements and active.static_loads == passive.static_loads
    lin = (load_car("quarter-car", linear=True), load_car("quarter-car-active", linear=True))
    np.testing.assert_array_equal(linear_model(lin[0]).A, linear_model(lin[1]).A)
    lp, la = linear_model(passive), linear_model(active)
    assert lp.states == la.states and lp.outputs == la.outputs
    np.testing.assert_array_equal(lp.A, la.A)
    ip, ia = fmu_variables("car", passive)[0], fmu_variables("car", active)[0]
    n = len(ip.inputs)
    np.testing.assert_array_equal(lp.B @ ip.input_map, (la.B @ ia.input_map)[:, :n])
    assert [v.name for v in ia.outputs][: len(ip.outputs)] == [v.name for v in ip.outputs]


@pytest.mark.parametrize("c_sky, c_ground", [(4000.0, 0.0), (0.0, 6000.0), (3000.0, 2000.0)])
def test_closed_loop_equals_the_textbook_dampers(c_sky, c_ground):
    car = load_car("quarter-car-active")
    law = SkyhookController(c_sky=c_sky, c_ground=c_ground)
    closed, forces = closed_loop_model(linear_model(car), car, law)
    np.testing.assert_allclose(
        in_textbook_order(closed), textbook(car.parameters, c_sky, c_ground), rtol=1e-12, atol=1e-9
    )
    vs, vu = closed.states.index("sprung.v"), closed.states.index("unsprung.v")
    assert forces[0, vs] == -c_sky and forces[0, vu] == c_ground


def test_half_car_actuators_act_at_their_axles():
    """A front actuator force F adds F at the front point: F to the bounce equation, lf F
    to the pitch equation, -F to the front wheel (the half car's small-angle rule)."""
    car = load_car("half-car-active")
    iface, _, _ = fmu_variables("car", car)
    names = [v.name for v in iface.inputs]
    lm = linear_model(car)
    p = car.parameters
    for axle, x, wheel in (("front", p["lf"], "front_wheel"), ("rear", -p["lr"], "rear_wheel")):
        b = lm.B @ iface.input_map[:, names.index(f"actuator_force_{axle}")]
        assert b[lm.states.index("body.v")] == pytest.approx(1 / p["ms"], rel=1e-12)
        assert b[lm.states.index("body.omega")] == pytest.approx(x / p["Iy"], rel=1e-12)
        mu = p["muf"] if axle == "front" else p["mur"]
        assert b[lm.states.index(f"{wheel}.v")] == pytest.approx(-1 / mu, rel=1e-12)
    outs = [v.name for v in iface.outputs]
    assert outs[-8:] == [
        f"actuator_{point}_{q}_{axle}"
        for axle in ("front", "rear")
        for q in ("velocity", "acceleration")
        for point in ("upper", "lower")
    ]


@pytest.mark.parametrize("text", ["skyhook", "groundhook", "hybrid"])
def test_centreline_active_full_car_on_identical_tracks_is_the_active_half_car(text):
    """full-car-active with its seat on the centreline, identical left and right tracks and
    each law at its default gains (the body's critical damping and the passive damper
    shared by four actuators instead of two, so each corner's gain is half its axle's):
    the head acceleration of the active half car to 1e-9 of its peak (both exact closed
    loops; measured 2e-13 to 4e-13)."""
    from test_full_car import four_wheels, half_car_road

    from bodyvib.models import load_model
    from bodyvib.vehicle.reference import reference_run

    body, (z, v) = load_model("reduced-paper"), half_car_road()
    half = load_car("half-car-active")
    full = load_car("full-car-active").with_parameters(seat_y=0.0)
    law_half, law_full = parse_control(text, half), parse_control(text, full)
    assert law_full.c_sky == law_half.c_sky / 2 and law_full.c_ground == law_half.c_ground / 2
    a = reference_run(half, body, z, v, 1e-3, controller=law_half)["head_acceleration"]
    b = reference_run(full, body, four_wheels(z), four_wheels(v), 1e-3, controller=law_full)
    scale = np.max(np.abs(a))
    assert scale > 0.1
    assert np.max(np.abs(b["head_acceleration"] - a)) <= 1e-9 * scale


def test_actuators_round_trip_through_the_file_format():
    net = network_from_dict(active_dict())
    assert network_from_dict(network_to_dict(net)) == net


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda d: d.update(force_inputs=["sprung"]), "'unsprung' takes no force"),
        (lambda d: d["actuators"][0].update({"from": "sprung"}), "are the same point"),
        (lambda d: d["actuators"].append(dict(d["actuators"][0])), "used twice"),
        (lambda d: d["actuators"][0].update(name="front axle"), "plain name"),
        (lambda d: d["actuators"][0].pop("to"), "exactly the fields"),
        (lambda d: d.update(actuators={}), "must be a list"),
    ],
)
def test_bad_actuators_are_refused(change, message):
    data = copy.deepcopy(active_dict())
    change(data)
    with pytest.raises(BodyvibError, match=message):
        network_from_dict(data)


def test_skyhook_law_and_its_semi_active_clipping():
    vu, vl = np.array([0.1, 0.1, -0.2]), np.array([0.0, 0.3, 0.1])
    np.testing.assert_array_equal(skyhook(vu, vl, 1000.0, 500.0), -1000.0 * vu + 500.0 * vl)
    # a damper's force opposes the relative velocity: F (vu - vl) <= 0, else 0
    semi = skyhook(vu, vl, 1000.0, semi_active=True)
    np.testing.assert_array_equal(semi, [-100.0, 0.0, 200.0])


def test_default_gains_are_the_body_critical_damping_and_the_passive_damper():
    p = load_car("quarter-car-active").parameters
    c_sky, c_ground = default_gains(load_car("quarter-car-active"))
    assert c_sky == pytest.approx(2 * np.sqrt(p["ks"] * p["ms"]), rel=1e-12)
    assert c_ground == pytest.approx(p["cs"], rel=1e-12)
    h = load_car("half-car-active").parameters
    c_sky, _ = default_gains(load_car("half-car-active"))
    assert c_sky == pytest.approx(np.sqrt((h["ksf"] + h["ksr"]) * h["ms"]), rel=1e-12)


@pytest.mark.parametrize(
    "text, car, message",
    [
        ("fuzzy", "quarter-car-active", "unknown controller 'fuzzy'"),
        ("skyhook:c=-5", "quarter-car-active", "must be a finite number >= 0"),
        ("skyhook:c=abc", "quarter-car-active", "is not a number"),
        ("skyhook:k=5", "quarter-car-active", "not understood"),
        ("skyhook", "quarter-car", "has no actuators"),
    ],
)
def test_bad_controllers_are_refused(text, car, message):
    with pytest.raises(BodyvibError, match=message):
        parse_control(text, load_car(car))


def test_parse_control_defaults_and_options():
    car = load_car("quarter-car-active")
    c_sky, c_ground = default_gains(car)
    assert parse_control("skyhook", car) == SkyhookController(c_sky=c_sky)
    assert parse_control("groundhook:semi", car) == SkyhookController(
        c_ground=c_ground, semi_active=True
    )
    assert parse_control("hybrid:c=1,g=2", car) == SkyhookController(1.0, 2.0)


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--control", "skyhook"], ["car 'quarter-car' has no actuators", "quarter-car-active"]),
        (["--car", "quarter-car-active", "--control", "pid"], ["unknown controller 'pid'"]),
        (["--car", "quarter-car-active", "--control", "skyhook:c=-1"], ["c_sky", ">= 0"]),
        (["--car", "half-car", "--control", "groundhook"], ["car 'half-car' has no actuators"]),
    ],
)
def test_cli_refuses_a_bad_controller_in_one_line(capsys, argv, words):
    """Refused before any FMU is built: status 2, one line, no traceback."""
    from bodyvib.cli.main import main

    status = main(["cosim", "--quiet", *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    assert err[0].startswith("bodyvib cosim: error:")
    for w in words:
        assert w in err[0]


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--control", "skyhook:c=x"], ["bodyvib build: error:", "is not a number"]),
        (["--control", "skyhook", "--fmus", "Road"], ["drop --fmus and --params"]),
        (["--control", "skyhook", "--car", "half-car"], ["'half-car' has no actuators"]),
        (["--car", "half-car-active"], ["use it with --control"]),
        (["control", "--laws", "passive;semi:c=1"], ["unknown controller 'semi'"]),
    ],
)
def test_build_and_control_refuse_bad_laws_in_one_line(capsys, tmp_path, argv, words):
    from bodyvib.cli.main import main

    argv = argv if argv[0] == "control" else ["build", "--dest", str(tmp_path / "d"), *argv]
    status = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1, err
    for w in words:
        assert w in err[0]
    assert not (tmp_path / "d").exists()


# -- the FMUs and the controlled co-simulation ------------------------------------------


@pytest.fixture(scope="module")
def active_fmus(tmp_path_factory):
    """Native FMI 2.0 FMUs: the active and the passive quarter car, the active one
    linearized (``--linear``), the reduced body."""
    from bodyvib.vehicle.fmus import build_project_fmu, linear_car_file

    out = {}
    linear = linear_car_file("quarter-car-active", str(tmp_path_factory.mktemp("car-file")))
    for key, name, model in (
        ("active", "QuarterCar", "quarter-car-active"),
        ("passive", "QuarterCar", "quarter-car"),
        ("linear", "QuarterCar", linear),
        ("body", "HumanBody3DOF", None),
    ):
        dest = tmp_path_factory.mktemp(key)
        out[key] = str(build_project_fmu(name, dest, model, native=True, platforms=("linux64",)))
    return out


def class_c_road(car, seconds, h=1e-3):
    from bodyvib.vehicle.quarter_car import wheel_offsets
    from bodyvib.vehicle.road.driven import RunSettings, driven_road, wheel_inputs

    t = np.arange(int(round(seconds / h)) + 1) * h
    road = driven_road(RunSettings("C", 20.0, seconds, h))
    z, v = wheel_inputs(road, 20.0, t, wheel_offsets(car))
    return t, z[:, 0], v[:, 0]


@pytest.fixture(scope="module")
def every_kind(tmp_path_factory):
    """The active quarter car as pythonfmu FMI 2.0 (built in a subprocess, as a user builds
    it), native FMI 2.0 and native FMI 3.0."""
    import subprocess
    import sys

    from helpers import ROOT

    from bodyvib.vehicle.fmus import build_project_fmu

    out = {}
    dest = tmp_path_factory.mktemp("pythonfmu")
    code = (
        "import sys; from bodyvib.vehicle.fmus import build_project_fmu; "
        "build_project_fmu('QuarterCar', sys.argv[1], 'quarter-car-active')"
    )
    subprocess.run([sys.executable, "-c", code, str(dest)], check=True, cwd=ROOT, timeout=600)
    out["pythonfmu"] = str(dest / "QuarterCar.fmu")
    for fmi in (2, 3):
        dest = tmp_path_factory.mktemp(f"native{fmi}")
        path = build_project_fmu(
            "QuarterCar", dest, "quarter-car-active", native=True, fmi=fmi, platforms=("linux64",)
        )
        out[f"native-fmi{fmi}"] = str(path)
    return out


@pytest.mark.integration
@pytest.mark.parametrize("kind", ["pythonfmu", "native-fmi2", "native-fmi3"])
def test_active_fmu_validates_and_holds_a_constant_force(every_kind, kind):
    """fmpy validate finds nothing; a constant actuator force of 1 kN on the level road
    settles (body mode damping ratio 0.23 at 1.2 Hz: e^-17 after 10 s) at the static
    closed form, suspension extended by F / ks, tire force 0."""
    from fmpy import simulate_fmu
    from fmpy.validation import validate_fmu

    path = every_kind[kind]
    assert validate_fmu(path) == []
    r = simulate_fmu(
        path,
        stop_time=10.0,
        output_interval=1e-3,
        start_values={"actuator_force": 1000.0},
        output=["suspension_deflection", "tire_force", "seat_displacement"],
    )
    ks = load_car("quarter-car-active").parameters["ks"]
    assert r["suspension_deflection"][-1] == pytest.approx(1000.0 / ks, rel=1e-6)
    assert r["seat_displacement"][-1] == pytest.approx(1000.0 / ks, rel=1e-6)
    assert abs(r["tire_force"][-1]) < 1e-6 * 1000.0


@pytest.mark.integration
@pytest.mark.parametrize(
    "name, fmu, measured",
    [("half-car-active", "HalfCar", 0.031), ("full-car-active", "FullCar", 0.0)],
)
def test_controlled_half_and_full_cars_meet_the_coupling_target(tmp_path, name, fmu, measured):
    """The half car's two actuators and the full car's four (on the two-track class C
    road its run drives) under the default skyhook law, native FMUs at 1 ms, against the
    exact closed loop: head NRMSE <= 0.05 % after 2 s (measured 0.031 % and 0.029 %)."""
    from bodyvib.models import load_model
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.fmus import build_project_fmu
    from bodyvib.vehicle.quarter_car import wheel_offsets, wheel_sides
    from bodyvib.vehicle.reference import nrmse, reference_run
    from bodyvib.vehicle.road.driven import RunSettings, driven_road
    from bodyvib.vehicle.road.tracks import roads_input, wheel_roads

    car = load_car(name)
    native = {"native": True, "platforms": ("linux64",)}
    car_fmu = build_project_fmu(fmu, tmp_path, name, **native)
    body_fmu = build_project_fmu("HumanBody3DOF", tmp_path, **native)
    t = np.arange(10001) * 1e-3
    settings = RunSettings("C", 20.0, 10.0)
    roads = wheel_roads(settings, driven_road(settings), wheel_sides(car), 1.5)
    z, v = roads_input(roads, 20.0, t, wheel_offsets(car))
    if fmu == "FullCar":  # the left and right tracks differ
        assert np.max(np.abs(z[:, 0] - z[:, 1])) > 1e-3
    law = parse_control("skyhook", car)
    with open_fmu(car_fmu, "car") as c, open_fmu(body_fmu, "body") as b:
        run = cosimulate(c, b, z, v, 1e-3, controller=law)
    ref = reference_run(car, load_model("reduced-paper"), z, v, 1e-3, controller=law)
    late = t > 2.0
    err = nrmse(run["head_acceleration"][late], ref["head_acceleration"][late])
    print(f"{name}: head NRMSE {err:.3%}")
    assert err <= 5e-4


@pytest.mark.integration
def test_idle_actuator_gives_the_passive_car(active_fmus):
    """The same road through both native FMUs, actuator force left at 0: the outputs the
    two share are the same numbers, bit for bit."""
    from bodyvib.vehicle.cosim import cosimulate, open_fmu

    car = load_car("quarter-car")
    _, z, v = class_c_road(car, 3.0)
    runs = {}
    for key in ("passive", "active"):
        with open_fmu(active_fmus[key], "car") as c, open_fmu(active_fmus["body"], "body") as b:
            runs[key] = cosimulate(c, b, z, v, 1e-3)
    for name in ("head_acceleration", "tire_force", "suspension_deflection"):
        np.testing.assert_array_equal(runs["active"][name], runs["passive"][name], err_msg=name)


@pytest.mark.integration
@pytest.mark.parametrize("law", ["skyhook", "groundhook", "hybrid"])
def test_controlled_cosimulation_meets_the_coupling_target(active_fmus, law):
    """Skyhook car co-simulated (native FMUs, 1 ms) against the exact discretization of
    the same closed loop: head-acceleration NRMSE <= 0.05 % after the first 2 s (the
    road fades in over 5 m, 0.25 s). Measured: 0.025 % skyhook, 0.035 %
    groundhook, 0.031 % hybrid."""
    from bodyvib.models import load_model
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.reference import nrmse, reference_run

    car = load_car("quarter-car-active")
    controller = parse_control(law, car)
    t, z, v = class_c_road(car, 10.0)
    with open_fmu(active_fmus["active"], "car") as c, open_fmu(active_fmus["body"], "body") as b:
        run = cosimulate(c, b, z, v, 1e-3, controller=controller)
    ref = reference_run(car, load_model("reduced-paper"), z, v, 1e-3, controller=controller)
    late = t > 2.0
    err = nrmse(run["head_acceleration"][late], ref["head_acceleration"][late])
    assert err <= 5e-4
    # the controller acts: the skyhook lowers the head acceleration against the passive car
    passive = reference_run(load_car("quarter-car"), load_model("reduced-paper"), z, v, 1e-3)
    if law == "skyhook":
        assert np.std(ref["head_acceleration"][late]) < np.std(passive["head_acceleration"][late])


@pytest.mark.integration
@pytest.mark.parametrize("law", ["skyhook", "groundhook", "hybrid"])
def test_coupling_bound_on_the_gains_is_where_the_cosimulation_diverges(active_fmus, law):
    """``cosim --control skyhook:c=1e6`` stopped on a step the FMUs discard, with no word on
    why: :func:`check_coupling` refuses gains that change the velocities they read by more
    than MAX_STEP_GAIN (0.4) of themselves in a step. The bound is where it matters: at 0.95
    of it the co-simulation still follows the exact closed loop (head NRMSE after 2 s
    measured 0.04 % for the skyhook and the hybrid law, 0.17 % for the groundhook, whose
    coupling error grows with its gain from 0.04 % at the default; 0.25 % allowed), at 1.5
    times it diverges. The bound is the linear loop's: on the linear active car (at these
    gains the car with contacts and stops lifts its wheel and meets its stops every few
    tenths of a second, each event a coupling error of its own: 0.77 % for the skyhook)."""
    import dataclasses
    import warnings

    from bodyvib.models import load_model
    from bodyvib.vehicle.control import MAX_STEP_GAIN, check_coupling, step_gain
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.events import LinearRangeWarning
    from bodyvib.vehicle.reference import nrmse, reference_run

    car = load_car("quarter-car-active")
    base = parse_control(law, car)
    t, z, v = class_c_road(car, 5.0)
    late = t > 2.0
    for factor in (0.95, 1.5):
        s = factor * MAX_STEP_GAIN / step_gain(base, car, 1e-3)
        law_at = dataclasses.replace(base, c_sky=s * base.c_sky, c_ground=s * base.c_ground)
        if factor > 1:
            with pytest.raises(BodyvibError, match="diverges from about 0.5"):
                check_coupling(law_at, car, 1e-3)
        else:
            check_coupling(law_at, car, 1e-3)
        with open_fmu(active_fmus["linear"], "car") as c:
            with open_fmu(active_fmus["body"], "body") as b:
                try:
                    run = cosimulate(c, b, z, v, 1e-3, controller=law_at)
                except BodyvibError as exc:  # a step the FMUs discard
                    assert factor > 1, exc
                    continue
        body = load_model("reduced-paper")
        with warnings.catch_warnings():  # at these gains the linear car leaves its range
            warnings.simplefilter("ignore", LinearRangeWarning)
            ref = reference_run(car, body, z, v, 1e-3, controller=law_at, linear=True)
        err = nrmse(run["head_acceleration"][late], ref["head_acceleration"][late])
        assert err <= 2.5e-3 if factor < 1 else err > 1.0, (factor, err)


@pytest.mark.integration
def test_controller_on_a_passive_car_fmu_is_refused(active_fmus):
    from bodyvib.vehicle.cosim import Master, open_fmu

    with open_fmu(active_fmus["passive"], "car") as c, open_fmu(active_fmus["body"], "body") as b:
        with pytest.raises(BodyvibError, match="has no actuator inputs"):
            Master(c, b, 1e-3, 10, controller=SkyhookController(c_sky=1000.0))


def test_law_comparison_matches_the_reference_runs():
    """The comparison's passive row against the monolithic reference of the passive car
    (another path: the car file's FMU outputs), and the skyhook row's actuator force
    against c_sky times the body velocity of the closed-loop reference."""
    from bodyvib.comfort.figures import weighted_rms
    from bodyvib.models import load_model
    from bodyvib.vehicle.active import compare_laws, format_comparison
    from bodyvib.vehicle.reference import ReferenceStream, reference_run
    from bodyvib.vehicle.road.driven import RunSettings

    car, body = load_car("quarter-car-active"), load_model("reduced-paper")
    settings = RunSettings("C", 20.0, 4.0)
    c = compare_laws(car, body, settings, ["passive", "skyhook:c=3000"])
    t, z, v = class_c_road(car, 4.0)
    ref = reference_run(load_car("quarter-car"), body, z, v, 1e-3)
    passive, sky = c.laws
    assert passive.head_wk_rms == pytest.approx(
        weighted_rms(ref["head_acceleration"], 1e3), rel=1e-9
    )
    assert passive.tire_force_rms == pytest.approx(np.sqrt(np.mean(ref["tire_force"] ** 2)), 1e-9)
    travel = np.sqrt(np.mean(ref["suspension_deflection"] ** 2))
    assert passive.suspension_travel_rms == pytest.approx(travel, rel=1e-9)
    assert passive.actuator_force_rms == 0.0
    stream = ReferenceStream(car, body, 1e-3, sky.controller).advance(z, v)
    force = -3000.0 * stream["seat_velocity"]  # the quarter car's seat is its sprung mass
    np.testing.assert_allclose(stream["actuator_force"], force, rtol=1e-12, atol=1e-9)
    assert sky.actuator_force_rms == pytest.approx(np.sqrt(np.mean(force**2)), rel=1e-9)
    assert "skyhook:c=3000" in format_comparison(c)


# -- the controller FMU --------------------------------------------------------------


@pytest.fixture(scope="module")
def controller_fmu(tmp_path_factory):
    from bodyvib.fmu.controller import build_controller_fmu

    dest = tmp_path_factory.mktemp("controller")
    return str(build_controller_fmu(dest, ("",), 4000.0, 1500.0, platforms=("linux64",)))


@pytest.mark.integration
def test_controller_fmu_validates_and_runs_in_a_c_host(controller_fmu, tmp_path):
    """fmpy validate finds nothing; tests/c_host/native_host.c (no Python in its process)
    feeds its chirp x, v as upper and lower velocity (accelerations left at 0): the force
    is -c_sky x + c_ground v, the same double operations, so exactly."""
    import subprocess
    import zipfile

    import fmpy
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu
    from helpers import ROOT

    assert validate_fmu(controller_fmu) == []
    exe = str(tmp_path / "native_host")
    headers = f"{fmpy.__path__[0]}/c-code"
    source = f"{ROOT}/tests/c_host/native_host.c"
    build = ["gcc", "-std=c99", "-O2", "-I", headers, source, "-o", exe, "-ldl", "-lm"]
    subprocess.run(build + ["-lpthread"], check=True, capture_output=True, timeout=120)
    with zipfile.ZipFile(controller_fmu) as z:
        z.extractall(tmp_path / "fmu")
    md = read_model_description(controller_fmu)
    binary = str(tmp_path / "fmu" / "binaries" / "linux64" / "SkyhookController.so")
    run = subprocess.run(
        [exe, "run", binary, md.guid, "0,1", "4", "0.001", "500"],
        capture_output=True,
        text=True,
        timeout=120,
        env={},
    )
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    assert lines[0] == "libpython absent" and lines[-1] == "ok"
    rows = np.array([[float(f) for f in line.split()] for line in lines[1:-1]])
    x, v, force = rows[:, 2], rows[:, 3], rows[:, 4]
    assert np.any(force != 0.0)
    np.testing.assert_array_equal(force, -4000.0 * x + 1500.0 * v)


@pytest.mark.integration
def test_controller_fmu_in_the_master_equals_the_library_law(active_fmus, controller_fmu):
    """The same hybrid law as an FMU (C) and as SkyhookController (numpy): the same run,
    bit for bit."""
    from bodyvib.vehicle.cosim import cosimulate, open_controller, open_fmu

    car = load_car("quarter-car-active")
    _, z, v = class_c_road(car, 2.0)
    runs = []
    with open_fmu(active_fmus["active"], "car") as c, open_fmu(active_fmus["body"], "body") as b:
        with open_controller(controller_fmu, c) as law:
            runs.append(cosimulate(c, b, z, v, 1e-3, controller=law))
    with open_fmu(active_fmus["active"], "car") as c, open_fmu(active_fmus["body"], "body") as b:
        runs.append(cosimulate(c, b, z, v, 1e-3, controller=SkyhookController(4000.0, 1500.0)))
    for name in ("head_acceleration", "tire_force", "suspension_deflection"):
        np.testing.assert_array_equal(runs[0][name], runs[1][name], err_msg=name)


def model_exchange_only(fmu, dest):
    """A copy of ``fmu`` whose description offers Model Exchange instead of co-simulation."""
    import re
    import zipfile

    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(dest, "w") as out:
        for item in src.infolist():
            data = src.read(item.filename)
            if item.filename == "modelDescription.xml":
                text = re.sub(
                    r"<CoSimulation[^>]*>",
                    '<ModelExchange modelIdentifier="SkyhookController">',
                    data.decode(),
                )
                data = text.replace("</CoSimulation>", "</ModelExchange>").encode()
            out.writestr(item, data)
    return str(dest)


@pytest.mark.integration
def test_controller_fmu_of_the_wrong_kind_is_refused_in_one_line(
    active_fmus, controller_fmu, tmp_path, capsys
):
    from bodyvib.cli.main import main
    from bodyvib.fmu.controller import build_controller_fmu

    half = str(build_controller_fmu(tmp_path / "half", ("_front", "_rear"), platforms=("linux64",)))
    me_only = model_exchange_only(controller_fmu, tmp_path / "me.fmu")
    cases = [
        (me_only, "Model Exchange only"),
        (active_fmus["active"], "it is a car FMU (give it to --car-fmu)"),
        (half, "the car has actuator_force: build it for this car"),
    ]
    for path, words in cases:
        argv = ["cosim", "--quiet", "--duration", "1", "--car-fmu", active_fmus["active"]]
        status = main(argv + ["--body", active_fmus["body"], "--control-fmu", path])
        err = capsys.readouterr().err.strip().splitlines()
        assert status == 2 and len(err) == 1, err
        assert words in err[0], err[0]


# -- the active SSP in generic hosts -----------------------------------------------------


@pytest.fixture(scope="module")
def active_ssp(tmp_path_factory):
    """``bodyvib build --control skyhook --native``: the package as a user builds it."""
    from bodyvib.cli.main import main

    dest = tmp_path_factory.mktemp("active_ssp")
    argv = ["build", "--control", "skyhook", "--native", "--platforms", "linux64"]
    assert main(argv + ["--dest", str(dest)]) == 0
    return dest / "native" / "active" / "ActiveQuarterCarWithOccupant.ssp"


def _assert_skyhook_closed_loop(head, car, tol):
    """A 5 s head acceleration of an active SSP with skyhook: within ``tol`` NRMSE of the
    exact closed loop (the law in the car's state space), far from the passive car."""
    from bodyvib.vehicle.reference import nrmse
    from bodyvib.vehicle.ssp import ssp_reference

    law = parse_control("skyhook", load_car(car))
    ref = ssp_reference(5.0, 1e-3, car=car, controller=law)
    assert head.size == ref["time"].size
    assert nrmse(head, ref["head_acceleration"]) <= tol
    passive = ssp_reference(5.0, 1e-3, car=car)
    assert nrmse(head, passive["head_acceleration"]) > 0.05


@pytest.mark.integration
@pytest.mark.parametrize("host", ["ssp_from_libcosimpy", "ssp_from_fmpy"])
def test_active_ssp_runs_in_generic_hosts(active_ssp, host):
    """libcosim and fmpy's SSP runner run the package unchanged; head acceleration against
    the exact closed loop on the road Road.fmu carries. These hosts are Jacobi: the
    controller reads the car's motion of the previous communication point, extrapolates
    the velocities with the accelerations over the step and gives the force its rate:
    measured 0.065 % NRMSE over 5 s (bodyvib's own master: 0.025 %). The passive car's
    reference is far off (the controller acts)."""
    from test_ssp import host_run

    res, _ = host_run(host, active_ssp, duration=5.0)
    _assert_skyhook_closed_loop(res["Body.head_acceleration"], "quarter-car-active", 8e-4)


@pytest.mark.integration
def test_active_ssp_runs_within_target_when_inputs_are_set_first(active_ssp):
    """examples/ssp_set_then_read.py sets every input before it reads the outputs that
    depend on it (OMSimulator's order): the controller is handed the car's velocities at
    the current point and must give the law of those, not of their extrapolation over the
    last step. Measured 0.016 % NRMSE over 5 s (0.83 % with a controller that
    extrapolated the velocities it was just handed), within the issue's 0.1 %."""
    from test_ssp import host_run

    res, _ = host_run("ssp_set_then_read", active_ssp, duration=5.0)
    _assert_skyhook_closed_loop(res["Body.head_acceleration"], "quarter-car-active", 1e-3)


@pytest.mark.integration
def test_active_ssp_without_the_acceleration_wires_lags_a_step(active_ssp, tmp_path):
    """The same package with only velocities and force connected: the force a step late and
    held, measured 1.27 % NRMSE in libcosim; the extrapolation is what meets the target."""
    import zipfile

    from test_ssp import host_run

    from bodyvib.vehicle.reference import nrmse
    from bodyvib.vehicle.ssp import (
        ACTIVE_COMPONENTS,
        ACTIVE_CONNECTIONS,
        ACTIVE_SSP_NAME,
        ssp_reference,
        write_ssp,
    )

    with zipfile.ZipFile(active_ssp) as z:
        z.extractall(tmp_path / "x")
    fmus = {c: str(tmp_path / "x" / "resources" / f"{n}.fmu") for c, n in ACTIVE_COMPONENTS.items()}
    wires = [w for w in ACTIVE_CONNECTIONS if "acceleration" not in w[1] and "rate" not in w[1]]
    ssp = write_ssp(tmp_path / "late.ssp", fmus, connections=wires, name=ACTIVE_SSP_NAME)
    res, _ = host_run("ssp_from_libcosimpy", ssp, duration=5.0)
    law = parse_control("skyhook", load_car("quarter-car-active"))
    ref = ssp_reference(5.0, 1e-3, car="quarter-car-active", controller=law)
    assert nrmse(res["Body.head_acceleration"], ref["head_acceleration"]) > 0.01


@pytest.mark.parametrize(
    "car, package, suffixes",
    [
        ("half-car-active", "ActiveHalfCarWithOccupant", ("_front", "_rear")),
        (
            "full-car-active",
            "ActiveFullCarWithOccupant",
            ("_front_left", "_front_right", "_rear_left", "_rear_right"),
        ),
    ],
)
def test_active_package_wires_each_actuator_to_its_controller_channel(car, package, suffixes):
    """Every actuator input of the active half car (per axle) and full car (per corner) and
    every controller input is driven by one wire, from the variable of the same actuator
    and quantity (the car's contract and the controller FMU's variable list, each from its
    own module)."""
    from bodyvib.fmu.controller import controller_variables
    from bodyvib.runtime.contract import actuator_variables
    from bodyvib.vehicle.ssp import PACKAGES

    components, connections, _ = PACKAGES[package]
    car_vars = actuator_variables(load_car(car))
    assert [names[0] for names in car_vars] == [f"actuator_force{s}" for s in suffixes]
    ctrl = controller_variables(suffixes)
    wires = [w for w in connections if "Controller" in (w[0], w[2])]
    driven = sorted((b, bc) for _, _, b, bc in wires)
    expected = [("Car", n) for names in car_vars for n in names[:2]]
    expected += [("Controller", n) for n, causality, _ in ctrl if causality == "input"]
    assert driven == sorted(expected)
    for a, ac, _, bc in wires:
        car_side, ctrl_side = (ac, bc) if a == "Car" else (bc, ac)
        suffix = next(s for s in suffixes if ctrl_side.endswith(s))
        assert car_side.endswith(ctrl_side) and car_side.endswith(suffix)
    assert components["Car"] == {"half-car-active": "HalfCar", "full-car-active": "FullCar"}[car]


def _build_active_ssp(tmp_path_factory, car, package):
    """``bodyvib build --control skyhook --car CAR --native``: the package's path."""
    from bodyvib.cli.main import main

    dest = tmp_path_factory.mktemp(package)
    argv = ["build", "--control", "skyhook", "--car", car, "--native"]
    assert main(argv + ["--platforms", "linux64", "--dest", str(dest)]) == 0
    return dest / "native" / "active" / f"{package}.ssp"


@pytest.fixture(scope="module")
def active_half_ssp(tmp_path_factory):
    return _build_active_ssp(tmp_path_factory, "half-car-active", "ActiveHalfCarWithOccupant")


@pytest.mark.integration
@pytest.mark.parametrize("host", ["ssp_from_fmpy", "ssp_from_libcosimpy"])
def test_active_half_car_ssp_runs_in_generic_hosts(active_half_ssp, host):
    """fmpy's SSP runner and libcosim run the half car's active package unchanged; head
    acceleration against the exact closed loop of the half car and both axles' skyhook
    law on the road pair RoadFrontRear.fmu carries. Measured 0.086 % NRMSE over 5 s at
    1 ms in both hosts (the passive half car in the same package: 0.006 %); the
    quarter car's 0.08 % target is met at 0.9 ms, the error being second order in the
    step (0.346 % at 2 ms, 0.021 % at 0.5 ms): the target here is 0.1 %. The passive
    car's reference is far off (the controllers act)."""
    from test_ssp import host_run

    kwargs = {"signals": [["Body", "head_acceleration"]]} if "libcosim" in host else {}
    res, _ = host_run(host, active_half_ssp, duration=5.0, **kwargs)
    _assert_skyhook_closed_loop(res["Body.head_acceleration"], "half-car-active", 1e-3)


@pytest.mark.integration
def test_active_half_car_ssp_runs_within_target_when_inputs_are_set_first(active_half_ssp):
    """The half car's active package in the set-then-read master: measured 0.016 % NRMSE
    over 5 s, within the issue's 0.1 %."""
    from test_ssp import host_run

    res, _ = host_run("ssp_set_then_read", active_half_ssp, duration=5.0)
    _assert_skyhook_closed_loop(res["Body.head_acceleration"], "half-car-active", 1e-3)


@pytest.fixture(scope="module")
def active_full_ssp(tmp_path_factory):
    return _build_active_ssp(tmp_path_factory, "full-car-active", "ActiveFullCarWithOccupant")


@pytest.mark.integration
@pytest.mark.parametrize("host", ["ssp_from_fmpy", "ssp_from_libcosimpy", "ssp_set_then_read"])
def test_active_full_car_ssp_runs_in_generic_hosts(active_full_ssp, host):
    """The full car's active package (a controller channel per corner, the two-track road
    RoadFourWheel.fmu carries) in fmpy's SSP runner, libcosim and the set-then-read master:
    head acceleration against the exact closed loop of the full car and the four corners'
    skyhook law. Measured 0.088 % NRMSE over 5 s at 1 ms in the Jacobi hosts (the half
    car's package: 0.086 %), 0.017 % set-then-read; the half car's bound of 0.1 %."""
    from test_ssp import host_run

    kwargs = {"signals": [["Body", "head_acceleration"]]} if "libcosim" in host else {}
    res, _ = host_run(host, active_full_ssp, duration=5.0, **kwargs)
    _assert_skyhook_closed_loop(res["Body.head_acceleration"], "full-car-active", 1e-3)


@pytest.mark.integration
def test_active_half_car_ssp_error_is_second_order_in_the_step(active_half_ssp):
    """Doubling libcosim's step to 2 ms multiplies the error by 4 (measured 4.03): the
    extrapolated velocities and the force rate make the coupling second order."""
    from test_ssp import host_run

    from bodyvib.vehicle.reference import nrmse
    from bodyvib.vehicle.ssp import ssp_reference

    law = parse_control("skyhook", load_car("half-car-active"))
    err = {}
    for h in (1e-3, 2e-3):
        res, _ = host_run(
            "ssp_from_libcosimpy",
            active_half_ssp,
            duration=5.0,
            step=h,
            signals=[["Body", "head_acceleration"]],
        )
        ref = ssp_reference(5.0, h, car="half-car-active", controller=law)
        err[h] = nrmse(res["Body.head_acceleration"], ref["head_acceleration"])
    assert 3.5 <= err[2e-3] / err[1e-3] <= 4.5, err
