"""``bodyvib design``: closed-form optima found, bad specs refused, files others read.

The two-mass quarter car on a white-velocity road (Gobbi & Mastinu, J. Sound Vib. 245,
2001; see tests/test_random_response.py) has, for the suspension damping c,

    var(body acceleration) ~ kt c + k^2 (ms + mu) / c
        -> minimum at c_a = k sqrt((ms + mu) / kt)
    var(tire force) ~ [kt M^2 c^2 + k^2 M^3 - 2 k kt ms mu M + kt^2 ms^2 mu] / c, M = ms + mu
        -> minimum at c_t = sqrt(k^2 M^3 - 2 k kt ms mu M + kt^2 ms^2 mu) / (M sqrt(kt)).

Both are of the form a c + b / c, decreasing then increasing, so the Pareto set of
the two in c alone is the interval between c_a and c_t.
"""

import json
import math
import os
import time

import numpy as np
import pytest

from bodyvib.cli.main import main
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.design import design, parse_spec

MS, MU, K, KT = 290.0, 59.0, 16812.0, 190000.0
M = MS + MU
C_ACC = K * math.sqrt(M / KT)
C_TIRE = math.sqrt(K**2 * M**3 - 2 * K * KT * MS * MU * M + KT**2 * MS**2 * MU) / (
    M * math.sqrt(KT)
)

BASE = {
    "car": "quarter-car",
    "body": None,
    "parameters": {"cs": {"min": 100, "max": 10000, "scale": "log"}},
    "operating_points": [{"road": "C", "speed": 20}],
    "objectives": ["rms:sprung.a"],
}


@pytest.mark.parametrize("method", ["ga", "cmaes"])
def test_finds_the_comfort_optimum_damping(method):
    spec = parse_spec({**BASE, "search": {"method": method, "population": 16, "generations": 20}})
    c = design(spec, verify=False).chosen[0].values["cs"]
    assert c == pytest.approx(C_ACC, rel=0.01)  # measured: 5e-8


@pytest.mark.parametrize("method", ["ga", "cmaes"])
def test_finds_the_road_holding_optimum_damping(method):
    """CMA-ES on one parameter ended in cma's ``not yet initialized (dimension needed)``:
    one coordinate is searched on a grid refined by bounded Brent."""
    search = {"method": method, "population": 16, "generations": 20}
    spec = parse_spec({**BASE, "objectives": ["tire_load_ratio"], "search": search})
    c = design(spec, verify=False).chosen[0].values["cs"]
    assert c == pytest.approx(C_TIRE, rel=0.01)  # measured: 7e-8 (ga), 3e-8 (cmaes)


def test_pareto_set_is_the_interval_between_the_optima():
    spec = parse_spec(
        {**BASE, "objectives": ["rms:sprung.a", "tire_load_ratio"], "search": {"seed": 3}}
    )
    r = design(spec, verify=False)
    c = r.values[:, 0]
    assert C_ACC < C_TIRE
    # a point just outside is dominated only at second order (both minima are flat:
    # 1e-3 in c is 1e-7 in the objective), which a finite population cannot resolve
    assert np.all(c > C_ACC * (1 - 1e-3)) and np.all(c < C_TIRE * (1 + 1e-3))
    assert c.min() == pytest.approx(C_ACC, rel=0.02)  # the front reaches both ends
    assert c.max() == pytest.approx(C_TIRE, rel=0.02)
    assert np.all(np.diff(r.objectives[:, 1]) <= 0)  # sorted by one, the other falls


def test_constraint_moves_the_optimum_onto_its_limit():
    """Minimum body acceleration with the 3-sigma travel at most 40 mm (limit active).

    Travel r.m.s. = sqrt(W M / (2 c)) grows as c falls, so the constrained optimum is
    the c where 3 sqrt(W M / (2 c)) = 0.04 m, above the free optimum c_a.
    """
    W = 2 * math.pi**2 * 0.01 * 256e-6 * 20
    c_limit = W * M / 2 / (0.04 / 3) ** 2
    assert c_limit > C_ACC
    spec = parse_spec({**BASE, "constraints": {"travel_ratio": 1.0}, "rattle_space": 0.04})
    c = design(spec, verify=False).chosen[0].values["cs"]
    assert c == pytest.approx(c_limit, rel=0.01)


def _spec(tmp_path, **changes):
    spec = {
        "car": "quarter-car",
        "body": "reduced-paper",
        "parameters": {"cs": {"min": 200, "max": 8000}},
        "operating_points": [{"road": "C", "speed": 20}],
        "objectives": ["head_wk_rms", "tire_load_ratio"],
    }
    spec.update(changes)
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    return str(path)


