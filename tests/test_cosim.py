"""Co-simulation of the real FMUs in fmpy against the monolithic reference; the CLI end to end.

The FMUs are built once per session, in a subprocess (an FMU's module names are
global to the process that loads it), into a temporary folder.
"""

import csv
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from helpers import ROOT, run_cli

from bodyvib.comfort.figures import weighted_rms
from bodyvib.comfort.stream import stream_comfort_figures
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.cosim import cosimulate, model_from_fmu, open_fmu, write_csv
from bodyvib.vehicle.reference import nrmse, reference_run
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.road.synthetic import make_road, road_input
from bodyvib.vehicle.study import coupling_error_sweep, run_study

pytestmark = pytest.mark.integration


@pytest.fixture(scope="session")
def fmus(python_fmus, tmp_path_factory):
    cushion = tmp_path_factory.mktemp("fmus_cushion")
    subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from bodyvib.vehicle.fmus import build_project_fmu; "
            "build_project_fmu('QuarterCar', sys.argv[1], 'quarter-car-cushion')",
            str(cushion),
        ],
        check=True,
        cwd=ROOT,
        capture_output=True,
    )
    return {
        "body": python_fmus["HumanBody3DOF"],
        "iso": python_fmus["HumanBodyISO7962"],
        "car": python_fmus["QuarterCar"],
        "cushion": str(cushion / "QuarterCar.fmu"),
    }


@pytest.mark.parametrize("which", ["body", "iso"])
def test_coupling_error_meets_target_at_1ms(fmus, which):
    """Issue target: head-acceleration NRMSE <= 0.05 % at 1 ms on a class C road at
    20 m/s. 10 s holds about 8 body-bounce periods and 45 periods of the 4.5 Hz body
    resonance, enough for a stable r.m.s. The plain master (seat force held) is far
    above the target, so the extrapolation is what meets it."""
    study = run_study({"b": fmus[which]}, fmus["car"], RunSettings("C", 20.0, 10.0, 1e-3))
    err = study.bodies["b"].coupling_nrmse
    assert err <= 5e-4
    held = run_study(
        {"b": fmus[which]}, fmus["car"], RunSettings("C", 20.0, 10.0, 1e-3), extrapolate=False
    )
    assert held.bodies["b"].coupling_nrmse > 5 * err
    doc = json.loads(json.dumps(held.to_dict()))  # the typed study's JSON form
    assert doc["bodies"]["b"]["coupling_nrmse"] == held.bodies["b"].coupling_nrmse
    assert doc["settings"]["master"] == "gauss-seidel, seat force held"


def test_study_options_and_keywords_record_the_same_run(fmus):
    """A StudyOptions and the old keywords are one call; the recorder's plot window and
    pair sums, kept block by block (333 points: the window straddles blocks), are the
    slices and sums of the full histories."""
    from bodyvib.vehicle.study import StudyOptions

    bodies = {"a": fmus["body"], "b": fmus["iso"]}
    settings = RunSettings("C", 20.0, 2.0, 1e-3)
    opts = StudyOptions(histories=True, block=333, window_s=0.5, reference=False)
    st = run_study(bodies, fmus["car"], settings, opts)
    kw = run_study(
        bodies, fmus["car"], settings, histories=True, block=333, window_s=0.5, reference=False
    )
    for label in bodies:
        head = st.bodies[label].run["head_acceleration"]
        assert np.array_equal(head, kw.bodies[label].run["head_acceleration"])
        inside = (st.time >= st.window_time[0]) & (st.time <= st.window_time[-1])
        assert np.array_equal(st.bodies[label].head_window, head[inside])
        assert st.bodies[label].coupling_nrmse is None
    assert st.window_time[-1] - st.window_time[0] == pytest.approx(0.5)
    a, b = (st.bodies[k].run["head_acceleration"] for k in "ab")
    num, den = st.history_sums[("a", "b")]
    assert num == pytest.approx(np.sum((a - b) ** 2), rel=1e-12)
    assert den == pytest.approx(np.sum(b**2), rel=1e-12)
    with pytest.raises(TypeError, match="'histoires'"):
        run_study(bodies, fmus["car"], settings, histoires=True)


