"""Streaming ISO 2631-1 figures against independent weightings of the same records."""

import numpy as np
import pytest
from scipy import signal

from bodyvib.comfort.figures import (
    WK_PARAMETERS,
    comfort_category,
    comfort_figures,
    weighted_acceleration,
    wk_response,
)
from bodyvib.comfort.stream import (
    ComfortStream,
    WkFilter,
    stream_batch_figures,
    stream_comfort_figures,
    wk_statespace,
)
from bodyvib.models import load_model
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.reference import reference_run
from bodyvib.vehicle.road.synthetic import make_road, road_input


@pytest.fixture(scope="module")
def head():
    """30 s of head acceleration at 1 kHz: reduced body, quarter car, class C, 20 m/s."""
    step = 1e-3
    t = np.arange(30001) * step
    z, v = road_input(make_road("C", 20.0, 30.0, seed=0), 20.0, t)
    return reference_run(load_car(), load_model("reduced-paper"), z, v, step)["head_acceleration"]


def _wk_lti():
    """Wk as one scipy transfer function, written out from ISO 2631-1 Annex A here."""
    P = WK_PARAMETERS
    w = {k: 2 * np.pi * P[k] for k in ("f1", "f2", "f3", "f4", "f5", "f6")}
    num = np.polymul(
        np.polymul([1, 0, 0], [w["f2"] ** 2]),
        np.polymul([1 / w["f3"], 1], [1 / w["f5"] ** 2, 1 / (P["Q5"] * w["f5"]), 1]),
    )
    den = np.polymul(
        np.polymul([1, w["f1"] / P["Q1"], w["f1"] ** 2], [1, w["f2"] / P["Q1"], w["f2"] ** 2]),
        np.polymul(
            [1 / w["f4"] ** 2, 1 / (P["Q4"] * w["f4"]), 1],
            [1 / w["f6"] ** 2, 1 / (P["Q6"] * w["f6"]), 1],
        ),
    )
    num = np.polymul(num, [(w["f5"] / w["f6"]) ** 2])
    return signal.lti(num, den)


def test_statespace_response_is_wk():
    A, B, C, D = wk_statespace()
    f = np.logspace(-2, 3, 200)
    H = np.array([(C @ np.linalg.solve(2j * np.pi * x * np.eye(8) - A, B) + D)[0, 0] for x in f])
    ref = wk_response(f)
    assert np.max(np.abs(H - ref) / np.abs(ref)) < 1e-12


def test_filter_is_the_analog_filter_on_the_linear_interpolant(head):
    # scipy's lsim with interp=True simulates the analog system driven by the
    # straight lines between samples, from rest: the same definition, computed
    # by other code (scipy's state space and matrix exponential) from a
    # transfer function typed independently of bodyvib.comfort.figures.
    t = np.arange(head.size) * 1e-3
    _, ref, _ = signal.lsim(_wk_lti(), head, t, interp=True)
    got = WkFilter(1000.0, 1).update(head[None])[0]
    scale = np.sqrt(np.mean(ref**2))
    assert np.max(np.abs(got - ref)) < 1e-9 * scale


def test_figures_agree_with_fft_method_within_interpolation_error(head):
    # The FFT method treats the record as band-limited; the filter sees the
    # linear interpolant, whose spectrum is the band-limited one times
    # sinc^2(f/fs) ~ 1 - (pi f/fs)^2/3. So a_w(stream)/a_w(FFT) - 1 should be
    # -(pi/fs)^2 <f^2>/3 with <f^2> the weighted record's mean-square frequency.
    fs = 1000.0
    got = stream_comfort_figures(head, fs)
    ref = comfort_figures(head, fs)
    aw = weighted_acceleration(head, fs)
    F = np.fft.rfftfreq(aw.size, 1 / fs)
    P = np.abs(np.fft.rfft(aw)) ** 2
    predicted = -((np.pi / fs) ** 2) * np.sum(F**2 * P) / np.sum(P) / 3
    rel = got.weighted_rms / ref.weighted_rms - 1
    assert rel == pytest.approx(predicted, rel=0.1)
    for k in ("vdv", "peak"):  # the same attenuation, within its spread over frequency
        assert getattr(got, k) / getattr(ref, k) - 1 == pytest.approx(predicted, rel=0.25)
    assert got.crest_factor == pytest.approx(ref.crest_factor, rel=5 * abs(predicted))
    assert got.comfort == ref.comfort == comfort_category(got.weighted_rms)


