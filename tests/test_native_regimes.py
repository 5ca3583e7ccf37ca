"""The native car's tire contact and stops: regimes stepped with located events in C.

The native QuarterCar (fmu_src/native/bodyvib_regimes.c) against the independent
event-locating solution of hand-written equations (test_regimes.hand_written_solution,
DOP853 at rtol 1e-10), against the pythonfmu car driven by the same road, and against
the native car built from the linearized model where nothing switches.
"""

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from helpers import fmi2_initialized, fmi2_model_exchange
from test_regimes import H, bump_road, hand_written_solution
from test_regimes_cosim import _study  # the reduced body on the car, 20 m/s, step H

from bodyvib.fmu.native import build_native_fmu
from bodyvib.models import load_model
from bodyvib.runtime.network import linearized, static_preloads
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.study import run_study

pytestmark = pytest.mark.integration

CAR_OUT = ("seat_displacement", "sprung_acceleration", "tire_force", "tire_contact", "stop_force")


def _nrmse(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2) / np.mean(b**2)))


def test_native_car_over_the_bump_matches_hand_written_equations(native_fmus):
    """`cosim --native` over the 80 mm bump at 20 m/s: head acceleration within 0.2 % NRMSE
    of the independent solution, each lift-off and landing at the communication point after
    the located one (one step), tire force >= 0, the stop hit once."""
    grid, head, events, f0 = hand_written_solution(1.5)
    b = _study(native_fmus, "sine:h=0.08,l=1.0,at=10", 1.5).bodies["b"]
    run = b.run
    assert _nrmse(run["head_acceleration"], head) < 0.002
    changes = grid[1:][np.diff(run["tire_contact"]) != 0]
    theirs = [t for t, name, _ in events if name == "tire"]
    assert changes.size == len(theirs) == 4
    assert np.all(np.abs(changes - np.array(theirs)) <= H)
    assert np.min(run["tire_force"] + f0) >= -1e-9 * f0
    assert b.events.lift_offs == 2 and b.events.stop_contacts == 1


def test_native_car_over_the_pothole_leaves_the_road(native_fmus):
    """The 50 mm pothole at 20 m/s: the wheel leaves the road, the total tire force
    (static preload with the body on board plus the dynamic force) never pulls."""
    b = _study(native_fmus, "pothole", 2.0).bodies["b"]
    mass = load_model("reduced-paper").total_mass()
    f0 = static_preloads(load_car().with_parameters(m_occupant=mass))["tire"]
    assert b.events.lift_offs >= 1
    assert np.min(b.run["tire_contact"]) == 0.0
    assert np.min(b.run["tire_force"] + f0) >= -1e-9 * f0


def _drive(path, t_end=1.5):
    """The car alone over the bump (road displacement and velocity at the communication
    points), seat force 0: fmpy's co-simulation loop."""
    t = np.arange(0.0, t_end + H / 2, H)
    z, v = bump_road(t)
    signals = np.array(
        list(zip(t, z, v)),
        dtype=[("time", float), ("road_displacement", float), ("road_velocity", float)],
    )
    return simulate_fmu(
        str(path),
        stop_time=t_end,
        step_size=H,
        output_interval=H,
        input=signals,
        output=CAR_OUT,
    )


def test_native_car_alone_equals_pythonfmu_car_and_fmi3(native_fmus, python_fmus):
    """The car alone over the bump: the native FMI 2.0 car within 1e-6 of its peak of the
    pythonfmu car (both exact, events to 1e-10 of the step: what is left is rounding in the
    located times), with the same flags; FMI 3.0 equal to FMI 2.0 bit for bit."""
    nat2, nat3 = _drive(native_fmus["QuarterCar"]), _drive(native_fmus["fmi3/QuarterCar"])
    py = _drive(python_fmus["QuarterCar"])
    for name in CAR_OUT:
        assert np.array_equal(nat2[name], nat3[name]), name
        scale = max(np.max(np.abs(py[name])), 1.0)
        assert np.max(np.abs(nat2[name] - py[name])) <= 1e-6 * scale, name
    assert np.min(nat2["tire_contact"]) == 0.0  # it leaves the road
    f0 = static_preloads(load_car())["tire"]
    assert np.min(nat2["tire_force"] + f0) >= -1e-9 * f0


