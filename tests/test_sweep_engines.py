"""The sweep engines against independent computations of the same cases."""

import numpy as np
import pytest
from helpers import assert_csv_is_the_cosim_engine

from bodyvib.comfort.figures import wk_response
from bodyvib.comfort.stream import WeightingStep, stream_comfort_figures
from bodyvib.frequency.response import frequency_response
from bodyvib.runtime.discretize import simulate
from bodyvib.runtime.network import linear_model
from bodyvib.vehicle.quarter_car import seated_system
from bodyvib.vehicle.reference import nrmse, reference_run
from bodyvib.vehicle.road.synthetic import N_BAND, displacement_psd
from bodyvib.vehicle.sweep.engines import case_road_input, run_batched, run_cosim, run_spectral
from bodyvib.vehicle.sweep.kernel import SUMS, pack, run
from bodyvib.vehicle.sweep.spec import expand

EPS = np.finfo(float).eps


def _reference(case):
    z, v = case_road_input(case)
    return reference_run(case.car_network(), case.body_network(), z, v, case.step)


@pytest.mark.integration
def test_batched_equals_per_case_reference_reduced_bodies():
    cases = expand(
        {
            "road": ["C", "E"],
            "speed": [10, 27],
            "duration": 4,
            "body": [
                "reduced-paper",
                {
                    "model": "reduced-paper",
                    "vary": {"k1": [0.8, 1.2], "c2": [0.5, 2]},
                    "samples": 2,
                    "name": "varied",
                },
            ],
            "car": ["quarter-car", "quarter-car-cushion"],
        }
    )
    rows, hist = run_batched(cases, record=True)
    assert len(rows) == len(hist) == len(cases) == 24  # 2 roads, 2 speeds, 2 cars, 3 bodies
    for case, row, h in zip(cases, rows, hist):
        ref = _reference(case)
        for k in ("head_acceleration", "seat_acceleration"):
            scale = np.sqrt(np.mean(ref[k] ** 2))
            assert np.max(np.abs(h[k] - ref[k])) < 1e-9 * scale, (case, k)
        # figures: the same streaming code on the reference's history
        fig = stream_comfort_figures(ref["head_acceleration"], 1 / case.step)
        for k in ("weighted_rms", "vdv", "peak", "crest_factor"):
            assert row[f"head_{k}"] == pytest.approx(getattr(fig, k), rel=1e-9)
        assert row["head_comfort"] == fig.comfort
        seat = stream_comfort_figures(ref["seat_acceleration"], 1 / case.step).weighted_rms
        assert row["seat_weighted_rms"] == pytest.approx(seat, rel=1e-9)
        assert row["error"] is None


def test_a_body_at_two_step_sizes_in_one_task_gets_each_steps_matrices():
    """A body's step rows are kept with its model, one set per step size: one task
    with the same body at 1 ms and at 2 ms gives each case the figures it has alone."""
    spec = {"road": "C", "speed": [15, 25], "duration": 1, "body": "reduced-paper"}
    fine, coarse = expand(dict(spec, step=1e-3)), expand(dict(spec, step=2e-3))
    together, _ = run_batched(fine + coarse)
    alone = run_batched(fine)[0] + run_batched(coarse)[0]
    assert together == alone
    assert together[0]["head_weighted_rms"] != together[2]["head_weighted_rms"]


