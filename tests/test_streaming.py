"""Memory independent of the run's length: the study computes everything as it goes.

The streaming pieces against their whole-record counterparts: the transmissibility
(Welch H1, the same segments), the monolithic reference carried block to block, the
master advanced block by block, and a whole study's figures against the same run's
kept histories. The comfort figures are the recursive Wk filter's
(bodyvib.comfort.stream): against the FFT weighting of the whole record they sit
(pi/fs)^2 <f^2> / 3 lower (linear against band-limited interpolation between samples),
about 2.2e-4 at a 1 ms step; every other figure equals the whole-record computation
to rounding.
"""

import numpy as np
import pytest

from bodyvib.comfort.figures import comfort_figures
from bodyvib.comfort.stream import stream_comfort_figures
from bodyvib.frequency.estimate import TransmissibilityStream, estimate_transmissibility
from bodyvib.models import load_model
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.reference import ReferenceStream, nrmse, reference_run
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.road.synthetic import make_road, road_input


def _road(duration=12.0, h=1e-3):
    t = np.arange(int(round(duration / h)) + 1) * h
    return t, road_input(make_road("C", 20.0, duration, seed=3), 20.0, t)


@pytest.mark.parametrize("block", [1000, 4096, 7777])
def test_transmissibility_stream_equals_welch_of_the_whole_record(block):
    t, (z, v) = _road()
    r = reference_run(load_car(), load_model("reduced-paper"), z, v, 1e-3)
    x, y = r["seat_acceleration"], r["head_acceleration"]
    whole = estimate_transmissibility(x, y, 1000.0)
    s = TransmissibilityStream(1000.0, x.size)
    for a in range(0, x.size, block):
        s.update(x[a : a + block], y[a : a + block])
    part = s.result()
    assert part.frequency_hz == whole.frequency_hz
    for key in ("modulus", "phase_deg", "coherence"):
        np.testing.assert_allclose(getattr(part, key), getattr(whole, key), rtol=1e-11, atol=1e-11)
    assert part.peak.frequency_hz == pytest.approx(whole.peak.frequency_hz, rel=1e-12)
    assert part.peak.modulus == pytest.approx(whole.peak.modulus, rel=1e-12)


@pytest.mark.parametrize("model, tol", [("reduced-paper", 1e-10), ("iso7962", 1e-6)])
def test_reference_stream_equals_the_whole_reference(model, tol):
    t, (z, v) = _road(6.0)
    whole = reference_run(load_car(), load_model(model), z, v, 1e-3)
    s = ReferenceStream(load_car(), load_model(model), 1e-3)
    parts = [s.advance(z[a : a + 1500], v[a : a + 1500]) for a in range(0, z.size, 1500)]
    for k, ref in whole.items():
        if k in parts[0]:
            got = np.concatenate([p[k] for p in parts])
            # the same recursion; reference_run steps by diff(t), which differs from h by
            # rounding (1e-13 relative after 4 s) and then gets its own step matrices: the
            # stiff ISO model (fastest pole -1.1e8 1/s, a 1.39 kHz mode with 0.23 % damping)
            # turns that into 1e-7 of its head acceleration (measured 9e-8); the reduced
            # model into 1e-12
            np.testing.assert_allclose(got, ref, rtol=0, atol=tol * np.max(np.abs(ref)))


def test_streamed_figures_against_the_fft_weighting():
    """The measured and predicted gap between the two weightings (docs/getting_started.md, "The check")."""
    t, (z, v) = _road(30.0)
    a = reference_run(load_car(), load_model("reduced-paper"), z, v, 1e-3)["head_acceleration"]
    fft, rec = comfort_figures(a, 1000.0), stream_comfort_figures(a, 1000.0, block=4096)
    # predicted: linear interpolation scales the spectrum by sinc^2(f/fs) ~ 1 - (pi f/fs)^2/3
    from bodyvib.comfort.figures import weighted_acceleration

    aw = weighted_acceleration(a, 1000.0)
    W = np.abs(np.fft.rfft(aw)) ** 2
    f = np.fft.rfftfreq(aw.size, 1e-3)
    predicted = (np.pi / 1000.0) ** 2 * np.sum(f**2 * W) / np.sum(W) / 3
    gap = 1 - rec.weighted_rms / fft.weighted_rms
    assert gap == pytest.approx(predicted, rel=0.05)
    for key in ("vdv", "peak"):
        assert 0 < 1 - getattr(rec, key) / getattr(fft, key) < 5e-4