@pytest.mark.parametrize(
    "changes,words",
    [
        ({"parameters": {"kz": {"min": 1, "max": 2}}}, ["unknown parameter 'kz'", "ks"]),
        ({"parameters": {"cs": {"min": -5, "max": 2}}}, ["'cs'", "below zero"]),
        ({"parameters": {"cs": {"min": 5, "max": 2}}}, ["'cs'", "must exceed"]),
        ({"objectives": ["rms:sprung.x", "head_wk_rms"]}, ["cannot be computed", "sprung.x"]),
        ({"objectives": ["rms:no.such"]}, ["no output 'no.such'"]),
        ({"objectives": ["comfort"]}, ["unknown objective 'comfort'"]),
        ({"body": None}, ["'head_wk_rms' needs a body model"]),
        ({"objectives": ["travel_ratio", "head_wk_rms"]}, ["needs 'rattle_space'"]),
        ({"operating_points": []}, ["'operating_points' is empty"]),
        ({"operating_points": [{"road": "bump", "speed": 20}]}, ["ISO 8608 class"]),
        ({"operating_points": [{"road": "C", "speed": 0}]}, ["speed"]),
        ({"search": {"method": "ga"}}, ["'ga' minimizes one objective"]),
        ({"colour": "red"}, ["unknown key(s) colour"]),
        # a bound given as a string was taken as its number
        ({"parameters": {"cs": {"min": "200", "max": 8000}}}, ["'cs' min", "string '200'"]),
        ({"operating_points": [{"road": "C", "speed": "20"}]}, ["speed", "string '20'"]),
        # sizes bounded by what they cost: a billion hung, 1e18 was a traceback
        ({"search": {"population": 1000000000}}, ["about 4.1e+10 designs", "limit is 1e+07"]),
        ({"search": {"population": 1e18}}, ["population 1e+18", "limit is 1e+07"]),
        ({"search": {"generations": 1e12}}, ["1e+12 generations", "limit is 1e+07"]),
        ({"search": {"generations": 1e100}}, ["1e+100 generations", "limit is 1e+07"]),
        ({"search": {"population": 10**6, "generations": 1}}, ["16 TB of memory", "population"]),
        # a verification of one sample wrote figures of 0.0
        ({"verify": {"duration": 1, "step": 5}}, ["verify step 5 s", "duration 1 s"]),
        ({"verify": {"step": 0.05}}, ["verify step 0.05 s is too long", "at most 0.0041 s"]),
        ({"verify": {"duration": 0.5}}, ["verify duration 0.5 s", "MTVV"]),
        ({"verify": {"duration": 1e7}}, ["verification run of 1e+07 s", "TB of memory"]),
    ],
)
def test_bad_specs_are_refused_in_one_line_before_any_work(capsys, tmp_path, changes, words):
    out = tmp_path / "out"
    t0 = time.monotonic()
    status = main(["design", _spec(tmp_path, **changes), "--out", str(out)])
    assert time.monotonic() - t0 < 10  # refused before any search (a second measured)
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and "Traceback" not in err[0], err
    for w in words:
        assert w in err[0], (err[0], w)
    assert not out.exists()


def test_api_refuses_like_the_command():
    with pytest.raises(BodyvibError, match="is empty"):
        parse_spec({**BASE, "operating_points": []})