def test_batched_equals_reference_stiff_iso_body_to_its_rounding_floor():
    # The ISO 7962 head acceleration is a difference of terms ~1e6 times larger
    # than itself (k2s = 6.6e10 N/m): summing C x in another order changes it by
    # up to eps * sum_j |C_j| max|x_j|. The step is 2^-10 s so that the
    # reference's time grid k*h differences to exactly h (with h = 1 ms the
    # differences of t = k*h round h to 0.000999999999999 s for part of the
    # run, which this stiff output turns into 1e-7 differences).
    cases = expand(
        {
            "road": ["D"],
            "speed": [25],
            "duration": 4,
            "step": 2.0**-10,
            "body": ["iso7962"],
            "car": ["quarter-car", "quarter-car-cushion"],
        }
    )
    rows, hist = run_batched(cases, record=True)
    assert len(rows) == len(hist) == len(cases) == 2
    for case, h in zip(cases, hist):
        ref = _reference(case)
        lm = linear_model(seated_system(case.car_network(), case.body_network()))
        z, v = case_road_input(case)
        t = np.arange(z.size) * case.step
        x, _ = simulate(lm, t, np.column_stack([z, v]))
        seat = case.car_network().roles["seat"]
        for k, out in (("head_acceleration", "body.head.a"), ("seat_acceleration", f"{seat}.a")):
            scale = np.sqrt(np.mean(ref[k] ** 2))
            floor = EPS * np.abs(lm.C[lm.output_index(out)]) @ np.abs(x).max(axis=0) / scale
            err = np.max(np.abs(h[k] - ref[k])) / scale
            assert err < max(1e-9, 10 * floor), (case.car, k, err, floor)


def test_batched_records_a_case_that_cannot_be_built(tmp_path):
    bad = tmp_path / "bad.json"
    cases = expand({"road": "C", "speed": 10, "duration": 1, "body": ["reduced-paper"]})
    good = cases[0]
    import dataclasses

    broken = dataclasses.replace(good, case_id=1, body_model=str(bad), case_key="x")
    rows, _ = run_batched([good, broken])
    assert rows[0]["error"] is None and rows[0]["head_weighted_rms"] > 0
    assert "does not exist" in rows[1]["error"]
    assert np.isnan(rows[1]["head_weighted_rms"])


def _spectral_density(case, f):
    """One-sided PSD of the weighted head acceleration, m^2 s^-4 / Hz (steady state)."""
    lm = linear_model(seated_system(case.car_network(), case.body_network()))
    H = frequency_response(lm, f, "body.head.a")
    S = displacement_psd(f / case.speed, case.road) / case.speed
    return np.abs(H) ** 2 * np.abs(wk_response(f)) ** 2 * S


@pytest.mark.integration
def test_spectral_matches_long_time_domain_runs_within_estimator_statistics():
    # The mean square of T seconds of a stationary Gaussian process with
    # one-sided PSD G has variance ~ (1/T) int G^2 df about its expectation
    # int G df. The synthesized road (fixed amplitudes, random phases) varies
    # less than a Gaussian one, so this sigma bounds the spread; eight seeds
    # cut it by sqrt(8) for their mean.
    T, seeds = 60.0, 8
    for speed, road in ((12.0, "C"), (28.0, "B")):
        cases = expand(
            {
                "road": road,
                "speed": speed,
                "seed": list(range(seeds)),
                "duration": T,
                "body": "reduced-paper",
            }
        )
        timed, _ = run_batched(cases)
        spec = run_spectral(cases)
        ms = np.array([r["head_weighted_rms"] ** 2 for r in timed])
        expected = spec[0]["head_weighted_rms"] ** 2
        assert all(r["head_weighted_rms"] == spec[0]["head_weighted_rms"] for r in spec)
        f = np.geomspace(N_BAND[0] * speed, N_BAND[1] * speed, 4000)
        G = _spectral_density(cases[0], f)
        assert np.trapezoid(G, f) == pytest.approx(expected, rel=1e-6)
        sigma = np.sqrt(np.trapezoid(G**2, f) / T)
        assert abs(ms.mean() - expected) < 4 * sigma / np.sqrt(seeds)
        assert np.all(np.abs(ms - expected) < 4 * sigma)
        assert ms.std(ddof=1) < sigma
        for r in spec:
            assert np.isnan(r["head_vdv"]) and np.isnan(r["head_peak"])
            assert r["seat_weighted_rms"] > 0


