"""Absorbed power, MSDV (Wf) and SEAT against tables, closed forms and the runs themselves."""

import math

import numpy as np
import pytest

from bodyvib.comfort.measures import (
    FEET_PER_METRE,
    SeatMeasureStream,
    absorbed_power,
    lee_pradko_power,
    lee_pradko_response,
    msdv,
    seat_value,
    wf_response,
)

# ISO 2631-1:1997, Table 3: weighting Wf (motion sickness), factor x 1000 at the
# nominal one-third-octave frequencies 0.1 ... 1 Hz.
WF_TABLE_3 = {
    0.1: 695,
    0.125: 895,
    0.16: 1006,
    0.2: 992,
    0.25: 854,
    0.315: 619,
    0.4: 384,
    0.5: 224,
    0.63: 116,
    0.8: 53.0,
    1.0: 23.5,
}


@pytest.mark.parametrize("f_hz,table", sorted(WF_TABLE_3.items()))
def test_wf_matches_table_3(f_hz, table):
    # Table 3 rounds to 3 significant figures; its frequencies are nominal (exact
    # one-third octaves differ by up to 1 %), hence 1 %
    assert abs(wf_response(f_hz)[0]) * 1000 == pytest.approx(table, rel=0.01)


@pytest.mark.parametrize("f_hz", [0.1, 0.2, 0.4])
def test_msdv_of_a_sine_is_its_weighted_rms_times_root_duration(f_hz):
    fs, T = 20.0, 1800.0
    t = np.arange(0, T, 1 / fs)
    a = 0.7 * np.sin(2 * np.pi * f_hz * t)
    expected = abs(wf_response(f_hz)[0]) * 0.7 / math.sqrt(2) * math.sqrt(T)
    assert msdv(a, fs) == pytest.approx(expected, rel=2e-3)  # the start transient: < 1e-3


@pytest.mark.parametrize("f_hz", [1.0, 4.0, 10.0])
def test_lee_pradko_power_of_a_sine(f_hz):
    """|H(f)|^2 times the mean square in (ft/s2)^2; H's modulus by hand at 4 Hz."""
    fs = 500.0
    t = np.arange(0, 300, 1 / fs)  # the start transient: 0.05 % of the mean square
    a = 2.0 * np.sin(2 * np.pi * f_hz * t)  # 2 m/s2 peak
    expected = abs(lee_pradko_response(f_hz)[0]) ** 2 * 2.0 * FEET_PER_METRE**2
    assert lee_pradko_power(a, fs) == pytest.approx(expected, rel=2e-3)
    s = 2j * math.pi * 4.0
    by_hand = 14.5 * s * (s + 44) / ((s + 63) * (s * s + 24 * s + 750))
    assert lee_pradko_response(4.0)[0] == pytest.approx(by_hand, rel=1e-12)


def test_stream_equals_whole_record_figures():
    rng = np.random.default_rng(3)
    fs = 1000.0  # content below about 20 Hz: linear interpolation is close to the FFT's
    a = np.convolve(rng.standard_normal(200000), np.ones(50) / 50, "same")
    F, v = rng.standard_normal(a.size), rng.standard_normal(a.size)
    s = SeatMeasureStream(fs)
    for k in range(0, a.size, 777):  # blocks of any size
        s.update(a[k : k + 777], F[k : k + 777], v[k : k + 777])
    m = s.figures()
    assert m.absorbed_power_w == pytest.approx(absorbed_power(F, v), rel=1e-12)
    # exact step with linear interpolation against the FFT of the analog filter
    assert m.lee_pradko_power_w == pytest.approx(lee_pradko_power(a, fs), rel=3e-3)
    assert m.msdv == pytest.approx(msdv(a, fs), rel=3e-3)


def test_seat_value_of_a_rigid_seat_is_100():
    a = np.random.default_rng(0).standard_normal(20000)
    assert seat_value(a, a, 1000.0) == pytest.approx(100.0, abs=1e-9)


def _seat_values(car, damper, values):
    """The design evaluator's SEAT objective (a row per value of ``damper``) of the reduced
    body on ``car`` on a class C road at 20 m/s."""
    from bodyvib.vehicle.design import DesignProblem, parse_spec

    spec = parse_spec(
        {
            "car": car,
            "body": "reduced-paper",
            "parameters": {damper: {"min": 100, "max": 3000}},
            "operating_points": [{"road": "C", "speed": 20}],
            "objectives": ["seat_seat"],
        }
    )
    return DesignProblem(spec).evaluate([[v] for v in values])[0]


