"""The ``bodyvib frf`` command, run as a user runs it."""

import json
import subprocess
import sys

import numpy as np
import pytest

from bodyvib.frequency import find_peaks, transmissibility
from bodyvib.frf import compare_transmissibility, format_table
from conftest import dynamic_stiffness_response
from bodyvib.models import load_model


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "bodyvib_cli", *args], capture_output=True,
                          text=True, cwd=cwd)


def test_frf_writes_plot_and_json(tmp_path):
    png, js = tmp_path / "frf.png", tmp_path / "frf.json"
    r = run_cli("frf", "--plot", str(png), "--json", str(js))
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads(js.read_text())
    f = np.array(data["frequency_hz"])
    assert f[0] == pytest.approx(0.5) and f[-1] == pytest.approx(31.5)
    assert set(data["models"]) == {"reduced-paper", "iso7962"}
    for name, m in data["models"].items():
        ref = dynamic_stiffness_response(load_model(name), f[::100], "head")
        np.testing.assert_allclose(np.array(m["modulus"])[::100], np.abs(ref), rtol=1e-6)
        dphase = np.array(m["phase_deg"])[::100] - np.degrees(np.angle(ref))
        np.testing.assert_allclose((dphase + 180) % 360 - 180, 0, atol=1e-4)  # unwrapped
    peaks = data["models"]["reduced-paper"]["peaks"]
    assert peaks[0]["frequency_hz"] == pytest.approx(4.43, abs=0.005)
    assert peaks[0]["modulus"] == pytest.approx(1.446, abs=0.0005)
    assert "peaks of iso7962: 1.665 at 4.45 Hz" in r.stdout


def test_frf_accepts_a_parameter_file(tmp_path):
    from bodyvib.runtime.modelfile import save_model
    net = load_model("reduced-paper").with_parameters(m1=6.0)
    from dataclasses import replace
    save_model(replace(net, name="heavier-head"), tmp_path / "h.json")
    r = run_cli("frf", "--models", str(tmp_path / "h.json"))
    assert r.returncode == 0, r.stderr
    assert "peaks of heavier-head" in r.stdout


@pytest.mark.parametrize("args, message", [
    (["frf", "--models", "nope"], "unknown model 'nope'"),
    (["frf", "--fmin", "-1"], "0 < fmin < fmax"),
    (["frf", "--fmax", "inf"], "fmax < inf"),  # ran on with NaN and exit status 0
    (["frf", "--plot", "x.bmp"], "must end in .png"),
])
def test_frf_errors_are_one_line(tmp_path, args, message):
    r = run_cli(*args, cwd=tmp_path)
    assert r.returncode == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


def test_peak_refinement_against_dense_grid():
    coarse = compare_transmissibility(["iso7962"], points=300)["models"]["iso7962"]["peaks"]
    f = np.linspace(3, 13, 20001)
    from bodyvib.frequency import transmissibility
    dense = find_peaks(f, np.abs(transmissibility(load_model("iso7962"), f)))
    for c, d in zip(coarse, dense):
        assert c["frequency_hz"] == pytest.approx(d["frequency_hz"], rel=2e-3)
        assert c["modulus"] == pytest.approx(d["modulus"], rel=1e-4)


def test_table_lists_third_octaves():
    text = format_table(compare_transmissibility(points=100))
    assert text.count("\n") > 20 and "31.50" in text


def test_table_rows_stay_inside_the_computed_range():
    """Rows outside [fmin, fmax] used to show the edge value (np.interp clamps)."""
    result = compare_transmissibility(["reduced-paper"], f_min=2.0, f_max=10.0, points=400)
    rows = [ln.split("|") for ln in format_table(result).splitlines()[3:] if "|" in ln]
    f_rows = [float(r[0]) for r in rows]
    assert f_rows == [2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0]
    exact = np.abs(transmissibility(load_model("reduced-paper"), f_rows))
    assert [float(r[1].split()[0]) for r in rows] == pytest.approx(exact, abs=6e-4)