@pytest.mark.integration
def test_spectral_quadrature_is_converged_and_scales_with_the_class():
    cases = expand(
        {
            "road": ["A", "D"],
            "speed": 20,
            "duration": 30,
            "body": ["reduced-paper", "iso7962"],
            "car": ["quarter-car", "quarter-car-cushion"],
        }
    )
    coarse = run_spectral(cases)
    fine = run_spectral(cases, points=16000)
    assert len(coarse) == len(fine) == len(cases) == 8
    for a, b in zip(coarse, fine):
        assert a["head_weighted_rms"] == pytest.approx(b["head_weighted_rms"], rel=1e-6)
        assert a["seat_weighted_rms"] == pytest.approx(b["seat_weighted_rms"], rel=1e-6)
    by = {(c.road, c.body, c.car): r for c, r in zip(cases, coarse)}
    for body in ("reduced-paper", "iso7962"):
        # Gd(n0) of class D is 4^3 times class A's: the r.m.s. scales by 8
        ratio = (
            by[("D", body, "quarter-car")]["head_weighted_rms"]
            / by[("A", body, "quarter-car")]["head_weighted_rms"]
        )
        assert ratio == pytest.approx(8.0, rel=1e-12)


@pytest.mark.integration
def test_cosim_engine_agrees_with_batched_within_the_coupling_error():
    # |rms(a) - rms(b)| <= rms(a - b): the relative r.m.s. difference is at most
    # the coupling NRMSE, which is measured here on the same runs.
    cases = expand(
        {
            "road": "C",
            "speed": 20,
            "duration": 3,
            "body": [
                "reduced-paper",
                "iso7962",
                {
                    "model": "reduced-paper",
                    "vary": {"k1": [0.6, 0.7], "m1": [1.3, 1.4]},
                    "samples": 1,
                    "name": "soft-neck",
                },
            ],
        }
    )
    co, co_hist = run_cosim(cases, record=True)
    ba, ba_hist = run_batched(cases, record=True)
    assert len(co) == len(ba) == len(co_hist) == len(ba_hist) == len(cases) == 3
    for _case, c, b, ch, bh in zip(cases, co, ba, co_hist, ba_hist):
        assert c["error"] is None, c["error"]
        err = nrmse(ch["head_acceleration"], bh["head_acceleration"])
        assert err < 5e-4  # the master's documented coupling error at 1 ms
        assert abs(c["head_weighted_rms"] / b["head_weighted_rms"] - 1) <= err * (1 + 1e-6)
        seat_err = nrmse(ch["seat_acceleration"], bh["seat_acceleration"])
        assert abs(c["seat_weighted_rms"] / b["seat_weighted_rms"] - 1) <= seat_err * (1 + 1e-6)
    # the varied parameters reached the FMU: the soft-neck body differs from the
    # nominal one by far more than the coupling error
    nominal, varied = co[0]["head_weighted_rms"], co[2]["head_weighted_rms"]
    assert abs(varied / nominal - 1) > 20 * 5e-4


@pytest.mark.integration
@pytest.mark.parametrize("linear", [False, True])
def test_a_sweep_case_runs_on_the_road_of_bodyvib_cosim(tmp_path, capsys, linear):
    """Class D at 15 m/s, where the wheel lifts: the cosim engine's case is ``bodyvib
    cosim``'s run (the car with contacts and stops), and with ``linear`` in the spec its
    ``--linear`` run (the linearized car)."""
    from bodyvib.cli.main import main

    csv = tmp_path / "cosim.csv"
    args = ["cosim", "--road", "D", "--seed", "3", "--speed", "15", "--duration", "2"]
    assert main(args + ["--csv", str(csv), "--quiet"] + (["--linear"] if linear else [])) == 0
    capsys.readouterr()
    spec = {"road": "D", "seed": 3, "speed": 15, "duration": 2, "body": "reduced-paper"}
    (case,) = expand(dict(spec, linear=linear))
    assert_csv_is_the_cosim_engine(csv, case)