def test_coupling_error_is_second_order_in_the_step(fmus):
    """Linear extrapolation makes the coupling error O(h^2): halving the step
    divides it by about 4 (3 to 5 allows for the higher-order terms)."""
    rows = coupling_error_sweep([2e-3, 1e-3], fmus["body"], fmus["car"], RunSettings(duration=5.0))
    ratio = rows[0]["coupling_nrmse"] / rows[1]["coupling_nrmse"]
    assert 3.0 < ratio < 5.0


def test_cushion_car_co_simulates_against_its_reference(fmus):
    """The cushion puts a 3 kg pan between car and body: the pan on the body's seat
    spring is an ~80 Hz mode that the coupling has to resolve, so at 1 ms the error
    is about 0.06 %
    (docs/getting_started.md, "The master and its coupling error"); the 0.05 % target holds at 0.5 ms (second order: 4x less)."""
    study = run_study({"b": fmus["body"]}, fmus["cushion"], RunSettings("C", 20.0, 5.0, 5e-4))
    assert study.bodies["b"].coupling_nrmse <= 5e-4
    # the cushion's 3-4 Hz seat resonance changes the ride: not the rigid seat's figures
    rigid = run_study({"b": fmus["body"]}, fmus["car"], RunSettings("C", 20.0, 5.0, 5e-4))
    assert study.bodies["b"].figures.weighted_rms != pytest.approx(
        rigid.bodies["b"].figures.weighted_rms, rel=0.02
    )


def test_master_outputs_match_reference_signal_by_signal(fmus):
    h, T, V = 1e-3, 4.0, 20.0
    t = np.arange(int(round(T / h)) + 1) * h
    z, v = road_input(make_road("bump", V, T), V, t)
    iso = model_from_fmu(fmus["iso"])
    occupant = {"m_occupant": iso.total_mass()}  # its weight on the tire, as the reference's
    with (
        open_fmu(fmus["car"], "car", start_values=occupant) as car,
        open_fmu(fmus["iso"], "body") as body,
    ):
        run = cosimulate(car, body, z, v, h)
    ref = reference_run(model_from_fmu(fmus["car"]), iso, z, v, h)
    for k in (
        "seat_displacement",
        "seat_acceleration",
        "tire_force",
        "suspension_deflection",
        "seat_force",
        "head_acceleration",
        "head_displacement",
        "torso_displacement",
    ):
        assert nrmse(run[k], ref[k]) < 2e-3, k


def test_csv_round_trip(fmus, tmp_path):
    h = 1e-3
    z, v = road_input(make_road("C", 20.0, 1.0), 20.0, np.arange(1001) * h)
    with open_fmu(fmus["car"], "car") as car, open_fmu(fmus["body"], "body") as body:
        run = cosimulate(car, body, z, v, h)
    path = tmp_path / "run.csv"
    write_csv(path, run)
    with open(path) as f:
        rows = list(csv.reader(f))
    assert rows[0][0] == "time [s]" and "head_acceleration [m/s2]" in rows[0]
    col = rows[0].index("head_acceleration [m/s2]")
    back = np.array([float(r[col]) for r in rows[1:]])
    assert np.allclose(back, run["head_acceleration"], rtol=1e-9, atol=1e-12)


def _description_only_fmu(path, fmi):
    """A ``.fmu`` holding only the reduced body's model description (FMI 2.0 or 3.0), as the
    native build writes it: enough for the refusals made from the description alone."""
    import zipfile

    from bodyvib.fmu.native import model_description, native_model
    from bodyvib.models import load_model

    nm = native_model("body", load_model("reduced-paper"), "HumanBody3DOF")
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("modelDescription.xml", model_description(nm, "{0-0-0-0-0}", fmi))
    return str(path)


