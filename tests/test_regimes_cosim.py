"""The tire contact and the stops in co-simulation: the pythonfmu car FMU locates its
events inside doStep; the run reports them (text, JSON, CSV)."""

import json

import numpy as np
import pytest
from helpers import run_cli
from test_regimes import H, hand_written_solution

from bodyvib.models import load_model
from bodyvib.runtime.network import static_preloads
from bodyvib.vehicle.quarter_car import load_car
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.study import run_study

pytestmark = pytest.mark.integration


def _study(python_fmus, road, duration):
    return run_study(
        {"b": python_fmus["HumanBody3DOF"]},
        python_fmus["QuarterCar"],
        RunSettings(road, 20.0, duration, H),
        histories=True,
    )


def test_cosim_over_the_bump_matches_hand_written_equations(python_fmus):
    """The 80 mm full-cosine bump at 20 m/s through the FMUs: head acceleration within
    0.2 % NRMSE of the independent solution (with the coupling error), lift-offs and
    landings at the communication point after each located one, tire force >= 0."""
    grid, head, events, f0 = hand_written_solution(1.5)
    study = _study(python_fmus, "sine:h=0.08,l=1.0,at=10", 1.5)
    b = study.bodies["b"]
    run = b.run
    err = np.sqrt(np.mean((run["head_acceleration"] - head) ** 2) / np.mean(head**2))
    assert err < 0.002, err
    flag = run["tire_contact"]
    changes = grid[1:][np.diff(flag) != 0]  # the first point after each switching
    theirs = [t for t, name, _ in events if name == "tire"]
    assert changes.size == len(theirs) == 4
    assert np.all(np.abs(changes - np.array(theirs)) <= H)
    assert np.min(run["tire_force"] + f0) >= -1e-9 * f0
    assert b.events.lift_offs == 2 and b.events.smallest_tire_load_ratio == 0.0
    assert b.events.stop_contacts == 1 and b.events.largest_stop_force_n > 1000
    assert b.reference_events["tire"]["lift_offs"] == 2
    doc = json.loads(json.dumps(study.to_dict()))
    assert doc["bodies"]["b"]["events"]["lift_offs"] == 2


def test_cosim_over_the_pothole_leaves_the_road(python_fmus):
    study = _study(python_fmus, "pothole", 2.0)
    run = study.bodies["b"].run
    body = load_model("reduced-paper")
    f0 = static_preloads(load_car().with_parameters(m_occupant=body.total_mass()))["tire"]
    assert study.bodies["b"].events.lift_offs >= 1
    assert np.min(run["tire_contact"]) == 0.0
    assert np.min(run["tire_force"] + f0) >= -1e-9 * f0


def test_cli_linear_runs_the_linear_car_and_the_report_says_what_happened(tmp_path):
    """`cosim --linear` over the bump pulls the wheel down with the road (the linear
    tire force far below minus the static load); the default lifts it twice and says so."""
    out = {}
    for name, extra in (("nl", []), ("lin", ["--linear"])):
        js = tmp_path / f"{name}.json"
        r = run_cli(
            "cosim",
            "--road",
            "sine:h=0.08,l=1.0,at=10",
            "--duration",
            "1.5",
            "--quiet",
            "--json",
            str(js),
            "--csv",
            str(tmp_path / f"{name}.csv"),
            *extra,
        )
        assert r.returncode == 0, r.stderr
        out[name] = (r.stdout, json.loads(js.read_text()))
    text, doc = out["nl"]
    assert "lift-offs (air, longest)" in text and "2 (80 ms, 66 ms)" in text
    assert "smallest tire-load ratio" in text
    assert doc["bodies"]["HumanBody3DOF"]["events"]["lift_offs"] == 2
    assert "lift-offs" not in out["lin"][0]
    header = (tmp_path / "nl.csv").read_text().splitlines()[0]
    assert "tire_contact [1]" in header
    lin = np.genfromtxt(tmp_path / "lin.csv", delimiter=",", names=True)
    assert lin["tire_force_N"].min() < -1.5 * 4107.8  # the linear tire pulls


def test_cli_linear_with_a_car_fmu_is_refused(tmp_path, python_fmus):
    r = run_cli("cosim", "--linear", "--car-fmu", python_fmus["QuarterCar"], "--quiet")
    assert r.returncode != 0
    assert r.stderr.strip().count("\n") == 0 and "--linear" in r.stderr