def test_frequency_response_of_several_outputs_shares_one_solve():
    from bodyvib.models import load_model
    from bodyvib.vehicle.quarter_car import load_car

    lm = linear_model(seated_system(load_car(), load_model("iso7962")))
    f = np.geomspace(0.1, 100, 50)
    both = frequency_response(lm, f, ["body.head.a", "sprung.a"])
    assert both.shape == (2, 50)
    np.testing.assert_allclose(both[0], frequency_response(lm, f, "body.head.a"), rtol=1e-13)
    np.testing.assert_allclose(both[1], frequency_response(lm, f, "sprung.a"), rtol=1e-13)


#: The compiled loop weights sample by sample, the stream by a block product over 64
#: samples: the same recursion summed in another order, so the figures differ by
#: rounding only (measured: 1e-13 relative at most on these cases).
FUSED_RTOL = 1e-12


def test_compiled_figures_equal_the_streamed_figures_of_the_same_history():
    """The kernel's own Wk weighting and figure sums (the MTVV window wrapping six
    times) against ComfortStream on the histories it recorded, for both bodies, one
    and two road points."""
    cases = expand(
        {
            "road": "D",
            "speed": [12, 27],
            "duration": 6,
            "body": ["reduced-paper", "iso7962"],
            "car": ["quarter-car", "half-car"],
        }
    )
    rows, hist = run_batched(cases, record=True)
    for case, row, h in zip(cases, rows, hist):
        _assert_streamed_figures(row, h, case.step)


def _assert_streamed_figures(row, histories, step):
    """A sweep row's head and seat figures are ComfortStream's of ``histories`` (head and
    seat acceleration) to FUSED_RTOL."""
    head = stream_comfort_figures(histories["head_acceleration"], 1 / step)
    for k in ("weighted_rms", "vdv", "peak", "crest_factor", "mtvv"):
        assert row[f"head_{k}"] == pytest.approx(getattr(head, k), rel=FUSED_RTOL, abs=0)
    seat = stream_comfort_figures(histories["seat_acceleration"], 1 / step)
    assert row["seat_weighted_rms"] == pytest.approx(seat.weighted_rms, rel=FUSED_RTOL, abs=0)
    assert row["head_comfort"] == head.comfort


@pytest.mark.integration
def test_batched_full_car_sweep_gives_the_figures_of_each_case_run_serially():
    """A batched sweep of full-car cases (four road points on two tracks, 12 cases in
    one task's lanes) against each case run alone: the monolithic reference stepped
    serially on the case's four wheel roads and its histories weighted by ComfortStream.
    Both step the same exact discretization; the loop adds the road points' input columns
    after the state's terms and weights sample by sample, the reference multiplies
    ``[x | u]`` at once and weights by blocks of samples. With the reduced body (no
    output row that cancels, as the ISO body's head does) the figures differ by that
    regrouping only: measured 2.4e-13 relative at most, within FUSED_RTOL. A road point
    left out moves them by percent. Each case alone in the engine gives the same bits
    as in the lanes."""
    import pandas as pd

    from bodyvib.vehicle.quarter_car import track_width, wheel_offsets, wheel_sides
    from bodyvib.vehicle.sweep.engines import case_wheel_inputs
    from bodyvib.vehicle.sweep.run import run_sweep

    spec = {
        "road": ["C", "E"],
        "speed": [10, 25],
        "duration": 3,
        "car": "full-car",
        "body": [
            "reduced-paper",
            {
                "model": "reduced-paper",
                "vary": {"k1": [0.8, 1.2], "c1": [0.8, 1.2]},
                "samples": 2,
                "name": "varied",
            },
        ],
    }
    table = run_sweep(spec, scheduler="serial").sort_values("case_id")
    cases = expand(spec)
    assert len(table) == len(cases) == 12
    for case, (_, row) in zip(cases, table.iterrows()):
        assert pd.isna(row["error"])
        car = case.car_network()
        z, v = case_wheel_inputs(case, wheel_offsets(car), wheel_sides(car), track_width(car))
        ref = reference_run(car, case.body_network(), z, v, case.step)
        _assert_streamed_figures(row, ref, case.step)
    for case, (_, row) in list(zip(cases, table.iterrows()))[::5]:
        alone = run_batched([case])[0][0]
        assert all(alone[f] == row[f] for f in ("head_weighted_rms", "head_vdv", "head_mtvv"))


