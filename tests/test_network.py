"""State-space assembly of lumped networks (bodyvib.runtime.network)."""

import numpy as np
import pytest
from helpers import dynamic_stiffness_response

from bodyvib.frequency.response import find_peaks, frequency_response, transmissibility
from bodyvib.models import load_model
from bodyvib.runtime.modelfile import network_from_dict
from bodyvib.runtime.network import linear_model, mount
from bodyvib.vehicle.quarter_car import load_car, seated_system


def reduced_matrices(m1, m2, k1, k2, c1, c2, ks):
    """The reduced model (docs/architecture.md, "The models") written out by hand: states (x1, x2, v1, v2, y)."""
    # ydot = v2 + [ks(xr - y) + k2(x2 - y)]/c2
    A = np.zeros((5, 5))
    B = np.zeros(5)
    A[0, 2] = A[1, 3] = 1.0
    # m1 a1 = k1(x2-x1) + c1(v2-v1)
    A[2, :] = [-k1 / m1, k1 / m1, -c1 / m1, c1 / m1, 0]
    # m2 a2 = ks(xr - y) + k1(x1-x2) + c1(v1-v2)
    A[3, :] = [k1 / m2, -k1 / m2, c1 / m2, -c1 / m2, -ks / m2]
    B[3] = ks / m2
    A[4, :] = [0, k2 / c2, 0, 1.0, -(ks + k2) / c2]
    B[4] = ks / c2
    return A, B


