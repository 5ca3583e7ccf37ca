"""Named internal forces (neck, lumbar) of the body models, against the element laws.

Each force is checked on states simulated by a solver of its own (scipy's Radau for the
reduced model, the exact step for the stiff ISO model) and against the element law written
out by hand from the masses' and nodes' motions; the reduced and ISO heads hang on one
element only, so the neck force is also the head's mass times its absolute acceleration
(Newton), an identity that needs no solver.
"""

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from bodyvib.models import load_model
from bodyvib.runtime.discretize import Discretization
from bodyvib.runtime.engine import FmuCore
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.modelfile import network_from_dict, network_to_dict
from bodyvib.runtime.network import linear_model
from bodyvib.seat.response import head_acceleration, internal_forces
from bodyvib.vehicle.quarter_car import load_car, seated_system
from bodyvib.vehicle.reference import reference_run
from bodyvib.vehicle.road.synthetic import make_road, road_input

#: Seat motion: a 2 cm (1 - cos) pulse of 0.25 s (up to 4 Hz, the bodies' first resonance).
H, T = 0.02, 0.25


def seat(t):
    """Seat displacement and velocity of the pulse at times ``t``."""
    t = np.asarray(t, float)
    on = (t >= 0) & (t <= T)
    w = 2 * np.pi / T
    return (
        np.where(on, 0.5 * H * (1 - np.cos(w * t)), 0.0),
        np.where(on, 0.5 * H * w * np.sin(w * t), 0.0),
    )


def outputs(lm, x, u):
    """Output histories ``C x + D u`` by name."""
    y = x @ lm.C.T + u @ lm.D.T
    return {name: y[:, i] for i, name in enumerate(lm.outputs)}


def states(lm, x):
    """State histories by name."""
    return {name: x[:, i] for i, name in enumerate(lm.states)}


def test_reduced_forces_equal_the_element_laws_on_a_radau_solution():
    """Neck = k1 (x2 - x1) + c1 (v2 - v1); lumbar = the seat spring's ks (xr - y), which the
    massless platform passes on to the lower body unchanged. States from scipy's Radau at
    rtol 1e-10; both forces to 1e-9 of their peak (the outputs are the same states' sums)."""
    net = load_model("reduced-paper")
    p = net.parameters
    lm = linear_model(net)
    t = np.linspace(0, 1.0, 2001)

    def rhs(tt, xx):
        z, v = seat(tt)
        return lm.A @ xx + lm.B @ np.array([float(z), float(v)])

    sol = solve_ivp(rhs, (0, 1.0), np.zeros(5), method="Radau", t_eval=t, rtol=1e-10,
                    atol=1e-14, max_step=T / 200)  # fmt: skip
    x = sol.y.T
    u = np.column_stack(seat(t))
    y, s = outputs(lm, x, u), states(lm, x)
    neck = p["k1"] * (s["m2.x"] - s["m1.x"]) + p["c1"] * (s["m2.v"] - s["m1.v"])
    lumbar = p["ks"] * (u[:, 0] - s["platform.y"])
    for name, law in (("neck_force", neck), ("lumbar_force", lumbar)):
        scale = np.max(np.abs(law))
        assert scale > 10.0  # newtons: the pulse loads both
        np.testing.assert_allclose(y[name], law, rtol=0, atol=1e-9 * scale)
    # Newton on the head, which hangs on the neck alone: F = m1 a1
    np.testing.assert_allclose(
        y["neck_force"], p["m1"] * y["m1.a"], rtol=0, atol=1e-9 * np.max(np.abs(neck))
    )