def _weighted_sums(wk, a, window):
    """sum w^2, sum w^4, max |w| and the largest window sum of w^2, by a plain loop."""
    x = np.zeros(wk.Phi.shape[0])
    w = np.empty(a.size)
    for k in range(a.size):
        if k > 0:
            x = wk.Phi @ x + wk.g_prev * a[k - 1] + wk.g_next * a[k]
        w[k] = wk.c @ x + wk.d * a[k]
    w2 = w * w
    runs = np.convolve(w2, np.ones(window))[: a.size]
    return np.array([w2.sum(), (w2 * w2).sum(), np.abs(w).max(), runs.max()])


@pytest.mark.parametrize("reads", [[2, 2, 4, 4, 6, 6, 8, 8], [1, 2, 3], [1]])
def test_kernel_weighting_of_any_fitting_shape_equals_a_plain_recursion(reads):
    """The loop's written-out weighting rows (eight states, padded when fewer) against
    the recursion evaluated with numpy: random stable coefficients, the head of one
    case driven straight by a road (tolerance: rounding of sums over 400 samples).
    The entries of ``Phi`` past a row's ``reads`` are not read (the reference has
    zeros there)."""
    rng = np.random.default_rng(7)
    n = len(reads)
    read = np.arange(n) < np.array(reads)[:, None]
    Phi = rng.uniform(-0.3, 0.3, (n, n))
    g, c = rng.normal(size=(2, n)), rng.normal(size=n)
    wk = WeightingStep(Phi, g[0], g[1], c, 0.3, reads)
    exact = WeightingStep(Phi * read, g[0], g[1], c, 0.3, reads)
    gz = np.zeros((1, 1, 5))
    gz[0, 0, 1] = 1.0  # the head acceleration is the road's displacement
    z = rng.normal(size=(1, 400))
    sums, _ = run(
        pack(np.zeros((1, 5, 1)), gz, np.zeros((1, 1, 5)), np.zeros((1, 1), int)),
        z,
        np.zeros_like(z),
        wk,
        50,
    )
    np.testing.assert_allclose(sums[:4, 0], _weighted_sums(exact, z[0], 50), rtol=1e-12)


def test_kernel_refuses_a_weighting_that_does_not_fit_its_rows():
    wk = WeightingStep(np.eye(2), np.ones(2), np.ones(2), np.ones(2), 0.0, [1, 3])
    inputs = pack(
        np.zeros((1, 5, 1)), np.zeros((1, 1, 5)), np.zeros((1, 1, 5)), np.zeros((1, 1), int)
    )
    with pytest.raises(ValueError, match="does not fit"):
        run(inputs, np.zeros((1, 10)), np.zeros((1, 10)), wk, 5)