@pytest.mark.parametrize(
    "what, kind, message",
    [
        ("junk", "body", r"'.*junk\.fmu' is not a readable FMU: File is not a zip file"),
        ("fmi3", "body", r"FMU '.*fmi3\.fmu' is FMI 3\.0; FMI 2\.0 is needed"),
        ("fmi2", "car", r"lacks the car interface: it is a body FMU \(give it to 'body_fmus'\)"),
    ],
)
def test_check_fmu_and_open_fmu_refuse_a_description_alike(tmp_path, what, kind, message):
    # both read the model description through one function: the same refusal, and open_fmu
    # makes it before extracting or instantiating anything
    from bodyvib.vehicle.cosim import check_fmu

    path = tmp_path / f"{what}.fmu"
    if what == "junk":
        path.write_text("not a zip")
    else:
        _description_only_fmu(path, 3 if what == "fmi3" else 2)
    with pytest.raises(BodyvibError, match=message):
        check_fmu(path, kind)
    with pytest.raises(BodyvibError, match=message):
        with open_fmu(path, kind):
            pass


def test_a_description_that_passes_check_fmu_goes_on_to_the_binary(tmp_path):
    from bodyvib.vehicle.cosim import check_fmu

    path = _description_only_fmu(tmp_path / "fmi2.fmu", 2)
    check_fmu(path, "body")  # the description is a valid FMI 2.0 body
    with pytest.raises(BodyvibError, match="has no binary for this platform"):
        with open_fmu(path, "body"):
            pass


def test_fmu_without_body_interface_is_refused(fmus):
    with pytest.raises(BodyvibError, match="lacks the body interface"):
        with open_fmu(fmus["car"], "body"):
            pass
    with pytest.raises(BodyvibError, match="does not exist"):
        with open_fmu("/nonexistent/Body.fmu", "body"):
            pass


def test_check_cli_end_to_end(fmus, tmp_path):
    """`bodyvib check` with FMUs built by the command itself; JSON keys as documented
    and consistent with the CSV written in the same run (the weighted r.m.s. is
    recomputed from the CSV's head acceleration)."""
    p = run_cli(
        "check",
        "--duration",
        "6",
        "--json",
        "c.json",
        "--plot",
        "c.png",
        "--csv",
        "c.csv",
        cwd=tmp_path,
    )
    assert p.returncode == 0, p.stderr
    assert "verdict: " in p.stdout
    doc = json.loads((tmp_path / "c.json").read_text())
    assert set(doc["bodies"]) == {"HumanBody3DOF", "HumanBodyISO7962"}
    for b in doc["bodies"].values():
        for key in ("weighted_rms", "vdv", "peak", "coupling_nrmse"):
            assert np.isfinite(b[key]), key
        assert b["coupling_nrmse"] <= 5e-4
    assert doc["verdict"] in ("PASS", "FAIL")
    assert doc["verdict"] == (
        "PASS" if all(c["passed"] for c in doc["check"]["criteria"]) else "FAIL"
    )
    assert (tmp_path / "c.png").stat().st_size > 10000
    with open(tmp_path / "c.csv") as f:
        rows = list(csv.reader(f))
    col = rows[0].index("HumanBody3DOF.head_acceleration [m/s2]")
    a = np.array([float(r[col]) for r in rows[1:]])
    # every point, every column (with each body's neck and lumbar force, and the seat's
    # x and y accelerations, NaN: the quarter car's body does not pitch or roll), streamed
    assert len(rows) == 1 + 6001 and len(rows[0]) == 26  # with tire_contact, stop_force
    sideways = rows[0].index("seat_acceleration_y [m/s2]")
    assert all(r[sideways] == "nan" for r in rows[1:])
    for label, b in doc["bodies"].items():
        neck = np.array([float(r[rows[0].index(f"{label}.neck_force [N]")]) for r in rows[1:]])
        assert b["neck_force"]["peak"] == pytest.approx(neck[np.argmax(np.abs(neck))], rel=1e-6)
        assert b["neck_force"]["rms"] == pytest.approx(np.sqrt(np.mean(neck**2)), rel=1e-6)
    got = doc["bodies"]["HumanBody3DOF"]["weighted_rms"]
    # the run's figures come from the recursive Wk filter as the run goes (10-digit CSV)
    assert stream_comfort_figures(a, 1000.0).weighted_rms == pytest.approx(got, rel=1e-8)
    # the MTVV (largest 1 s running r.m.s.) is among them, from the same stream
    mtvv = doc["bodies"]["HumanBody3DOF"]["mtvv"]
    assert stream_comfort_figures(a, 1000.0).mtvv == pytest.approx(mtvv, rel=1e-8)
    assert "MTVV" in p.stdout
    # and sit (pi/fs)^2 <f^2> / 3 below the FFT weighting of the whole record (2e-4 here)
    assert 0 < 1 - got / weighted_rms(a, 1000.0) < 5e-4