def test_iso_forces_equal_the_series_spring_laws_on_the_exact_step():
    """ISO model, e1 (neck) and e3 (lumbar) are series elements: the force through each is
    its series spring's, k1* (x2 - y1) and k3* (xr - y3), from the masses' and nodes'
    motions of the exact step (the model is too stiff for an explicit integrator)."""
    net = load_model("iso7962")
    p = net.parameters
    lm = linear_model(net)
    h = 1e-4
    t = np.arange(0, 0.6, h)
    u = np.column_stack(seat(t))
    du = np.column_stack([u[:, 1], np.gradient(u[:, 1], h)])
    x = Discretization(lm).run(u, du, h)
    y, s = outputs(lm, x, u), states(lm, x)
    neck = p["k1s"] * (s["m2.x"] - s["y1.y"])
    lumbar = p["k3s"] * (u[:, 0] - s["y3.y"])
    for name, law in (("neck_force", neck), ("lumbar_force", lumbar)):
        scale = np.max(np.abs(law))
        assert scale > 10.0
        np.testing.assert_allclose(y[name], law, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(
        y["neck_force"], p["m1"] * y["m1.a"], rtol=0, atol=1e-9 * np.max(np.abs(neck))
    )


@pytest.mark.parametrize("model", ["reduced-paper", "iso7962"])
def test_neck_force_row_is_head_mass_times_head_acceleration_row(model):
    """No solver: the output rows themselves satisfy F_neck = m1 a1 (C and D rows)."""
    net = load_model(model)
    lm = linear_model(net)
    m1 = net.mass_values()[net.point("head")]
    i, j = lm.output_index("neck_force"), lm.output_index("head.a")
    scale = np.max(np.abs(lm.C[i]))
    np.testing.assert_allclose(lm.C[i], m1 * lm.C[j], rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(lm.D[i], m1 * lm.D[j], rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize("model", ["reduced-paper", "iso7962"])
def test_lumbar_force_is_the_seat_force(model):
    """Both bodies stand on the seat through one load path, so the lumbar element carries
    the whole seat force (the massless nodes pass it on)."""
    lm = linear_model(load_model(model))
    i, j = lm.output_index("lumbar_force"), lm.output_index("seat_force")
    scale = np.max(np.abs(np.r_[lm.C[j], lm.D[j]]))
    np.testing.assert_allclose(np.r_[lm.C[i], lm.D[i]], np.r_[lm.C[j], lm.D[j]], atol=1e-9 * scale)


@pytest.mark.parametrize("model", ["reduced-paper", "iso7962"])
def test_body_fmu_core_outputs_the_forces(model):
    """The FMU engine (the pythonfmu FMUs' and the native build's contract) outputs
    neck_force and lumbar_force after the five body outputs; over the pulse the neck force
    is m1 times the head acceleration output and the lumbar force the seat force output."""
    net = load_model(model)
    m1 = net.mass_values()[net.point("head")]
    core = FmuCore("body", net)
    names = [v.name for v in core.interface.outputs]
    assert names[5:] == ["neck_force", "lumbar_force"]
    core.initialize()
    h = 1e-3
    t = np.arange(0, 0.6, h)
    z, v = seat(t)
    vr = list(range(3, 3 + len(names)))
    y = np.empty((t.size, len(names)))
    for k in range(t.size):
        core.set_real([0, 1], [z[k], v[k]])
        y[k] = core.get_real(vr)
        core.do_step(t[k], h)
    out = dict(zip(names, y.T))
    scale = np.max(np.abs(out["neck_force"]))
    assert scale > 10.0
    np.testing.assert_allclose(
        out["neck_force"], m1 * out["head_acceleration"], rtol=0, atol=1e-9 * scale
    )
    np.testing.assert_allclose(
        out["lumbar_force"],
        out["seat_force"],
        rtol=0,
        atol=1e-9 * np.max(np.abs(out["seat_force"])),
    )


def test_seated_system_carries_the_forces_under_the_prefix():
    """Mounted on the car, the body's forces are ``body.neck_force``, ``body.lumbar_force``."""
    lm = linear_model(seated_system(load_car(), load_model("reduced-paper")))
    for name, element in (("neck", "upper_body"), ("lumbar", "lower_body")):
        i, j = lm.output_index(f"body.{name}_force"), lm.output_index(f"body.{element}.force")
        np.testing.assert_array_equal(lm.C[i], lm.C[j])
        np.testing.assert_array_equal(lm.D[i], lm.D[j])


def test_forces_round_trip_and_bad_forces_are_refused():
    net = load_model("reduced-paper")
    d = network_to_dict(net)
    assert network_from_dict(json.loads(json.dumps(d))).forces == net.forces
    for forces, match in (
        (["upper_body"], "'forces' must be an object"),
        ({"neck": "nope"}, "forces.neck names unknown element 'nope'"),
        ({"neck force": "upper_body"}, "forces name 'neck force' must be a plain name"),
        ({"seat": "upper_body"}, "other than the base 'seat'"),
    ):
        with pytest.raises(BodyvibError, match=match):
            network_from_dict(dict(d, forces=forces))


@pytest.mark.parametrize("model", ["reduced-paper", "iso7962"])
def test_forces_from_a_seat_acceleration_equal_the_monolithic_reference(model):
    """``respond``'s forces, from the seat acceleration alone (the seat's frame), against the
    car + body reference's forces of the same run (class C road, 20 m/s): the seat record
    is taken linear between samples, an O(h^2) error (as for the head acceleration):
    NRMSE below 5e-4 at 1 ms and quartering (3.5-4.5) when the step halves."""
    body = load_model(model)
    errors = {name: [] for name in ("neck_force", "lumbar_force")}
    for step in (1e-3, 5e-4):
        t = np.arange(int(round(8.0 / step)) + 1) * step
        z, v = road_input(make_road("C", 20.0, 8.0, seed=0), 20.0, t)
        ref = reference_run(load_car(), body, z, v, step)
        got = internal_forces(body, ref["seat_acceleration"], 1 / step)
        for name, e in errors.items():
            r = ref[name]
            e.append(np.sqrt(np.mean((got[name] - r) ** 2) / np.mean(r**2)))
    for name, (e1, e2) in errors.items():
        assert e1 < 5e-4, name
        assert 3.5 < e1 / e2 < 4.5, name
    # and in that frame too the neck force is m1 times the head's absolute acceleration
    m1 = body.mass_values()[body.point("head")]
    head = head_acceleration(body, ref["seat_acceleration"], 1 / step)
    neck = got["neck_force"]
    np.testing.assert_allclose(neck, m1 * head, rtol=0, atol=1e-9 * np.max(np.abs(neck)))


def _forceless(tmp_path):
    """The reduced model's file without its ``forces``: a user model that names none."""
    d = network_to_dict(load_model("reduced-paper"))
    del d["forces"]
    path = tmp_path / "no-forces.json"
    path.write_text(json.dumps(d))
    return str(path)


def test_a_body_without_named_forces_runs_with_nan_forces(tmp_path):
    """The monolithic reference of a body that names no force records NaN for them and the
    same head acceleration as the body that does."""
    t = np.arange(2001) * 1e-3
    z, zv = road_input(make_road("bump", 20.0, 2.0), 20.0, t)
    plain = reference_run(load_car(), load_model(_forceless(tmp_path)), z, zv, 1e-3)
    named = reference_run(load_car(), load_model("reduced-paper"), z, zv, 1e-3)
    assert np.all(np.isnan(plain["neck_force"])) and np.all(np.isnan(plain["lumbar_force"]))
    np.testing.assert_array_equal(plain["head_acceleration"], named["head_acceleration"])
    assert np.max(np.abs(named["neck_force"])) > 1.0


@pytest.mark.integration
def test_cosimulation_records_the_fmu_forces_or_nan(tmp_path):
    """Real pythonfmu FMUs: the master records the body FMU's neck force, equal to the
    monolithic reference's within the coupling error (the head's, 0.05 % NRMSE at 1 ms),
    and NaN for a body FMU built from a file that names no force."""
    from bodyvib.vehicle.cosim import cosimulate, open_fmu
    from bodyvib.vehicle.fmus import build_project_fmu

    car = str(build_project_fmu("QuarterCar", tmp_path / "car"))
    t = np.arange(2001) * 1e-3
    z, zv = road_input(make_road("bump", 20.0, 2.0), 20.0, t)
    ref = reference_run(load_car(), load_model("reduced-paper"), z, zv, 1e-3)
    for source, named in (("reduced-paper", True), (_forceless(tmp_path), False)):
        body = str(build_project_fmu("HumanBody3DOF", tmp_path / str(named), source))
        with open_fmu(car, "car", "car") as c, open_fmu(body, "body", "body") as b:
            run = cosimulate(c, b, z, zv, 1e-3)
        if named:
            e = np.sqrt(np.mean((run["neck_force"] - ref["neck_force"]) ** 2))
            assert e < 5e-4 * np.sqrt(np.mean(ref["neck_force"] ** 2))
        else:
            assert np.all(np.isnan(run["neck_force"])) and np.all(np.isnan(run["lumbar_force"]))
            assert np.all(np.isfinite(run["head_acceleration"]))
