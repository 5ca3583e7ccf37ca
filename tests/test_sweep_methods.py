"""Each sweep engine's method and its range: the co-simulation engine steps the nonlinear
car's FMU and counts its events as ``bodyvib cosim`` does; the spectral engine's linear
expectation says where it leaves its range."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from bodyvib.frequency.response import frequency_response
from bodyvib.models import load_model
from bodyvib.runtime.network import linear_model, linearized
from bodyvib.vehicle.events import seated_preloads
from bodyvib.vehicle.quarter_car import load_car, seated_system
from bodyvib.vehicle.road.synthetic import N_BAND, displacement_psd
from bodyvib.vehicle.sweep.engines import case_road_input, run_spectral
from bodyvib.vehicle.sweep.spec import expand


def _tire_force_rms(road: str, speed: float) -> float:
    """The expected r.m.s. dynamic tire force of the quarter car with the reduced body on
    an ISO 8608 class at ``speed``, by hand: ``sigma^2 = int |H(f)|^2 Gd(f / V) / V df``
    over the synthesized band, H the road-to-tire-force response of the seated linear
    car (its named output, not the engine's switching rows), by adaptive quadrature in
    ``ln f``."""
    lm = linear_model(seated_system(linearized(load_car()), load_model("reduced-paper")))

    def integrand(lnf):
        f = math.exp(lnf)
        h = frequency_response(lm, [f], "tire.force")[0]
        return abs(h) ** 2 * displacement_psd(f / speed, road) / speed * f

    lo, hi = math.log(N_BAND[0] * speed), math.log(N_BAND[1] * speed)
    # the modes' frequencies (body 1.2 Hz, wheel hop 9.4 Hz, the occupant's 4-5 Hz) as
    # break points of the quadrature
    knots = [math.log(x) for x in (1.2, 4.5, 9.4) if lo < math.log(x) < hi]
    ms, err = quad(integrand, lo, hi, points=knots, limit=400, epsabs=0.0, epsrel=1e-11)
    assert err < 1e-10 * ms
    return math.sqrt(ms)


def test_spectral_rows_say_where_the_linear_tire_leaves_its_range():
    """Class B and class F at 30 m/s: the rows' 3-sigma tire-force ratio equals 3 times the
    hand-computed r.m.s. dynamic tire force over the static tire load (the car with the
    body's weight on its seat) to the engine's quadrature error (trapezoids on a log grid
    of 500 points per band: 1.2e-7 measured here; 1e-6 allowed). Class F's is beyond 1 (the wheel would leave the road:
    out of the linear car's range), class B's well inside."""
    cases = expand({"road": ["B", "F"], "speed": 30, "body": "reduced-paper"})
    rows = run_spectral(cases)
    body = load_model("reduced-paper")
    f0 = seated_preloads(load_car(), body.total_mass())[0]["tire"]
    for row, case in zip(rows, cases):
        assert row["error"] is None and row["stepping"] == "linear"
        expected = 3.0 * _tire_force_rms(case.road, case.speed) / f0
        assert row["tire_force_3sigma_ratio"] == pytest.approx(expected, rel=1e-6), case.road
        assert 0.0 < row["stop_travel_3sigma_ratio"] < math.inf
    b, f = rows
    assert b["tire_force_3sigma_ratio"] < 0.5 < 1.0 < f["tire_force_3sigma_ratio"]
    # a linear spec gives the same rows: the range is the car's, whichever car steps
    lin = run_spectral(expand({"road": ["B", "F"], "speed": 30, "linear": True}))
    for a, c in zip(rows, lin):
        assert a["tire_force_3sigma_ratio"] == c["tire_force_3sigma_ratio"]
    # the sweep's summary says which cases leave the range
    pd = pytest.importorskip("pandas")
    from bodyvib.vehicle.sweep.summary import format_summary

    df = pd.DataFrame(
        [
            {**r, "case_id": c.case_id, "road": c.road, "speed": c.speed, "body": c.body,
             "car": c.car, "engine": "spectral", "error": ""}
            for r, c in zip(rows, cases)
        ]
    )  # fmt: skip
    text = format_summary(df)
    f_travel = int(f["stop_travel_3sigma_ratio"] > 1)
    assert (
        "linear range: 1 of 2 cases leave it (3 sigma of the tire force beyond the static "
        f"load in 1, of the travel beyond the stops in {f_travel}"
    ) in text
    assert "linear range" not in format_summary(df.iloc[:1])


def test_spectral_range_is_nan_for_a_car_without_contacts():
    """The cushion car (a linear tire, no stops): nothing to leave."""
    (row,) = run_spectral(expand({"road": "C", "speed": 20, "car": "quarter-car-cushion"}))
    assert row["error"] is None, row["error"]
    assert np.isnan(row["tire_force_3sigma_ratio"]) and np.isnan(row["stop_travel_3sigma_ratio"])


def _heavy_body(tmp_path) -> str:
    """The reduced body with 1.3 times its masses, as a parameter file (another static
    tire load: the car FMU's occupant start value must follow the body)."""
    import json

    from bodyvib.runtime.modelfile import network_to_dict

    body = load_model("reduced-paper")
    doc = network_to_dict(
        body.with_parameters(m1=1.3 * body.value("m1"), m2=1.3 * body.value("m2"))
    )
    path = tmp_path / "heavy.json"
    path.write_text(json.dumps(doc))
    return str(path)


def _cosim_single_run(tmp_path, body, name):
    """``bodyvib cosim`` on the pothole at 20 m/s for 2 s: its JSON events and CSV."""
    import json

    from helpers import run_cli

    js, csv = tmp_path / f"{name}-run.json", tmp_path / f"{name}-run.csv"
    args = ["--params", body] if body != "reduced-paper" else []
    r = run_cli(
        "cosim", "--road", "pothole", "--speed", "20", "--duration", "2", "--quiet",
        "--json", str(js), "--csv", str(csv), *args,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    (events,) = [b["events"] for b in json.loads(js.read_text())["bodies"].values()]
    return events, np.genfromtxt(csv, delimiter=",", names=True)


def _event_shift(cosim_force, reference, f0, step):
    """A bound on how far the coupling moves a lift-off or a landing: the largest
    difference of the total tire force between the co-simulation and the reference at
    the points in contact in both, over the smallest rate at which the reference's
    force crosses zero (its chord over the step before a lift-off, after a landing)."""
    ref = reference["tire_force"] + f0
    co = cosim_force + f0
    both = (reference["tire_contact"] == 1) & (co > 0)
    diff = float(np.max(np.abs(co[both] - ref[both])))
    flag = reference["tire_contact"]
    k = np.flatnonzero(np.diff(flag) != 0)  # last point before each switching
    rates = []
    for j in k:
        if flag[j] == 1:  # lift-off between j and j + 1: the chord before it
            rates.append(abs(ref[j] - ref[j - 1]) / step)
        else:  # landing: the chord after it
            rates.append(abs(ref[j + 2] - ref[j + 1]) / step)
    return diff / min(rates), diff


@pytest.mark.integration
def test_cosim_engine_steps_the_nonlinear_car_and_counts_its_events(tmp_path):
    """Two cases on the pothole at 20 m/s where the wheel lifts (the reduced body and a
    heavier one). The cosim engine's event columns equal those of ``bodyvib cosim`` single
    runs of the same cases (the same FMU and start values, the same counter). Against the
    batched engine's rows (run again with exact steps and located events): the same
    lift-offs, stop contacts and smallest load ratio; the time in the air within, per
    flight, one step (the co-simulation counts communication points in the air, the
    reference the located flight) plus twice the coupling's shift of an event (its tire
    force's difference over the force's rate at the crossing, both measured on these
    runs); the head's weighted r.m.s. within the head acceleration's NRMSE
    (|rms(a) - rms(b)| <= rms(a - b))."""
    from bodyvib.vehicle.reference import ReferenceStream, nrmse
    from bodyvib.vehicle.sweep.engines import run_batched, run_cosim

    heavy = _heavy_body(tmp_path)
    cases = expand(
        {"road": "pothole", "speed": 20, "duration": 2, "body": ["reduced-paper", heavy]}
    )
    co, co_hist = run_cosim(cases, record=True)
    ba, ba_hist = run_batched(cases, record=True)
    step = cases[0].step
    for case, c, b, ch, bh, name in zip(cases, co, ba, co_hist, ba_hist, ("nominal", "heavy")):
        assert c["error"] is None and b["error"] is None, (c["error"], b["error"])
        assert c["stepping"] == b["stepping"] == "events"
        single, csv = _cosim_single_run(tmp_path, case.body_model, name)
        assert c["lift_offs"] == single["lift_offs"] >= 1
        assert c["time_in_air"] == single["time_in_air_s"] > 0.01
        assert c["stop_contacts"] == single["stop_contacts"]
        assert c["largest_stop_force"] == single["largest_stop_force_n"]
        assert c["smallest_tire_load_ratio"] == single["smallest_tire_load_ratio"] == 0.0
        a = ch["head_acceleration"]  # the same run (the CSV keeps 10 significant digits)
        np.testing.assert_allclose(
            csv["head_acceleration_ms2"], a, rtol=1e-9, atol=1e-9 * np.max(np.abs(a))
        )
        # against the monolithic reference with located events
        for k in ("lift_offs", "stop_contacts", "largest_stop_force", "smallest_tire_load_ratio"):
            assert c[k] == b[k], k
        z, v = case_road_input(case)
        body, car = case.body_network(), case.car_network()
        reference = ReferenceStream(car, body, step).advance(z, v)
        f0 = seated_preloads(car, body.total_mass())[0]["tire"]
        shift, _ = _event_shift(csv["tire_force_N"], reference, f0, step)
        assert shift < 0.1 * step  # the coupling moves an event by far less than a step
        tol = c["lift_offs"] * (step + 2 * shift)
        assert abs(c["time_in_air"] - b["time_in_air"]) <= tol
        err = nrmse(ch["head_acceleration"], bh["head_acceleration"])
        assert abs(c["head_weighted_rms"] / b["head_weighted_rms"] - 1) <= err * (1 + 1e-6)
    # the heavier body loads the tire more: a different run, not the nominal one again
    assert co[0]["head_weighted_rms"] != co[1]["head_weighted_rms"]
