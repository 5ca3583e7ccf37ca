"""bodyvib road: a synthetic class and (once a reader exists) a profile file, end to end."""

import importlib.util
import json

import numpy as np
import pytest

from bodyvib.cli.main import main
from bodyvib.vehicle.road.classify import classify_profile
from bodyvib.vehicle.road.iri import international_roughness_index
from bodyvib.vehicle.road.synthetic import random_road

HAS_READER = importlib.util.find_spec("bodyvib.vehicle.road.measured") is not None


def test_class_road_prints_and_writes_the_summary(tmp_path, capsys):
    js, png = str(tmp_path / "road.json"), str(tmp_path / "road.png")
    assert (
        main(
            [
                "road",
                "D",
                "--length",
                "500",
                "--spacing",
                "0.05",
                "--seed",
                "3",
                "--json",
                js,
                "--plot",
                png,
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "class D" in text and "IRI" in text
    doc = json.load(open(js))
    assert doc["iso8608"]["iso8608_class"] == "D"
    assert doc["length_m"] == pytest.approx(500.0) and doc["spacing_m"] == pytest.approx(0.05)
    # the command's numbers are the library's on the same samples
    x = np.arange(10001) * 0.05
    z = random_road("D", 500.05, seed=3).displacement(x)
    assert doc["iri"]["iri_m_per_km"] == pytest.approx(
        international_roughness_index(x, z).iri_m_per_km, rel=1e-12
    )
    assert doc["iso8608"]["gd_n0_m3"] == pytest.approx(classify_profile(x, z).gd_n0_m3, rel=1e-12)
    from scipy.signal import detrend

    assert doc["elevation_m"]["rms"] == pytest.approx(np.std(detrend(z)), rel=1e-9)
    assert (tmp_path / "road.png").stat().st_size > 10000


@pytest.mark.parametrize(
    "args, words",
    [
        (["road", "X"], "neither a profile file nor an ISO 8608 class"),
        # a file's name: the reader's own words, as cosim says them (was "neither ...")
        (["road", "nosuch.csv"], "road file 'nosuch.csv' does not exist"),
        (["road", "no/such.crg"], "road file 'no/such.crg' does not exist"),
        (["road", "C", "--spacing", "0"], "--spacing must be a positive number"),
        (["road", "C", "--length", "1"], "too little of ISO 8608"),
        (["road", "C", "--json", "out.txt"], "--json"),
    ],
)
def test_bad_road_input_is_refused_in_one_line(capsys, args, words):
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err


@pytest.mark.skipif(
    not HAS_READER, reason="bodyvib.vehicle.road.measured (profile files) not merged yet"
)
def test_csv_profile_file_gives_the_arrays_figures(tmp_path, capsys):
    x = np.arange(0, 600, 0.05)
    z = random_road("C", 600.0, seed=4).displacement(x)
    path = tmp_path / "profile.csv"
    np.savetxt(
        path,
        np.column_stack([x, z]),
        delimiter=",",
        header="distance [m],elevation [m]",
        comments="",
        fmt="%.12g",
    )
    js = str(tmp_path / "p.json")
    assert main(["road", str(path), "--json", js]) == 0
    doc = json.load(open(js))
    assert doc["iso8608"]["iso8608_class"] == "C"
    assert doc["iri"]["iri_m_per_km"] == pytest.approx(
        international_roughness_index(x, z).iri_m_per_km, rel=1e-9
    )