def test_class_c_equals_the_linear_native_car_bit_for_bit(native_fmus, tmp_path):
    """Class C at 20 m/s, where nothing switches: every output of the run equals the one
    with the native car built from the linearized model."""
    lin = build_native_fmu(
        linearized(load_car()), "car", "QuarterCar", "linear", tmp_path, platforms=["linux64"]
    )
    settings = RunSettings("C", 20.0, 5.0, H)
    runs = [
        run_study({"b": native_fmus["HumanBody3DOF"]}, car, settings, histories=True)
        .bodies["b"]
        .run
        for car in (native_fmus["QuarterCar"], str(lin))
    ]
    assert np.max(np.abs(runs[0]["tire_force"])) > 100  # a real excitation
    for name in ("head_acceleration", "seat_force", "tire_force", "suspension_deflection"):
        assert np.array_equal(runs[0][name], runs[1][name]), name
    assert np.all(runs[0]["tire_contact"] == 1.0)


def test_serialized_state_holds_the_regime(native_fmus, tmp_path):
    """A state taken while the wheel is in the air, serialized and restored into a fresh
    instance, continues exactly as the original run (the regime is part of it)."""
    path = native_fmus["QuarterCar"]
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(path, unzipdir=str(tmp_path / "car"))

    def slave(name):
        return fmi2_initialized(md, unzipped, name, slave=True)

    def step(s, k):
        z, v = bump_road(k * H)
        s.setReal([vr["road_displacement"], vr["road_velocity"]], [float(z), float(v)])
        s.doStep(k * H, H)
        return s.getReal([vr[o] for o in CAR_OUT])

    a = slave("a")
    k, y = 0, None
    while True:
        last, y = y, step(a, k)
        k += 1
        if y[3] == 0.0:  # in the air
            break
    blob = a.serializeFMUstate(a.getFMUstate())
    # the regime, last before the 8-byte checksum: its mask, then the switching functions
    # (tire contact, the stop's compression and rebound sides) at the last two step ends,
    # each positive where its bit is set. Engaged, the stop's compression function is its
    # force; the tire's was positive a step ago, on the road
    mask, g_prev, g_now = np.split(np.frombuffer(bytes(blob)[-8 - 8 * 7 : -8], "<f8"), [1, 4])
    on = [(int(mask[0]) >> i) & 1 == 1 for i in range(3)]
    assert not on[0] and list(g_now > 0.0) == on
    assert last[3] == 1.0 and g_prev[0] > 0.0
    assert on[1] and g_prev[1] == pytest.approx(last[4], rel=1e-9) and g_prev[1] > 0.0
    ahead = [step(a, k + j) for j in range(150)]
    b = slave("b")
    b.setFMUstate(b.deSerializeFMUstate(blob))
    assert b.getReal([vr["tire_contact"]]) == [0.0]
    again = [step(b, k + j) for j in range(150)]
    assert ahead == again
    assert any(y[3] == 1.0 for y in again)  # it lands within the 150 steps
    for s in (a, b):
        s.terminate()
        s.freeInstance()


#: A wheel thrown up at 3 m/s (the body down at 1 m/s) on a still road: it leaves the
#: road, hits the bump stop and lands; no input moves (fmpy's model-exchange loop applies
#: inputs only between its output points, so a moving road would measure fmpy, not the FMU).
THROW = {"state.unsprung.v": 3.0, "state.sprung.v": -1.0}
ME_OUT = ("seat_displacement", "suspension_deflection", "tire_force", "stop_force")


