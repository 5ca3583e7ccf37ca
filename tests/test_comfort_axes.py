"""ISO 2631-1 in every axis: the weightings against the standard's tables, the totals
against hand sums of sinusoids whose weighted r.m.s. the tables give, the health
guidance caution zone against Annex B."""

import numpy as np
import pytest

from bodyvib import BodyvibError
from bodyvib.comfort import (
    SEATED_AXES,
    axis_figures,
    health_guidance,
    vibration_totals,
    weighted_axis,
    weighting,
)

# ISO 2631-1:1997 Table 3 (Wk, Wd, Wf) and Table 4 (Wc, We, Wj): weighting factors
# x 1000 at one-third-octave centre frequencies, as printed (three significant figures).
TABLES = {
    "Wk": {0.5: 418, 0.63: 459, 0.8: 477, 1: 482, 1.25: 484, 1.6: 494, 2: 531, 2.5: 631,
           3.15: 804, 4: 967, 5: 1039, 6.3: 1054, 8: 1036, 10: 988, 12.5: 902, 16: 768,
           20: 636, 25: 513, 31.5: 405, 40: 314, 50: 246, 63: 186, 80: 132},
    "Wd": {0.5: 853, 0.63: 944, 0.8: 992, 1: 1011, 1.25: 1008, 1.6: 968, 2: 890, 2.5: 776,
           3.15: 642, 4: 512, 5: 409, 6.3: 323, 8: 253, 12.5: 161, 16: 125, 20: 100,
           25: 80.0, 31.5: 63.2, 40: 49.4, 50: 38.8, 63: 29.5, 80: 21.1},
    "Wf": {0.02: 24.2, 0.025: 37.7, 0.0315: 59.7, 0.04: 97.1, 0.05: 157, 0.063: 267,
           0.08: 461, 0.1: 695, 0.125: 895, 0.16: 1006, 0.2: 992, 0.25: 854, 0.315: 619,
           0.4: 384, 0.5: 224, 0.63: 116, 0.8: 53.0, 1: 23.5},
    "Wc": {0.5: 843, 0.63: 929, 0.8: 972, 1: 991, 1.25: 1000, 1.6: 1007, 2: 1012,
           2.5: 1017, 3.15: 1022, 4: 1024, 5: 1013, 6.3: 974, 8: 891, 10: 776, 12.5: 647,
           16: 512, 20: 409, 25: 325, 31.5: 256, 40: 199},
    "We": {0.5: 862, 0.63: 939, 0.8: 941, 1: 880, 1.25: 772, 1.6: 632, 2: 512, 2.5: 409,
           3.15: 323, 4: 253, 5: 202, 6.3: 160, 8: 125, 10: 100, 12.5: 80.1, 16: 62.5},
    "Wj": {0.5: 417, 0.63: 458, 0.8: 478, 1: 484, 1.25: 485, 1.6: 483, 2: 482, 2.5: 489,
           3.15: 524, 4: 628, 5: 793, 6.3: 946, 8: 1017, 10: 1030, 12.5: 1026, 16: 1018,
           20: 1012, 25: 1007, 31.5: 1001, 40: 991, 50: 972, 63: 931, 80: 843},
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(TABLES))
def test_weightings_match_the_standards_tables(name):
    """Within 1 %: the tables round to three significant figures (at most 0.5 %)."""
    f = np.array(sorted(TABLES[name]))
    table = np.array([TABLES[name][x] for x in f]) / 1000.0
    np.testing.assert_allclose(np.abs(weighting(name, f)), table, rtol=0.01)


def test_an_unknown_weighting_names_the_six():
    with pytest.raises(BodyvibError, match="Wk, Wd, Wf, Wc, We, Wj"):
        weighting("Wb", 1.0)


def _sine(f_hz, amplitude, fs=1000.0, seconds=40.0):
    t = np.arange(int(fs * seconds)) / fs
    return amplitude * np.sin(2 * np.pi * f_hz * t)