def test_kernel_weights_the_seats_x_and_y_rows_in_the_same_pass():
    """``M``'s last two rows (the seat's x and y) weighted with two more weightings in
    the step of the head's: each row's ``sum a_w^2`` against the numpy recursion, the
    watched row before them and the head's sums as without them (tolerance: rounding
    of sums over 400 samples)."""
    rng = np.random.default_rng(11)
    steps = []
    for reads in ([1, 2, 3], [2, 2, 4, 4, 6, 6]):
        n = len(reads)
        Phi = rng.uniform(-0.3, 0.3, (n, n)) * (np.arange(n) < np.array(reads)[:, None])
        g, c = rng.normal(size=(2, n)), rng.normal(size=n)
        steps.append(WeightingStep(Phi, g[0], g[1], c, rng.normal(), reads))
    wk = steps[0]
    gz = np.zeros((1, 2, 8))  # one state; head, seat, forces, a watched row, then x and y
    gz[0, 0, [1, 6]] = 1.0, 2.0  # road point 0: the head and x = 2 z0
    gz[0, 1, [5, 7]] = 1.0, -1.0  # road point 1: the watched row z1 and y = -z1
    z = rng.normal(size=(2, 400))
    road = np.array([[0, 1]])
    sums, _ = run(pack(np.zeros((1, 8, 1)), gz, 0 * gz, road), z, 0 * z, wk, 50, axes=steps)
    for j, (w, a) in enumerate((w, a) for w in steps for a in (2 * z[0], -z[1])):
        expected = _weighted_sums(w, a, 50)[0]
        assert sums[-4 + j, 0] == pytest.approx(expected, rel=1e-12), j
    np.testing.assert_allclose(sums[:4, 0], _weighted_sums(wk, z[0], 50), rtol=1e-12)
    assert sums.shape[0] == len(SUMS) + 1 + 4 and sums[len(SUMS), 0] == z[1].max()
    g6 = gz[:, :, :6]
    alone, _ = run(pack(np.zeros((1, 6, 1)), g6, 0 * g6, road), z, 0 * z, wk, 50)
    np.testing.assert_array_equal(sums[: len(SUMS) + 1], alone)
    eight = WeightingStep(np.eye(8), np.ones(8), np.ones(8), np.eye(8)[6], 0.0, [8] * 8)
    with pytest.raises(ValueError, match="first six states"):
        run(pack(np.zeros((1, 8, 1)), gz, 0 * gz, road), z, 0 * z, wk, 50, axes=[eight] * 2)


def test_spectral_half_car_rows_carry_the_seats_axes():
    """The seat's x and pitch of a half car on an ISO 8608 road: the spectral engine's
    figures against the integral of the pitch acceleration's response (body.alpha, not
    the seat's .ax row) times the seat height, weighted by Wd and We, by trapezoids on
    another grid; a quarter car's seat columns are NaN."""
    from bodyvib.comfort import weighting

    cases = expand(
        {"road": "C", "speed": 20, "body": "reduced-paper", "car": ["half-car", "quarter-car"]}
    )
    half, quarter = run_spectral(cases)
    car = cases[0].car_network()
    lm = linear_model(seated_system(car, cases[0].body_network()))
    h, wheelbase = car.parameters["seat_h"], car.parameters["lf"] + car.parameters["lr"]
    f = np.geomspace(N_BAND[0] * 20, N_BAND[1] * 20, 20000)
    alpha = frequency_response(lm, f, "body.alpha", delays=[0.0, wheelbase / 20])
    S = displacement_psd(f / 20, "C") / 20
    for name, scale, key in (("Wd", h, "seat_aw_x"), ("We", 1.0, "seat_aw_ry")):
        ms = np.trapezoid(np.abs(scale * alpha * weighting(name, f)) ** 2 * S, f)
        assert half[key] == pytest.approx(np.sqrt(ms), rel=1e-4), key
    assert half["seat_aw_y"] == 0.0 and np.isnan(half["seat_aw_rx"])
    z = half["seat_weighted_rms"]
    assert half["seat_aw_z"] == z
    assert half["seat_av"] == pytest.approx(np.hypot(half["seat_aw_x"], z), rel=1e-12)
    assert half["seat_rotation_av"] == pytest.approx(0.40 * half["seat_aw_ry"], rel=1e-12)
    assert all(np.isnan(quarter[k]) for k in ("seat_aw_x", "seat_av", "seat_aw_ry"))