def test_fft_method_on_a_fine_linear_interpolant_converges_to_the_filter(head):
    # Independent check of the definition: the FFT method applied to the same
    # linear interpolant sampled 10x finer sees it as band-limited to 5 kHz;
    # the remaining difference is (pi f / 10 kHz)^2/3, about 2e-6.
    seg = head[:5001]
    fine_t = np.arange(50001) * 1e-4
    fine = np.interp(fine_t, np.arange(seg.size) * 1e-3, seg)
    ref = weighted_acceleration(fine, 1e4)[::10]
    got = WkFilter(1000.0, 1).update(seg[None])[0]
    scale = np.sqrt(np.mean(ref**2))
    assert np.sqrt(np.mean((got - ref) ** 2)) < 2e-5 * scale


def test_block_splitting_and_batching_do_not_change_figures(head):
    rng = np.random.default_rng(3)
    batch = np.stack([head, -0.5 * head[::-1], np.roll(head, 4000)])
    one = stream_batch_figures(batch, 1000.0, block=batch.shape[1])
    s = ComfortStream(1000.0, 3)
    k = 0
    while k < batch.shape[1]:
        n = int(rng.integers(1, 3000))
        s.update(batch[:, k : k + n])
        k += n
    split = s.figures()
    assert len(one) == len(split) == 3
    for key in ("weighted_rms", "vdv", "peak", "crest_factor", "mtvv"):
        np.testing.assert_allclose(getattr(split, key), getattr(one, key), rtol=1e-12)
    alone = stream_comfort_figures(batch[1], 1000.0)
    # a record alone and in a batch: the same figures to rounding. Each weighted sample is
    # a BLAS product of a row of at most 8 + 1 + LIFT = 73 terms; the BLAS kernel for one
    # row is not the one for three (gemv against gemm, their vector widths), so the sums
    # may round in another order: bit for bit on some processors, 1 ulp apart on others
    # (the peak, seen on an AVX-512 machine). 1e-13 is a hundred times that reordering and
    # far below what a wrong sample would move a figure by.
    for key in ("weighted_rms", "vdv", "peak", "crest_factor", "mtvv"):
        assert getattr(alone, key) == pytest.approx(getattr(one.case(1), key), rel=1e-13), key
    assert alone.comfort == one.case(1).comfort
    assert split.comfort == one.comfort
    assert s.samples == batch.shape[1]


def test_sine_at_the_standards_factor():
    # 5 Hz sine, 60 s: weighted r.m.s. -> |Wk(5 Hz)| / sqrt(2) (transient ~1e-3)
    t = np.arange(0, 60, 1e-3)
    got = stream_comfort_figures(np.sin(2 * np.pi * 5 * t), 1000.0)
    assert got.weighted_rms == pytest.approx(abs(wk_response(5.0)[0]) / np.sqrt(2), rel=2e-3)


def test_bad_input_is_refused():
    with pytest.raises(BodyvibError, match="sampling rate"):
        WkFilter(0.0, 1)
    with pytest.raises(BodyvibError, match="at least one case"):
        WkFilter(1000.0, 0)
    f = ComfortStream(1000.0, 2)
    with pytest.raises(BodyvibError, match="no samples"):
        f.figures()
    with pytest.raises(BodyvibError, match="shape"):
        f.update(np.zeros((3, 10)))
    with pytest.raises(BodyvibError, match="NaN"):
        f.update(np.full((2, 4), np.nan))
    with pytest.raises(BodyvibError, match="n >= 2"):
        stream_comfort_figures([1.0], 1000.0)
    with pytest.raises(BodyvibError, match="stream_batch_figures"):
        stream_comfort_figures(np.zeros((2, 10)), 1000.0)
    with pytest.raises(BodyvibError, match="n >= 2"):
        stream_batch_figures(np.zeros(10), 1000.0)
