"""ISO 2631-5:2018 vertical figures against independent computations and the standard's tables."""

import math

import numpy as np
import pytest
from scipy import signal

from bodyvib.comfort.spine import (
    SPINE_POLES,
    SPINE_ZERO,
    WEIBULL,
    acceleration_dose,
    daily_dose,
    injury_probability,
    injury_risk,
    response_peaks,
    spinal_dose,
    spinal_response,
)


def _spine_ss():
    """Formula 1 from its roots (not the module's polynomials): a factor
    ``1 + 2 z s / w + (s / w)^2`` has the roots ``w (-z +- j sqrt(1 - z^2))`` and leading
    coefficient ``1 / w^2``; unity gain at DC."""

    def roots(w, z):
        return [w * complex(-z, sign * np.sqrt(1 - z**2)) for sign in (1, -1)]

    poles = [r for w, z in SPINE_POLES for r in roots(w, z)]
    gain = np.prod([w**2 for w, _ in SPINE_POLES]) / SPINE_ZERO[0] ** 2
    return signal.ZerosPolesGain(roots(*SPINE_ZERO), poles, gain)


def _shocks(fs):
    """Three half-sine shocks of 8, 12 and 5 m/s2 (50-120 ms) in 4 s of rest."""
    t = np.arange(0, 4, 1 / fs)
    a = np.zeros_like(t)
    for t0, dur, amp in ((0.5, 0.1, 8.0), (1.7, 0.12, 12.0), (3.0, 0.05, -5.0)):
        on = (t >= t0) & (t < t0 + dur)
        a[on] += amp * np.sin(np.pi * (t[on] - t0) / dur)
    return t, a


def test_dose_of_shocks_matches_a_time_domain_integration():
    """Dz from the module (FFT, analog from rest) against scipy's lsim of Formula 1.

    The ODE integration at 4 kHz (linear input between samples) is independent of
    the FFT weighting; their doses agree to 4e-6 (asserted 1 %).
    """
    fs = 4000.0
    t, a = _shocks(fs)
    _, y, _ = signal.lsim(_spine_ss(), a, t, interp=True)
    peaks = response_peaks(y)
    expected = 1.07 * np.sum(peaks**6) ** (1 / 6)
    assert acceleration_dose(a, fs) == pytest.approx(expected, rel=0.01)
    np.testing.assert_allclose(spinal_response(a, fs), y, atol=2e-3 * np.abs(y).max())


def test_response_peaks_are_positive_run_maxima():
    r = np.array([-1.0, 2.0, 5.0, 1.0, 0.0, 3.0, -2.0, -1.0, 0.5])
    assert response_peaks(r).tolist() == [5.0, 3.0, 0.5]


def test_daily_dose_scales_with_the_sixth_root_of_time():
    assert daily_dose(2.0, 64 * 60.0, 60.0) == pytest.approx(4.0)
    s = spinal_dose(_shocks(1000.0)[1], 1000.0, exposure_s=4.0 * 3**6)
    assert s.daily_dose == pytest.approx(3 * s.dose, rel=1e-12)
    assert s.compression == pytest.approx(0.029 * s.daily_dose)


@pytest.mark.parametrize(
    "sex,table_c2", [("male", (0.72, 1.42, 2.17)), ("female", (0.52, 0.87, 1.20))]
)
def test_table_c2_follows_from_table_c1(sex, table_c2):
    """Annex C: the R of 10, 50 and 90 % risk (Table C.2) are the Weibull quantiles of C.1."""
    for p, r in zip((0.1, 0.5, 0.9), table_c2):
        assert injury_probability(r, sex) == pytest.approx(p, abs=0.01)
        alpha, beta = WEIBULL[sex]
        assert alpha * (-math.log(1 - p)) ** (1 / beta) == pytest.approx(r, abs=0.006)


def test_injury_risk_by_hand():
    """One year from age 40, 240 days, a man: R = Sd N^(1/6) / (6.75 - 0.052 40 - 9.81 mz)."""
    dzd = 10.0
    sd = 0.029 * dzd
    expected = sd * 240 ** (1 / 6) / (6.75 - 0.052 * 40 - 9.81 * 0.029)
    assert injury_risk(dzd, 40, 1, 240) == pytest.approx(expected, rel=1e-12)
    two = injury_risk(dzd, 40, 2, 240)
    second = sd * 240 ** (1 / 6) / (6.75 - 0.052 * 41 - 9.81 * 0.029)
    assert two == pytest.approx((expected**6 + second**6) ** (1 / 6), rel=1e-12)


def test_respond_reports_the_spinal_dose(tmp_path, capsys):
    """``bodyvib respond`` on a shock record: Dz, Dzd (8 h) and Sd as the module gives them."""
    import json

    from bodyvib.cli.main import main

    t, a = _shocks(1000.0)
    rec = tmp_path / "shocks.csv"
    np.savetxt(rec, np.column_stack([t, a]), delimiter=",", header="time,acceleration", comments="")
    out = tmp_path / "r.json"
    assert main(["respond", str(rec), "--json", str(out), "--models", "reduced-paper"]) == 0
    assert "ISO 2631-5 Dz" in capsys.readouterr().out
    seat = json.loads(out.read_text())["seat"]
    expected = spinal_dose(a - a.mean(), 1000.0)
    assert seat["spinal_dose_dz"] == pytest.approx(expected.dose, rel=1e-12)
    assert seat["spinal_daily_dose_dzd"] == pytest.approx(expected.daily_dose, rel=1e-12)


def test_streamed_dose_equals_the_whole_record_dose():
    """Block by block (exact step, linear input) against the FFT of the whole record."""
    from bodyvib.comfort.measures import SeatMeasureStream

    fs = 1000.0
    _, a = _shocks(fs)
    s = SeatMeasureStream(fs)
    zeros = np.zeros(a.size)
    for k in range(0, a.size, 50):  # 50 ms blocks: they cut through every response run
        s.update(a[k : k + 50], zeros[k : k + 50], zeros[k : k + 50])
    assert s.figures().spinal_dose == pytest.approx(acceleration_dose(a, fs), rel=1e-3)