def _full_car_psd(case, f, output, name):
    """One-sided PSD of a full car's output weighted by ``name``, from each wheel's own
    response and the four wheels' cross-spectral matrix: ``S_ij = S c_ij exp(-i w (t_i -
    t_j))``, ``c_ij`` 1 on one track and the tracks' ``rho(n)`` across them."""
    from bodyvib.comfort import weighting
    from bodyvib.runtime.network import linearized
    from bodyvib.vehicle.quarter_car import track_width, wheel_offsets, wheel_sides
    from bodyvib.vehicle.road.synthetic import track_coherence

    car = case.car_network()
    lm = linear_model(seated_system(linearized(car), case.body_network()))
    v, sides, behind = case.speed, wheel_sides(car), wheel_offsets(car)
    H = [
        frequency_response(lm, f, output, gains=[float(j == i) for j in range(4)]) for i in range(4)
    ]
    rho = track_coherence(f / v, track_width(car))
    S = displacement_psd(f / v, case.road) / v
    total = np.zeros(f.size)
    for i in range(4):
        for j in range(4):
            c = 1.0 if sides[i] == sides[j] else rho
            lag = np.exp(-2j * np.pi * f * (behind[i] - behind[j]) / v)
            total += np.real(H[i] * np.conj(H[j]) * c * lag)
    return total * S * np.abs(weighting(name, f)) ** 2


@pytest.mark.integration
def test_spectral_full_car_on_two_correlated_tracks():
    """The full car on an ISO 8608 road's two tracks (correlated as an isotropic surface):
    the spectral engine's head and seat figures against the integral of the PSD built
    from each wheel's response and the four wheels' cross-spectral matrix (1e-6: two
    grids), and against eight 60 s time-domain runs on synthesized two-track roads within
    the estimator's statistics (as for the quarter car above). The seat's y, zero on one
    track, comes from the tracks' difference alone."""
    from bodyvib.vehicle import seat_point

    T, seeds = 60.0, 8
    cases = expand(
        {"road": "C", "speed": 20, "seed": list(range(seeds)), "duration": T,
         "body": "reduced-paper", "car": "full-car"}
    )  # fmt: skip
    spec, (timed, _) = run_spectral(cases), run_batched(cases)
    floor = seat_point(cases[0].car_network())
    f = np.geomspace(N_BAND[0] * 20, N_BAND[1] * 20, 20000)
    for key, output, name in (
        ("head_weighted_rms", "body.head.a", "Wk"),
        ("seat_aw_y", f"{floor}.ay", "Wd"),
        ("seat_aw_x", f"{floor}.ax", "Wd"),
    ):
        G = _full_car_psd(cases[0], f, output, name)
        expected = np.trapezoid(G, f)
        assert spec[0][key] ** 2 == pytest.approx(expected, rel=1e-6), key
        ms = np.array([r[key] ** 2 for r in timed])
        sigma = np.sqrt(np.trapezoid(G**2, f) / T)
        assert abs(ms.mean() - expected) < 4 * sigma / np.sqrt(seeds), key
    assert spec[0]["seat_aw_y"] > 0.05 * spec[0]["head_weighted_rms"]


@pytest.mark.integration
@pytest.mark.parametrize("car", ["half-car", "full-car"])
def test_batched_rows_carry_the_seats_axes_of_the_reference_run(car):
    """The batched engine weights the seat's x and y with Wd and We by the kernel's
    recursion (:func:`bodyvib.comfort.weighting_statespace`); the same figures from the
    monolithic reference run's histories by the FFT filters of
    :func:`bodyvib.comfort.vibration_totals` (:func:`bodyvib.vehicle.seat_axes`)."""
    from bodyvib.vehicle import seat_axes, seat_height
    from bodyvib.vehicle.quarter_car import track_width, wheel_offsets, wheel_sides
    from bodyvib.vehicle.sweep.engines import case_wheel_inputs

    case = expand({"road": "C", "speed": 20, "duration": 10, "body": "reduced-paper", "car": car})
    (row,), _ = run_batched(case)
    net = case[0].car_network()
    z, v = case_wheel_inputs(case[0], wheel_offsets(net), wheel_sides(net), track_width(net))
    ref = reference_run(net, case[0].body_network(), z, v, case[0].step)
    x, y = ref["seat_acceleration_x"], ref["seat_acceleration_y"]
    expected = seat_axes(x, y, ref["seat_acceleration"], 1000.0, seat_height(net))
    for key, value in expected.items():
        assert row[key] == pytest.approx(value, rel=1e-3, abs=1e-12), key
    assert np.isnan(row["seat_aw_rx"]) == (car == "half-car")