@pytest.mark.parametrize("name,f_hz", [("Wd", 1.0), ("Wc", 8.0), ("We", 0.8), ("Wj", 6.3)])
def test_a_weighted_sine_in_steady_state_has_the_tables_gain(name, f_hz):
    """After the filter's start (the first 20 s dropped), a sine's weighted r.m.s. is
    |W(f)| / sqrt(2): the FFT method is exact for the analog filter, and 20 s are over
    30 time constants of the slowest pole (the 0.4 Hz band limit)."""
    aw = weighted_axis(_sine(f_hz, 1.0), 1000.0, name)
    steady = aw[aw.size // 2 :]
    gain = TABLES[name][f_hz] / 1000.0
    assert np.sqrt(np.mean(steady**2)) == pytest.approx(gain / np.sqrt(2), rel=0.006)


# The weighting of each axis (ISO 2631-1 Tables 1 and 2): seat x, y Wd; z Wk;
# rotations We; backrest x Wc, y, z Wd; feet Wk.
AXIS_WEIGHTINGS = dict.fromkeys(("seat_x", "seat_y", "backrest_y", "backrest_z"), "Wd")
AXIS_WEIGHTINGS.update(dict.fromkeys(("seat_z", "feet_x", "feet_y", "feet_z"), "Wk"))
AXIS_WEIGHTINGS.update(dict.fromkeys(("seat_rx", "seat_ry", "seat_rz"), "We"))
AXIS_WEIGHTINGS["backrest_x"] = "Wc"

# Sinusoids at table frequencies on every axis: (axis, frequency, amplitude, comfort k of
# ISO 2631-1 8.2.2/8.2.3, typed here from the clause, not from the module).
CASE = [
    ("seat_x", 1.0, 0.3, 1.0),
    ("seat_y", 2.0, 0.2, 1.0),
    ("seat_z", 6.3, 1.0, 1.0),
    ("seat_rx", 1.0, 0.5, 0.63),
    ("seat_ry", 2.0, 0.4, 0.40),
    ("seat_rz", 4.0, 0.6, 0.20),
    ("backrest_x", 4.0, 0.5, 0.80),
    ("backrest_y", 1.0, 0.3, 0.50),
    ("backrest_z", 2.0, 0.3, 0.40),
    ("feet_x", 5.0, 0.4, 0.25),
    ("feet_y", 8.0, 0.4, 0.25),
    ("feet_z", 10.0, 0.8, 0.40),
]


def test_totals_of_twelve_axes_match_hand_sums_of_the_tables():
    """Each axis's a_w is A |W(f)| / sqrt(2) with |W(f)| from the tables; the point and
    overall values are root sums of squares of k a_w (eq. (10), 8.2.3). The 40 s records
    include the filters' start, which changes the r.m.s. by under 1 %."""
    signals = {axis: _sine(f, amp) for axis, f, amp, _ in CASE}
    totals = vibration_totals(signals, 1000.0)
    expected = {
        axis: amp * TABLES[AXIS_WEIGHTINGS[axis]][f] / 1000.0 / np.sqrt(2)
        for axis, f, amp, _ in CASE
    }
    for axis, value in expected.items():
        assert totals.axes[axis].weighted_rms == pytest.approx(value, rel=0.01), axis
    k = {axis: kk for axis, _, _, kk in CASE}
    seat = np.sqrt(sum((k[a] * expected[a]) ** 2 for a in ("seat_x", "seat_y", "seat_z")))
    overall = np.sqrt(sum((k[a] * expected[a]) ** 2 for a in expected))
    assert totals.points["seat"] == pytest.approx(seat, rel=0.01)
    assert totals.overall == pytest.approx(overall, rel=0.01)
    # health: the dominant seat axis with 1.4, 1.4, 1 (7.2.3)
    health = max(1.4 * expected["seat_x"], 1.4 * expected["seat_y"], expected["seat_z"])
    assert totals.health_value == pytest.approx(health, rel=0.01)


def test_the_axis_table_holds_the_standards_weightings():
    """Seat x, y: Wd; z: Wk; rotations: We; backrest x: Wc, y, z: Wd; feet: Wk."""
    assert {a: v[0] for a, v in SEATED_AXES.items()} == AXIS_WEIGHTINGS


def test_health_guidance_zone_follows_annex_b():
    """8 h: 0.43 to 0.87 m/s2; the bounds scale as T^-1/2 (eq. (B.1)), about 3 and 6 m/s2
    at 10 min as Figure B.1 draws them."""
    at8 = health_guidance(0.5)
    assert (at8.lower, at8.upper, at8.zone) == (pytest.approx(0.43), pytest.approx(0.87), "caution")
    short = health_guidance(1.0, 600.0)
    assert short.lower == pytest.approx(3.0, rel=0.01)
    assert short.upper == pytest.approx(6.0, rel=0.01)
    assert short.zone == "below"
    assert health_guidance(1.0).zone == "above"


@pytest.mark.parametrize(
    "call,match",
    [
        (lambda: axis_figures(np.ones(10), 100.0, "seat_q"), "unknown axis 'seat_q'"),
        (lambda: vibration_totals({}, 100.0), "no signal given"),
        (
            lambda: vibration_totals({"seat_x": np.ones(10), "seat_z": np.ones(11)}, 100.0),
            "differ in length",
        ),
        (lambda: health_guidance(-1.0), "non-negative"),
        (lambda: health_guidance(1.0, 0.0), "positive number of s"),
    ],
)
def test_bad_input_is_refused_in_words(call, match):
    with pytest.raises(BodyvibError, match=match):
        call()


@pytest.mark.parametrize("name", sorted(TABLES))
def test_every_weighting_has_a_state_space_for_recursive_filters(name):
    """weighting_statespace (a term the weighting leaves out is a unity section) against
    the standard's tables at their frequencies, to their rounding."""
    from bodyvib.comfort import weighting_statespace
    from bodyvib.comfort.axes import WEIGHTINGS

    A, B, C, D = weighting_statespace(WEIGHTINGS[name])
    f = np.array(sorted(TABLES[name]))
    H = [(C @ np.linalg.solve(2j * np.pi * x * np.eye(len(A)) - A, B) + D)[0, 0] for x in f]
    table = np.array([TABLES[name][x] for x in f]) / 1000.0
    np.testing.assert_allclose(np.abs(H), table, rtol=0.01)


def test_each_axis_names_the_method_that_governs_it():
    """ISO 2631-1 6.3 per axis: a steady sine (crest factor sqrt 2) is evaluated by the
    basic method; a 1 s burst in a 100 s record (MTVV / a_w = 10, VDV / (a_w T^1/4) = 3.2)
    is not."""
    fs = 1000.0
    t = np.arange(int(100 * fs)) / fs
    steady = axis_figures(np.sin(2 * np.pi * 1.0 * t), fs, "seat_x")
    burst = axis_figures(np.where(t < 1.0, np.sin(2 * np.pi * 1.0 * t), 0.0), fs, "seat_x")
    assert steady.comfort_method == "basic"
    assert burst.comfort_method == "mtvv"
    assert burst.mtvv / burst.weighted_rms > 1.5