def test_reduced_model_matches_hand_written_equations():
    net = load_model("reduced-paper")
    lm = linear_model(net)
    A_ref, B_ref = reduced_matrices(**net.parameters)
    # reorder the builder's states (x1, x2, v1, v2, y) to compare
    order = [lm.states.index(s) for s in ("m1.x", "m2.x", "m1.v", "m2.v", "platform.y")]
    A = lm.A[np.ix_(order, order)]
    B = lm.B[order, 0]
    np.testing.assert_allclose(A, A_ref, rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(B, B_ref, rtol=1e-14)
    assert np.all(lm.B[:, 1] == 0)  # no damper on the seat


def test_reduced_model_poles_and_peak_match_design():
    lm = linear_model(load_model("reduced-paper"))
    poles = np.sort_complex(np.linalg.eigvals(lm.A))
    # the architecture notes print them to 3-4 significant digits
    expected = np.sort_complex(
        np.array([-249, -38.7 + 110.8j, -38.7 - 110.8j, -20.6 + 23.8j, -20.6 - 23.8j])
    )
    assert np.all(np.abs(poles - expected) <= 0.05 + 0.0005 * np.abs(expected)), poles
    f = np.linspace(0.5, 31.5, 6201)
    peaks = find_peaks(f, np.abs(transmissibility(lm, f)))
    assert len(peaks) == 1
    assert peaks[0].frequency_hz == pytest.approx(4.43, abs=0.005)
    assert peaks[0].modulus == pytest.approx(1.446, abs=0.0005)


def test_iso_model_peaks_and_static_mass():
    net = load_model("iso7962")
    f = np.linspace(0.5, 31.5, 6201)
    peaks = find_peaks(f, np.abs(transmissibility(net, f)))
    assert [p.frequency_hz for p in peaks] == [
        pytest.approx(4.45, abs=0.01),
        pytest.approx(11.0, abs=0.1),
    ]
    assert peaks[0].modulus == pytest.approx(1.665, abs=0.001)
    assert peaks[1].modulus == pytest.approx(1.02, abs=0.005)
    assert net.total_mass() == pytest.approx(75.0, abs=1e-9)


# The ISO model is stiff (k2* = 6.6e10 N/m against masses of ~10 kg and
# w^2 ~ 1e2..1e5): both linear solves have condition numbers near 1e8, so they
# agree to ~1e8 * eps ~ 1e-8, not to 1e-9. The reduced model's agree to 1e-12.
RTOL = {"reduced-paper": 1e-9, "iso7962": 1e-6}


@pytest.mark.parametrize("name", ["reduced-paper", "iso7962"])
def test_state_space_equals_nodal_analysis(name):
    net = load_model(name)
    f = np.geomspace(0.1, 100, 60)
    for point in net.mass_names:
        ss = frequency_response(net, f, f"{point}.x")
        ref = dynamic_stiffness_response(net, f, point)
        np.testing.assert_allclose(ss, ref, rtol=RTOL[name])


def test_every_element_kind_equals_nodal_analysis(rng):
    """A network using all five element kinds, including a damper on the base."""
    data = {
        "name": "all-kinds",
        "parameters": {
            p: float(v)
            for p, v in zip(
                ["ma", "mb", "mc", "k1", "c1", "k2", "k3", "c3", "k3s", "k4", "c4", "k4s", "c5"],
                rng.uniform(0.5, 2.0, 13)
                * [10, 20, 5, 1e4, 100, 2e4, 3e4, 300, 1e5, 1e4, 200, 4e4, 50],
            )
        },
        "masses": {"a": "ma", "b": "mb", "c": "mc"},
        "elements": [
            {"name": "e1", "kind": "kelvin", "from": "seat", "to": "a", "k": "k1", "c": "c1"},
            {"name": "e2", "kind": "spring", "from": "a", "to": "b", "k": "k2"},
            {
                "name": "e3",
                "kind": "series_kelvin",
                "from": "a",
                "to": "c",
                "k_series": "k3s",
                "k": "k3",
                "c": "c3",
            },
            {
                "name": "e4",
                "kind": "zener",
                "from": "b",
                "to": "c",
                "k": "k4",
                "c": "c4",
                "k_series": "k4s",
            },
            {"name": "e5", "kind": "damper", "from": "seat", "to": "b", "c": "c5"},
        ],
        "roles": {"head": "c"},
    }
    net = network_from_dict(data)
    f = np.geomspace(0.1, 50, 40)
    for p in "abc":
        np.testing.assert_allclose(
            frequency_response(net, f, f"{p}.x"), dynamic_stiffness_response(net, f, p), rtol=1e-9
        )
    # acceleration output = -(2 pi f)^2 x, with the base-velocity feedthrough
    w = 2 * np.pi * f
    np.testing.assert_allclose(
        frequency_response(net, f, "b.a"),
        -(w**2) * dynamic_stiffness_response(net, f, "b"),
        rtol=1e-9,
    )


@pytest.mark.parametrize("name", ["reduced-paper", "iso7962"])
def test_seat_force_is_total_inertia_force(name):
    """Newton on the whole body: seat force = -sum(m_i a_i) (compression positive)."""
    net = load_model(name)
    lm = linear_model(net)
    f = np.geomspace(0.2, 40, 30)
    w = 2 * np.pi * f
    inertia = sum(
        m * -(w**2) * dynamic_stiffness_response(net, f, p) for p, m in net.mass_values().items()
    )
    # body pushes down (compression) when the masses accelerate upward
    np.testing.assert_allclose(frequency_response(lm, f, "seat_force"), inertia, rtol=RTOL[name])


def test_scale_invariance_of_transmissibility():
    net = load_model("reduced-paper")
    scaled = net.with_parameters(**{k: 1.7 * v for k, v in net.parameters.items()})
    f = np.geomspace(0.5, 31.5, 50)
    np.testing.assert_allclose(transmissibility(scaled, f), transmissibility(net, f), rtol=1e-12)


def test_mounted_system_equals_nodal_analysis():
    """Two-way coupling: the body on the car, compared point by point."""
    net = seated_system(load_car(), load_model("iso7962"))
    f = np.geomspace(0.3, 30, 40)
    for p in ("sprung", "unsprung", "body.m1", "body.m3"):
        np.testing.assert_allclose(
            frequency_response(net, f, f"{p}.x"),
            dynamic_stiffness_response(net, f, p),
            rtol=RTOL["iso7962"],
        )
    assert net.total_mass() == pytest.approx(290 + 59 + 75.0)
    assert "sprung.force" not in linear_model(net).inputs


def test_mount_rejects_unknown_point():
    with pytest.raises(ValueError, match="no point 'roof'"):
        mount(load_car(), load_model("reduced-paper"), at="roof")


def test_statespace_object_has_named_signals():
    from bodyvib.frequency.response import to_statespace

    ss = to_statespace(linear_model(load_model("reduced-paper")))
    assert ss.ninputs == 2 and "m1_a" in ss.output_labels and "seat_force" in ss.output_labels


def test_element_outputs_of_the_quarter_car():
    """Tire force = kt (x_road - x_wheel) (compression +); suspension deflection
    = x_sprung - x_wheel; and the force the suspension puts on the sprung mass
    is ks*(x_u - x_s) + cs*(v_u - v_s): checked against the nodal solution."""
    car = load_car()
    p = car.parameters
    f = np.geomspace(0.5, 20, 15)
    s = 2j * np.pi * f
    xs = dynamic_stiffness_response(car, f, "sprung")
    xu = dynamic_stiffness_response(car, f, "unsprung")
    np.testing.assert_allclose(
        frequency_response(car, f, "tire.force"), p["kt"] * (1 - xu), rtol=1e-9
    )
    np.testing.assert_allclose(
        frequency_response(car, f, "suspension.deflection"), xs - xu, rtol=1e-9
    )
    np.testing.assert_allclose(
        frequency_response(car, f, "suspension.force"),
        (p["ks"] + p["cs"] * s) * (xu - xs),
        rtol=1e-9,
    )


def test_series_element_force_equals_seat_force():
    """The ISO model's element e3 is the only one on the seat: its force is the seat force,
    and both are the rate of the body's momentum, s^2 sum m_i X_i (Newton; every X_i by
    nodal analysis). The stiff model's solves agree to ~1e-8 (comment below): rtol 1e-6."""
    net = load_model("iso7962")
    f = np.geomspace(0.5, 30, 10)
    s = 2j * np.pi * f
    momentum = s**2 * sum(
        m * dynamic_stiffness_response(net, f, name) for name, m in net.mass_values().items()
    )
    np.testing.assert_allclose(frequency_response(net, f, "e3.force"), momentum, rtol=1e-6)
    np.testing.assert_allclose(frequency_response(net, f, "seat_force"), momentum, rtol=1e-6)
