"""The ``bodyvib frf`` command, run as a user runs it."""

import json

import numpy as np
import pytest
from helpers import dynamic_stiffness_response, run_cli

from bodyvib.frequency.compare import compare_transmissibility, format_table
from bodyvib.frequency.response import find_peaks, transmissibility
from bodyvib.models import load_model


@pytest.mark.integration
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


@pytest.mark.integration
def test_frf_accepts_a_parameter_file(tmp_path):
    from bodyvib.models import save_model

    net = load_model("reduced-paper").with_parameters(m1=6.0)
    from dataclasses import replace

    save_model(replace(net, name="heavier-head"), tmp_path / "h.json")
    r = run_cli("frf", "--models", str(tmp_path / "h.json"))
    assert r.returncode == 0, r.stderr
    assert "peaks of heavier-head" in r.stdout


@pytest.mark.integration
@pytest.mark.parametrize(
    "args, message",
    [
        (["frf", "--models", "nope"], "unknown model 'nope'"),
        (["frf", "--fmin", "-1"], "0 < fmin < fmax"),
        (["frf", "--fmax", "inf"], "fmax < inf"),  # ran on with NaN and exit status 0
        (["frf", "--plot", "x.bmp"], "must end in .png"),
    ],
)
def test_frf_errors_are_one_line(tmp_path, args, message):
    r = run_cli(*args, cwd=tmp_path)
    assert r.returncode == 2
    assert message in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr


def test_peak_refinement_against_dense_grid():
    coarse = compare_transmissibility(["iso7962"], points=300).models["iso7962"].peaks
    f = np.linspace(3, 13, 20001)
    from bodyvib.frequency.response import transmissibility

    dense = find_peaks(f, np.abs(transmissibility(load_model("iso7962"), f)))
    assert len(coarse) == len(dense) == 2  # ISO 7962's two resonances in 3-13 Hz
    for c, d in zip(coarse, dense, strict=True):
        assert c.frequency_hz == pytest.approx(d.frequency_hz, rel=2e-3)
        assert c.modulus == pytest.approx(d.modulus, rel=1e-4)


def test_table_lists_third_octaves():
    text = format_table(compare_transmissibility(points=100))
    assert text.count("\n") > 20 and "31.50" in text


def test_table_rows_stay_inside_the_computed_range():
    """No row lies outside [fmin, fmax], where np.interp would repeat the edge value."""
    result = compare_transmissibility(["reduced-paper"], f_min=2.0, f_max=10.0, points=400)
    rows = [ln.split("|") for ln in format_table(result).splitlines()[3:] if "|" in ln]
    f_rows = [float(r[0]) for r in rows]
    assert f_rows == [2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0]
    exact = np.abs(transmissibility(load_model("reduced-paper"), f_rows))
    assert [float(r[1].split()[0]) for r in rows] == pytest.approx(exact, abs=6e-4)


def test_models_with_one_name_keep_both_curves(tmp_path):
    """Every refit is named reduced-refit-<target>: two of them keep two keys, two curves,
    two table columns."""
    from dataclasses import replace

    from bodyvib.models import save_model

    base = load_model("reduced-paper")
    save_model(replace(base, name="refit"), tmp_path / "a.json")
    save_model(replace(base.with_parameters(m1=6.0), name="refit"), tmp_path / "b.json")
    r = compare_transmissibility([str(tmp_path / "a.json"), str(tmp_path / "b.json")], points=50)
    assert list(r.models) == ["refit (a.json)", "refit (b.json)"]
    a, b = (m.modulus for m in r.models.values())
    assert np.max(np.abs(a - b)) > 0.01  # two different curves
    table = format_table(r)
    assert "refit (a.json)" in table and "refit (b.json)" in table
    r2 = compare_transmissibility(["reduced-paper", "reduced-paper"], points=50)
    assert list(r2.models) == ["reduced-paper", "reduced-paper #2"]


@pytest.mark.integration
def test_absurd_parameters_are_refused_not_printed(tmp_path):
    """Parameters of 1e300 printed |T| of 1e277 and wrote bare NaN into the JSON; every digit
    of such a result is lost (scaling all parameters leaves |T| unchanged, yet it came out
    0.03 instead of 1)."""
    import json as _json

    from bodyvib.runtime.modelfile import network_to_dict

    net = load_model("reduced-paper")
    data = network_to_dict(net)
    data["parameters"]["k1"] = 1e300
    (tmp_path / "big.json").write_text(_json.dumps(data))
    js = tmp_path / "out.json"
    r = run_cli("frf", "--models", str(tmp_path / "big.json"), "--json", str(js))
    assert r.returncode == 2 and "k1 = 1e+300 is outside" in r.stderr
    assert r.stderr.count("\n") == 1 and not js.exists()


@pytest.mark.integration
def test_frf_outputs_checked_before_work_and_all_or_none(tmp_path):
    """--json keep.json --plot result.txt replaced keep.json, then failed on the plot."""
    keep = tmp_path / "keep.json"
    keep.write_text("old")
    r = run_cli("frf", "--json", str(keep), "--plot", str(tmp_path / "result.txt"))
    assert r.returncode == 2 and "must end in .png" in r.stderr and r.stdout == ""
    assert keep.read_text() == "old"
    model = tmp_path / "m.json"
    from bodyvib.models import save_model

    save_model(load_model("reduced-paper"), model)
    r = run_cli("frf", "--models", str(model), "--json", str(model))
    assert r.returncode == 2 and "is the input of --models" in r.stderr