@pytest.fixture(scope="module")
def fmus(python_fmus):
    return {
        "body": python_fmus["HumanBody3DOF"],
        "iso": python_fmus["HumanBodyISO7962"],
        "car": python_fmus["QuarterCar"],
    }


@pytest.mark.integration
def test_master_block_by_block_equals_one_block(fmus):
    from bodyvib.vehicle.cosim import Master, cosimulate, open_fmu

    t, (z, v) = _road(3.0)
    with open_fmu(fmus["car"], "car") as car, open_fmu(fmus["body"], "body") as body:
        whole = cosimulate(car, body, z, v, 1e-3, block=z.size)
    with open_fmu(fmus["car"], "car") as car, open_fmu(fmus["body"], "body") as body:
        m = Master(car, body, 1e-3, z.size)
        rows = np.concatenate(
            [m.advance(z[a : a + 333], v[a : a + 333]) for a in range(0, z.size, 333)]
        )
    from bodyvib.vehicle.cosim import MASTER_SIGNALS

    for i, k in enumerate(MASTER_SIGNALS):
        np.testing.assert_array_equal(rows[:, i], whole[k])  # bit for bit


@pytest.mark.integration
def test_study_figures_equal_those_of_its_own_histories(fmus):
    """A streamed study against the whole-record computations on the same run's kept
    histories: coupling NRMSE, transmissibility and the NRMSE between bodies to
    rounding; the comfort figures to rounding against the recursive filter on the whole
    record and within 5e-4 (measured 2.1e-4 to 2.5e-4) of the FFT weighting."""
    from bodyvib.vehicle.study import run_study

    st = run_study(
        {"r": fmus["body"], "i": fmus["iso"]},
        fmus["car"],
        RunSettings("C", 20.0, 12.0, 1e-3),
        histories=True,
        block=1000,
    )
    for _label, b in st.bodies.items():
        run, ref = b.run, b.reference
        a = run["head_acceleration"]
        assert b.coupling_nrmse == pytest.approx(nrmse(a, ref["head_acceleration"]), rel=1e-9)
        rec = stream_comfort_figures(a, 1000.0)
        fft = comfort_figures(a, 1000.0)
        for key in ("weighted_rms", "vdv", "peak"):
            assert getattr(b.figures, key) == pytest.approx(getattr(rec, key), rel=1e-12)
            assert 0 < 1 - getattr(b.figures, key) / getattr(fft, key) < 5e-4
        seat = stream_comfort_figures(run["seat_acceleration"], 1000.0)
        assert b.seat_figures.weighted_rms == pytest.approx(seat.weighted_rms, rel=1e-12)
        whole = estimate_transmissibility(run["seat_acceleration"], a, 1000.0)
        np.testing.assert_allclose(b.transmissibility.modulus, whole.modulus, rtol=1e-10)
        assert b.transmissibility.peak.frequency_hz == pytest.approx(
            whole.peak.frequency_hz, rel=1e-10
        )
        w = (st.time >= st.window_time[0] - 1e-9) & (st.time <= st.window_time[-1] + 1e-9)
        np.testing.assert_array_equal(b.head_window, a[w])
    e = nrmse(st.bodies["r"].run["head_acceleration"], st.bodies["i"].run["head_acceleration"])
    assert st.history_nrmse("r", "i") == pytest.approx(e, rel=1e-12)