def test_cosim_cli_with_iso_body_fmu(fmus, tmp_path):
    p = run_cli(
        "cosim",
        "--road",
        "B",
        "--duration",
        "3",
        "--body",
        fmus["iso"],
        "--car-fmu",
        fmus["car"],
        "--json",
        "r.json",
        "--quiet",
        cwd=tmp_path,
    )
    assert p.returncode == 0, p.stderr
    doc = json.loads((tmp_path / "r.json").read_text())
    assert list(doc["bodies"]) == ["HumanBodyISO7962"]
    assert doc["bodies"]["HumanBodyISO7962"]["coupling_nrmse"] <= 5e-4


@pytest.mark.parametrize(
    "args, words",
    [
        (["--road", "Q"], "unknown road"),
        (["--speed", "-3"], "speed must be a positive"),
        (["--step", "0"], "step must be a positive"),
        (["--duration", "-1"], "duration must be a positive"),
        (["--body", "missing.fmu"], "does not exist"),
        (["--seed", "-1"], "seed must be a non-negative integer"),
        (["--car", "nope"], "unknown vehicle model 'nope'"),
        (["--params", "missing.json"], "model file 'missing.json' does not exist"),
    ],
)
def test_cli_errors_are_one_line(tmp_path, args, words):
    p = run_cli("cosim", "--quiet", *args, cwd=tmp_path)
    assert p.returncode == 2
    assert words in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_bad_car_model_is_refused_before_any_fmu_is_built(tmp_path):
    """A mistyped --car is refused before any FMU is built, not after a HumanBody3DOF build."""
    p = run_cli("cosim", "--car", "nope", cwd=tmp_path)
    assert p.returncode == 2 and "unknown vehicle model" in p.stderr
    assert "building" not in p.stderr


def test_example_coupling_sweep_runs():
    """examples/cosim_coupling_sweep.run on a short road: the extrapolating master
    beats the plain one at every step, and both errors shrink with the step."""
    sys.path.insert(0, os.path.join(ROOT, "examples"))
    try:
        import cosim_coupling_sweep
    finally:
        sys.path.pop(0)
    rows = cosim_coupling_sweep.run(steps=(4e-3, 1e-3), duration=3.0)
    assert all(r["extrapolated"] < r["held"] for r in rows)
    assert rows[1]["held"] < rows[0]["held"] and rows[1]["extrapolated"] < rows[0]["extrapolated"]


@pytest.mark.integration
def test_report_and_json_name_the_car_seat_and_controller(fmus, tmp_path, capsys):
    """``cosim --json`` recorded neither the car, the seat nor the control law, and the text
    header did not name the seat; ``check --road D`` ran its two comfort words together."""
    from bodyvib.cli.main import main

    out = tmp_path / "run.json"
    argv = ["cosim", "--car", "quarter-car-active", "--seat", "cushion", "--control"]
    argv += ["skyhook:c=3000", "--duration", "1", "--quiet", "--body", fmus["body"]]
    assert main(argv + ["--json", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == "car quarter-car-active, seat cushion, controller skyhook c_sky = 3000 N s/m"
    assert json.loads(out.read_text())["vehicle"] == {
        "car": "quarter-car-active",
        "seat": "cushion",
        "control": {
            "law": "skyhook c_sky = 3000 N s/m",
            "given": "skyhook:c=3000",
            "c_sky_N_s_m": 3000.0,
            "c_ground_N_s_m": 0.0,
            "semi_active": False,
        },
    }
    argv = ["check", "--road", "D", "--duration", "2", "--quiet", "--body", fmus["body"]]
    assert main(argv + ["--iso-body", fmus["iso"], "--car-fmu", fmus["car"]]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith(f"car {fmus['car']}, no seat")
    comfort = next(line for line in lines if line.startswith("comfort"))
    words = "very uncomfortable / extremely uncomfortable"
    assert comfort.split("  ")[-1].strip() == words, comfort  # each cell after two spaces
    assert comfort.count(words) == 2 and words + words[0] not in comfort
