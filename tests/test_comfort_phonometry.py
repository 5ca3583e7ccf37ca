"""ISO 2631-1 in every axis against an independent implementation: phonometry's
human-vibration functions (ISO 8041-1 weightings applied in the frequency domain, ISO 2631-1
eqs. (1)-(5) and (10)), on the same records.

phonometry needs Python 3.13 or newer; it runs in a virtual environment of its own, built
from the first such interpreter found (on PATH or under pyenv), and the module is skipped
where there is none. Tolerance 1 %: phonometry weights with the exact analog response over
the whole record (circular), bodyvib with the bilinear digital filter from rest; on
records of tens of seconds that differ by the start transient and the warping near
80 Hz, each well below 1 % of a weighted r.m.s. here (measured: at most 0.24 %, on the r.m.s. of one axis).
"""

import glob
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bodyvib.comfort import POINTS, SEATED_AXES, vibration_totals

pytestmark = pytest.mark.integration

PHONOMETRY = "phonometry==3.3.0"

# The script phonometry runs: every axis's weighted record, its r.m.s., VDV and MTVV, the
# point totals with the comfort factors given, and the health basis of the seat.
SCRIPT = r"""
import json, sys
import numpy as np
from phonometry.vibration import human_vibration as hv

data = np.load(sys.argv[1])
spec = json.loads(sys.argv[2])
fs = float(data["fs"])
out = {"axes": {}, "points": {}}
for axis, weighting in spec["weightings"].items():
    aw = hv.apply_weighting(data[axis], fs, weighting)
    out["axes"][axis] = {
        "weighted_rms": float(np.sqrt(np.mean(aw ** 2))),
        "vdv": hv.vibration_dose_value(aw, fs),
        "mtvv": hv.mtvv(aw, fs),
    }
for point, names in spec["points"].items():
    names = [a for a in names if a in out["axes"]]
    if names:
        out["points"][point] = hv.vibration_total_value(
            [out["axes"][a]["weighted_rms"] for a in names],
            k=[spec["k"][a] for a in names],
        )
out["overall"] = hv.vibration_total_value(list(out["points"].values()))
if {"seat_x", "seat_y", "seat_z"} <= set(out["axes"]):
    out["health"] = hv.wbv_exposure_basis(
        *(out["axes"][a]["weighted_rms"] for a in ("seat_x", "seat_y", "seat_z"))
    )
json.dump(out, sys.stdout)
"""


def _python_313():
    """An interpreter of Python 3.13 or newer, or None."""
    names = [shutil.which(f"python3.{m}") for m in range(13, 20)]
    home = os.environ.get("PYENV_ROOT", os.path.expanduser("~/.pyenv"))
    names += sorted(glob.glob(os.path.join(home, "versions", "3.1[3-9]*", "bin", "python3")))
    for exe in filter(None, names):
        done = subprocess.run(
            [exe, "-c", "import sys; print(sys.version_info >= (3, 13))"],
            capture_output=True,
            text=True,
        )
        if done.returncode == 0 and done.stdout.strip() == "True":
            return exe
    return None


@pytest.fixture(scope="module")
def phonometry(tmp_path_factory):
    """Run phonometry's figures on records: a function (records, fs) -> its dict."""
    exe = _python_313()
    if exe is None:
        pytest.skip("phonometry needs Python >= 3.13; none found on PATH or under pyenv")
    venv = tmp_path_factory.mktemp("phonometry") / "venv"
    subprocess.run([exe, "-m", "venv", str(venv)], check=True, timeout=300)
    py = str(venv / "bin" / "python")
    pip = subprocess.run(
        [py, "-m", "pip", "install", "-q", PHONOMETRY], capture_output=True, text=True
    )
    if pip.returncode != 0:
        pytest.skip(f"{PHONOMETRY} could not be installed: {pip.stderr.strip()[-300:]}")
    folder = venv.parent

    def run(records, fs):
        np.savez(folder / "records.npz", fs=fs, **records)
        spec = {
            "weightings": {a: SEATED_AXES[a][0] for a in records},
            "k": {a: SEATED_AXES[a][1] for a in records},
            "points": {p: list(names) for p, names in POINTS.items()},
        }
        done = subprocess.run(
            [py, "-c", SCRIPT, str(folder / "records.npz"), json.dumps(spec)],
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)

    return run


def _assert_same(ours, theirs, rel):
    for axis, f in ours.axes.items():
        for key in ("weighted_rms", "vdv", "mtvv"):
            assert getattr(f, key) == pytest.approx(theirs["axes"][axis][key], rel=rel), (
                axis,
                key,
            )
    for point, value in ours.points.items():
        assert value == pytest.approx(theirs["points"][point], rel=rel), point
    assert ours.overall == pytest.approx(theirs["overall"], rel=rel)
    if "health" in theirs:
        assert ours.health_value == pytest.approx(theirs["health"], rel=rel)


def _broadband(rng, n, fs, scale):
    """Band-limited random vibration (0.5-40 Hz) with a few half-sine shocks: a record
    whose crest factor brings VDV and MTVV away from the r.m.s. figures."""
    spectrum = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1.0 / fs)
    spectrum[(f < 0.5) | (f > 40.0)] = 0.0
    x = np.fft.irfft(spectrum, n)
    x *= scale / np.std(x)
    for at in rng.uniform(2.0, n / fs - 2.0, size=3):
        k = int(at * fs)
        width = int(0.08 * fs)
        x[k : k + width] += 4.0 * scale * np.sin(np.pi * np.arange(width) / width)
    return x


def test_every_axis_and_every_total_match_phonometry(phonometry):
    """All twelve axes of ISO 2631-1's seated person, each with its own weighting (Wk, Wd,
    Wc, We) and comfort factor: a_w, VDV, MTVV, the point and overall totals and the health
    basis within 1 % of phonometry's on the same records."""
    fs, seconds = 500.0, 60.0
    n = int(fs * seconds)
    rng = np.random.default_rng(2631)
    records = {a: _broadband(rng, n, fs, 0.2 + 0.1 * i) for i, a in enumerate(SEATED_AXES)}
    ours = vibration_totals(records, fs)
    theirs = phonometry(records, fs)
    _assert_same(ours, theirs, rel=0.01)


def test_a_full_car_runs_seat_figures_match_phonometry(phonometry, tmp_path):
    """bodyvib cosim --car full-car over a two-track road: the JSON's seat_aw_x, seat_aw_y,
    seat_aw_z and seat_av within 1 % of phonometry's from the run's own CSV columns."""
    from helpers import read_run_csv

    out, js = tmp_path / "run.csv", tmp_path / "run.json"
    cmd = [sys.executable, "-m", "bodyvib.cli", "cosim", "--car", "full-car"]
    cmd += ["--duration", "20", "--csv", str(out), "--json", str(js), "--quiet"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    run = read_run_csv(out)
    body = json.loads(Path(js).read_text())["bodies"]["HumanBody3DOF"]
    columns = {"seat_x": "seat_acceleration_x", "seat_y": "seat_acceleration_y"}
    columns["seat_z"] = "seat_acceleration"
    fs = 1.0 / float(np.median(np.diff(run["time"])))
    theirs = phonometry({a: np.asarray(run[c], float) for a, c in columns.items()}, fs)
    for a in "xyz":
        ref = theirs["axes"][f"seat_{a}"]["weighted_rms"]
        assert body[f"seat_aw_{a}"] == pytest.approx(ref, rel=0.01), a
    assert body["seat_av"] == pytest.approx(theirs["points"]["seat"], rel=0.01)
    assert body["seat_aw_y"] > 0.05 * body["seat_aw_z"]  # the offset seat rolls
