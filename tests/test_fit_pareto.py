"""The trade-off of Eq. 3's J against the transmissibility peak: NSGA-II front, files, CLI."""

import csv
import json

import numpy as np
import pytest
from helpers import ROOT, run_cli
from scipy.optimize import minimize_scalar

from bodyvib.fit.config import load_config
from bodyvib.fit.objective import model_target, parameter_array
from bodyvib.fit.pareto import (
    _GRID,
    FREQUENCY_TOLERANCE_HZ,
    MODULUS_TOLERANCE,
    chosen_points,
    pareto_front,
    peak_error,
    peaks,
    reference_peak,
    write_pareto,
)
from bodyvib.fit.space import REDUCED_PARAMETERS
from bodyvib.frequency.response import transmissibility
from bodyvib.models import load_model

#: A short NSGA-II for tests (the shipped 100 x 200 takes a few seconds).
SMALL = {"pareto": {"population": 40, "generations": 40}}
SHIPPED = load_model(f"{ROOT}/params/refit-iso7962.json")


def exact_peak(net, f0):
    """The |T| maximum by a bounded scalar search on the state-space response."""
    r = minimize_scalar(
        lambda f: -abs(transmissibility(net, [f])[0]),
        bounds=(0.9 * f0, 1.1 * f0),
        method="bounded",
        options={"xatol": 1e-10},
    )
    return -r.fun, r.x


@pytest.mark.parametrize("name", ["reduced-paper", "refit", "iso7962"])
def test_peaks_match_a_scalar_search_on_the_state_space_response(name):
    """The parabola through the grid maximum (ln f step h) errs by O(h^2) in frequency and
    O(h^3) in modulus: bound them by h^2 and h^3."""
    h = np.log(_GRID[1] / _GRID[0])
    if name == "iso7962":
        net = load_model(name)
        m, f = reference_peak(net)
    else:
        net = SHIPPED if name == "refit" else load_model(name)
        m, f = peaks(parameter_array(net))
    m_exact, f_exact = exact_peak(net, f)
    assert m == pytest.approx(m_exact, rel=h**3)
    assert f == pytest.approx(f_exact, rel=h**2)


def test_peak_error_is_in_units_of_the_check_tolerances():
    ref = np.array([1.665, 4.45])
    assert peak_error([1.665 * (1 - MODULUS_TOLERANCE), 4.45], ref) == pytest.approx(1.0)
    assert peak_error([1.665, 4.45 + FREQUENCY_TOLERANCE_HZ], ref) == pytest.approx(1.0)
    assert peak_error([1.665, 4.45], ref) == 0.0


@pytest.fixture(scope="module")
def front():
    cfg = load_config(overrides=SMALL)
    target = model_target("iso7962", config=cfg)
    start = [SHIPPED.parameters[k] for k in REDUCED_PARAMETERS]
    return pareto_front(target, cfg, seed=1, start=start)


def test_front_is_non_dominated_and_its_min_J_end_is_the_refit(front):
    J, e = front.objective, front.peak_error
    assert len(J) >= 10
    for i in range(len(J)):
        dominated = (J <= J[i]) & (e <= e[i]) & ((J < J[i]) | (e < e[i]))
        assert not dominated.any(), i
    # the first population held the single-objective optimum: the min-J end is J* (the
    # shipped refit's value, to the objective's rounding)
    assert J.min() == pytest.approx(SHIPPED.provenance["objective"]["value_per_s"], rel=1e-9)
    # the values are what they claim: recompute the objective and the peak error
    np.testing.assert_allclose(front.target.objective(front.parameters), J, rtol=1e-12)
    np.testing.assert_allclose(
        peak_error(peaks(front.parameters), front.reference_peak), e, rtol=1e-12
    )
    # every point keeps the pinned total mass
    np.testing.assert_allclose(front.parameters[:, 0] + front.parameters[:, 1], 75.0, rtol=1e-12)


def test_front_files_parse_and_carry_provenance(front, tmp_path):
    files = write_pareto(tmp_path, front, command="bodyvib fit --pareto --report x")
    chosen = chosen_points(front)
    assert {"min-J", "knee", "min-peak-error"} <= set(chosen)
    with open(tmp_path / "pareto_front.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(front.objective)
    np.testing.assert_allclose([float(r["J_per_s"]) for r in rows], front.objective, rtol=1e-7)
    assert (tmp_path / "pareto_front.png").read_bytes()[:4] == b"\x89PNG"
    for name, i in chosen.items():
        path = tmp_path / f"pareto-{name}.json"
        assert str(path) in files
        net = load_model(path)  # a model every command reads
        prov = json.loads(path.read_text())["provenance"]
        for key in (
            "method",
            "seed",
            "objectives",
            "reference_model",
            "date",
            "bodyvib_version",
            "library",
        ):
            assert prov[key] is not None, key
        assert prov["method"] == "NSGA-II" and prov["reference_model"] == "iso7962"
        assert prov["objectives"]["J_per_s"] == pytest.approx(front.objective[i])
        assert float(front.target.objective(parameter_array(net))) == pytest.approx(
            front.objective[i], rel=1e-9
        )


@pytest.mark.integration
def test_cli_pareto_errors_are_one_line(tmp_path):
    out = str(tmp_path / "r.json")
    for args, match in (
        (["--pareto"], "give --report"),
        (["--pareto", "--report", str(tmp_path), "--measured", "x.csv"], "reference model"),
    ):
        r = run_cli("fit", "--out", out, "--quiet", *args)
        assert r.returncode == 2 and match in r.stderr and r.stderr.count("\n") == 1, r.stderr
    blocker = tmp_path / "file"
    blocker.write_text("")
    r = run_cli("fit", "--out", out, "--quiet", "--pareto", "--report", str(blocker))
    assert r.returncode == 2 and "is a file" in r.stderr and r.stderr.count("\n") == 1
    assert not (tmp_path / "r.json").exists()  # refused before the search


def test_check_report_points_to_the_front_when_the_peak_fails():
    from types import SimpleNamespace as NS

    from bodyvib.vehicle.check import Comparison, Criterion
    from bodyvib.vehicle.report import PEAK_HINT, format_report

    peak = NS(to_dict=lambda: {"modulus": 1.45, "frequency_hz": 4.3})
    body = NS(
        figures=NS(
            weighted_rms=1.0, vdv=3.0, peak=4.0, crest_factor=4.0, mtvv=1.2, comfort="uncomfortable"
        ),
        transmissibility=NS(peak=peak),
        coupling_nrmse=3e-4,
        real_time_factor=30.0,
        seat_figures=NS(weighted_rms=0.9),
        forces={},
    )
    study = NS(
        settings=NS(speed=20, duration=30, step=1e-3),
        master="m",
        road={"name": "C"},
        bodies={"A": body, "B": body},
    )

    def comparison(passed):
        c = Criterion(
            name="transmissibility_peak",
            reduced=1.45,
            iso=1.67,
            difference=0.13,
            tolerance=0.1,
            unit="",
            passed=passed,
        )
        return Comparison(reduced="A", iso="B", criteria=[c], verdict="PASS" if passed else "FAIL")

    assert PEAK_HINT in format_report(study, comparison(False)).splitlines()
    assert "--pareto" not in format_report(study, comparison(True))