@pytest.mark.parametrize("fmi", ["", "fmi3/"])
def test_model_exchange_event_indicators_match_cosimulation(native_fmus, fmi):
    """fmpy's CVode with the switching functions as event indicators against the exact
    co-simulation step with located events. fmpy gives CVode ``atol = rtol`` (nominals 1):
    the global error is a modest multiple of ``rtol`` times each output's peak, and falls with
    ``rtol``. Bound: 1e3 rtol of the peak at rtol 1e-8 (measured at most 1.6e2, the stop
    force, whose 1.4e5 N/m stiffness scales the deflection's error), errors falling at least
    30x from rtol 1e-6 to 1e-8 (measured 70-400x); the same lift-off and landing, each
    located within the output step before the co-simulation's flag changes."""
    path = native_fmus[fmi + "QuarterCar"]
    out = ME_OUT + ("tire_contact",)
    cs = simulate_fmu(path, stop_time=0.3, step_size=H, output=out, start_values=THROW)
    cs_changes = cs["time"][1:][np.diff(cs["tire_contact"]) != 0]
    assert cs_changes.size == 2 and np.max(np.abs(cs["stop_force"])) > 1000
    errors = {}
    for rtol in (1e-6, 1e-8):
        me = simulate_fmu(
            path,
            fmi_type="ModelExchange",
            solver="CVode",
            relative_tolerance=rtol,
            stop_time=0.3,
            output_interval=H,
            output=out,
            start_values=THROW,
            record_events=True,
        )
        keep = np.r_[True, np.diff(me["time"]) > 0]  # the value after each event
        t = me["time"][keep]
        errors[rtol] = {
            o: np.max(np.abs(np.interp(cs["time"], t, me[o][keep]) - cs[o])) / np.max(np.abs(cs[o]))
            for o in ME_OUT
        }
        changes = me["time"][1:][np.diff(me["tire_contact"]) != 0]
        assert changes.size == 2
        assert np.all((cs_changes - changes >= 0) & (cs_changes - changes <= H))
    for o in ME_OUT:
        assert errors[1e-8][o] <= 1e3 * 1e-8, (o, errors)
        assert errors[1e-8][o] * 30 <= errors[1e-6][o], (o, errors)


def test_model_exchange_jacobian_is_the_regime_in_force(native_fmus, tmp_path):
    """With the wheel in the air, the directional derivatives of the state derivatives are
    those of the free regime: equal to central differences of the derivatives (exact for an
    affine regime, up to rounding: 1e-6 of the Jacobian's largest entry) and not the
    linear model's (the tire's stiffness is gone from the wheel's acceleration row). A
    derivative read by value reference equals the derivatives vector bit for bit."""
    import ctypes

    md, m = fmi2_model_exchange(native_fmus["QuarterCar"], tmp_path / "me", "me")
    der = [d.variable.valueReference for d in md.derivatives]
    states = [d.variable.derivative.valueReference for d in md.derivatives]
    m.newDiscreteStates()
    m.enterContinuousTimeMode()
    n = len(states)

    def set_states(values):
        m.setContinuousStates((ctypes.c_double * n)(*values), n)

    def derivatives():
        dx = (ctypes.c_double * n)()
        m.getDerivatives(dx, n)
        return np.array(dx)

    def jacobian():
        return np.array(
            [m.getDirectionalDerivative(der, states, list(np.eye(n)[j])) for j in range(n)]
        ).T

    linear = jacobian()
    x = np.array(m.getReal(states))
    names = [d.variable.derivative.name for d in md.derivatives]
    x[names.index("state.unsprung.x")] += 0.2  # the wheel 0.2 m up: the tire can only push
    set_states(x)
    m.completedIntegratorStep()
    m.enterEventMode()
    m.newDiscreteStates()
    m.enterContinuousTimeMode()
    assert m.getReal([{v.name: v.valueReference for v in md.modelVariables}["tire_contact"]]) == [
        0.0
    ]
    free = jacobian()
    dx = derivatives()
    assert list(dx) == m.getReal(der)
    fd = np.empty((n, n))
    for j in range(n):
        e = np.eye(n)[j] * 1e-3
        set_states(x + e)
        up = derivatives()
        set_states(x - e)
        fd[:, j] = (up - derivatives()) / 2e-3
    np.testing.assert_allclose(free, fd, rtol=0, atol=1e-6 * np.max(np.abs(free)))
    assert np.max(np.abs(free - linear)) > 1e-3 * np.max(np.abs(linear))
    m.terminate()
    m.freeInstance()