def test_rigid_seat_in_the_design_evaluator_is_100_percent():
    """The quarter car's seat is the sprung mass itself: SEAT 100 % to 1e-9."""

    F = _seat_values("quarter-car", "cs", [1000.0, 2500.0])
    np.testing.assert_allclose(F[:, 0], 100.0, rtol=0, atol=1e-9)


def test_cushion_seat_value_matches_the_frequency_integral():
    """SEAT of the cushion seat with the occupant: ratio of Wk-weighted spectral integrals.

    Independent of the Lyapunov evaluator: |H_pan(f)|^2 |Wk(f)|^2 and |H_floor(f)|^2
    |Wk(f)|^2 integrated over a white road velocity (S_v flat, so S_z ~ 1/f^2) by
    the trapezoid rule on 200,000 log-spaced points over 0.01-1000 Hz.
    """
    from bodyvib.comfort import wk_response
    from bodyvib.frequency.response import frequency_response
    from bodyvib.models import load_model
    from bodyvib.runtime.network import linear_model
    from bodyvib.vehicle.quarter_car import load_car, seated_system

    F = _seat_values("quarter-car-cushion", "cc", [565.0])
    lm = linear_model(seated_system(load_car("quarter-car-cushion"), load_model("reduced-paper")))
    f = np.geomspace(0.01, 1000, 200001)
    H = frequency_response(lm, f, ["pan.a", "sprung.a"])
    g = np.abs(wk_response(f)) ** 2 / f**2  # |Wk|^2 S_z(f), up to a constant
    pan, floor = (np.trapezoid(np.abs(h) ** 2 * g, f) for h in H)
    assert F[0, 0] == pytest.approx(100 * math.sqrt(pan / floor), rel=1e-6)
    assert F[0, 0] < 100  # the cushion isolates the wheel hop: measured 52.6 %


@pytest.mark.integration
def test_absorbed_power_is_the_runs_mean_seat_force_times_velocity(python_fmus):
    from bodyvib.vehicle.road.driven import RunSettings
    from bodyvib.vehicle.study import run_study

    fmus = python_fmus
    study = run_study(
        {"b": fmus["HumanBody3DOF"]},
        fmus["QuarterCar"],
        RunSettings("C", 20.0, 5.0, 1e-3),
        histories=True,
    )
    b = study.bodies["b"]
    run = b.run
    expected = float(np.mean(run["seat_force"] * run["seat_velocity"]))
    assert b.seat_measures.absorbed_power_w == pytest.approx(expected, rel=1e-9)
    assert expected > 0  # a passive body takes power from the seat
    assert b.seat_measures.msdv > 0 and b.seat_measures.lee_pradko_power_w > 0
    assert "absorbed_power_w" in b.to_dict()
    from bodyvib.comfort.spine import acceleration_dose

    dz = acceleration_dose(run["seat_acceleration"], 1000.0)
    assert b.seat_measures.spinal_dose == pytest.approx(dz, rel=1e-3)


def test_respond_reports_the_seat_records_msdv_and_power(capsys, tmp_path):
    """``bodyvib respond``: the seat's MSDV and Lee & Pradko power, as the functions give."""
    import json

    from bodyvib.cli.main import main

    fs = 250.0  # at least the 240 Hz the head's figures need (bodyvib.comfort.check_step)
    t = np.arange(0, 120, 1 / fs)
    a = 0.5 * np.sin(2 * np.pi * 0.2 * t) + 0.8 * np.sin(2 * np.pi * 4.0 * t)
    rec = tmp_path / "seat.csv"
    np.savetxt(rec, np.column_stack([t, a]), delimiter=",", header="time,acceleration", comments="")
    out = tmp_path / "r.json"
    assert main(["respond", str(rec), "--json", str(out), "--models", "reduced-paper"]) == 0
    printed = capsys.readouterr().out
    assert "seat MSDV (Wf)" in printed and "Lee & Pradko" in printed
    seat = json.loads(out.read_text())["seat"]
    assert seat["msdv"] == pytest.approx(msdv(a, fs), rel=1e-12)
    assert seat["lee_pradko_power_w"] == pytest.approx(lee_pradko_power(a, fs), rel=1e-12)