@pytest.mark.integration
def test_command_writes_the_front_and_car_files_others_read(tmp_path, capsys):
    """The example spec, small: files written, car file taken by a sweep as it is.

    The spectral sweep engine of the written car file gives the head Wk r.m.s. the
    evaluator predicted (both exact for the road spectrum; 5e-6 apart at 20 m/s from
    the road's band limits); the time-domain verification agrees within the scatter of
    30 s runs (0.3 % measured, 1 % allowed, 3 % for the tire load, whose content above
    the synthesized road's 57 Hz band limit the evaluator counts).
    """
    from bodyvib.vehicle.quarter_car import load_car
    from bodyvib.vehicle.sweep.engines import run_batched, run_spectral
    from bodyvib.vehicle.sweep.spec import expand

    example = os.path.join(os.path.dirname(__file__), "..", "examples", "design")
    spec = json.load(open(os.path.join(example, "quarter-car-class-c.json")))
    spec["search"].update(population=16, generations=10)
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "out"
    assert main(["design", str(path), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "compromise" in printed and "evaluator" in printed and "run" in printed
    summary = json.load(open(out / "design.json"))
    for name in ("design_front.csv", "design_front.parquet", "design_front.png"):
        assert (out / name).stat().st_size > 0
    compromise = next(c for c in summary["chosen"] if c["label"] == "compromise")
    car_file = str(out / "design-compromise.json")
    assert load_car(car_file).parameters["cs"] == pytest.approx(compromise["values"]["cs"])
    case = expand({"road": "C", "speed": 20, "body": "reduced-paper", "car": car_file})
    row = run_spectral(case)[0]
    pred, ver = compromise["predicted"], compromise["verified"]
    assert row["head_weighted_rms"] == pytest.approx(pred["head_wk_rms"], rel=1e-4)
    assert ver["head_wk_rms"] == pytest.approx(pred["head_wk_rms"], rel=0.01)
    assert ver["tire_load_ratio"] == pytest.approx(pred["tire_load_ratio"], rel=0.03)
    # the verification is the batched engine's run of the linear car (the design's model):
    # same road, same exact step
    case = expand(
        {
            "road": "C",
            "speed": 20,
            "duration": 30,
            "body": "reduced-paper",
            "car": car_file,
            "linear": True,
        }
    )
    assert run_batched(case)[0][0]["head_weighted_rms"] == pytest.approx(
        ver["head_wk_rms"], rel=1e-9
    )


@pytest.mark.integration
def test_expected_absorbed_power_matches_runs():
    """E[seat force x seat velocity] from the Lyapunov solution against 30 s runs.

    Four seeds, class C at 20 m/s: measured 1.114, 1.127, 1.102, 1.116 W against the
    evaluator's 1.1215 W (mean -0.6 %, the runs' fade-in included); a power scales
    with W, so a wrong scaling with the road would be a factor 2 (class D) away.
    """
    import dataclasses

    from bodyvib.vehicle.design import DesignProblem, verify_design

    spec = parse_spec(
        {
            **BASE,
            "body": "reduced-paper",
            "objectives": ["absorbed_power"],
            "operating_points": [{"road": "C", "speed": 20}, {"road": "D", "speed": 20}],
        }
    )
    F, _ = DesignProblem(spec).evaluate([[1000.0]])
    runs = [
        verify_design(
            dataclasses.replace(spec, verify=dataclasses.replace(spec.verify, seed=s)),
            {"cs": 1000.0},
        )["absorbed_power"]
        for s in range(4)
    ]
    assert np.mean(runs) == pytest.approx(F[0, 0], rel=0.02)
    assert np.all(np.abs(np.array(runs) / F[0, 0] - 1) < 0.04)


@pytest.mark.integration
def test_ctrl_c_during_the_search_stops_it_and_keeps_the_old_files(tmp_path):
    """SIGINT a few seconds into a long search: status 130, one line, outputs all old."""
    import signal
    import subprocess
    import sys
    import time

    from helpers import check_stopped_run, write_old_outputs

    spec = tmp_path / "spec.json"
    spec.write_text(
        json.dumps(
            {
                **BASE,
                "objectives": ["rms:sprung.a", "tire_load_ratio"],
                "search": {"population": 200, "generations": 500},
            }
        )
    )
    out = tmp_path / "out"
    outputs = [out / "design_front.csv", out / "design.json"]
    write_old_outputs(outputs)
    p = subprocess.Popen(
        [sys.executable, "-m", "bodyvib.cli", "design", str(spec), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(6)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert check_stopped_run(p.returncode, err, outputs, 130, "interrupted", "design")


@pytest.mark.integration
def test_full_disk_under_out_leaves_no_folder(tmp_path, capsys, monkeypatch):
    """A full disk under ``design --out`` left an empty output folder; every other command
    leaves nothing. A 16 kB tmpfs holds the front's CSV but not its plot; where no tmpfs can
    be mounted, the same ENOSPC is injected at the chosen designs' car files, the last."""
    import errno

    from helpers import mount_tmpfs

    import bodyvib.vehicle.design.report as report

    spec = _spec(tmp_path, search={"population": 8, "generations": 2})
    disk = tmp_path / "disk"
    disk.mkdir()
    with mount_tmpfs(disk, "16k") as mounted:
        if not mounted:

            def full(net, path):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), os.fspath(path))

            monkeypatch.setattr(report, "save_model", full)
        out = disk / "new" / "design"
        assert main(["design", spec, "--out", str(out), "--no-verify"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "No space left" in err[0], err
        assert os.listdir(disk) == []  # not even the folders
