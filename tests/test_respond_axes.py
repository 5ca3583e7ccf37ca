"""bodyvib respond in every axis: measured seat, backrest and feet channels and the seat's
rotations, read by name or by a mapping, against the standard's weighting tables and hand
sums of the totals."""

import json

import numpy as np
import pytest

from bodyvib.cli.main import main
from bodyvib.runtime.errors import BodyvibError
from bodyvib.seat import parse_channels, read_signal, respond

FS = 500.0
SECONDS = 40.0

# Sinusoids at one-third-octave frequencies of ISO 2631-1:1997 Tables 3 and 4: (axis, the
# column's name in the file, its unit's factor to SI, frequency, amplitude in SI, weighting
# factor x 1000 as the table prints it, comfort k of 8.2.2 and 8.2.3 typed from the clause).
# Half of the columns bear the standard names, the others are mapped; some are in g or deg/s2.
CASE = [
    ("seat_x", "AccX [g]", 9.80665, 1.0, 0.3, 1011, 1.0),
    ("seat_y", "seat_y", 1.0, 2.0, 0.2, 890, 1.0),
    ("seat_z", "AccZ [m/s2]", 1.0, 6.3, 1.0, 1054, 1.0),
    ("seat_rx", "seat_rx [deg/s2]", np.pi / 180, 1.0, 0.5, 880, 0.63),
    ("seat_ry", "Pitch", 1.0, 2.0, 0.4, 512, 0.40),
    ("seat_rz", "seat_rz", 1.0, 4.0, 0.6, 253, 0.20),
    ("backrest_x", "BackX", 1.0, 4.0, 0.5, 1024, 0.80),
    ("backrest_y", "backrest_y", 1.0, 1.0, 0.3, 1011, 0.50),
    ("backrest_z", "backrest_z", 1.0, 2.0, 0.3, 890, 0.40),
    ("feet_x", "FloorX", 1.0, 5.0, 0.4, 1039, 0.25),
    ("feet_y", "feet_y", 1.0, 8.0, 0.4, 1036, 0.25),
    ("feet_z", "feet_z", 1.0, 10.0, 0.8, 988, 0.40),
]
MAPPING = "seat_z=AccZ,seat_x=AccX,seat_ry=Pitch,backrest_x=BackX,feet_x=FloorX"


def _time():
    return np.arange(int(FS * SECONDS)) / FS


def _columns():
    """Each axis's column in its file unit: A sin(2 pi f t) / factor."""
    t = _time()
    return {c: amp * np.sin(2 * np.pi * f * t) / scale for _, c, scale, f, amp, _, _ in CASE}


def _expected():
    """Weighted r.m.s. A |W(f)| / sqrt(2) per axis, and the totals by hand (eq. (10), 8.2.3,
    7.2.3): root sums of squares of k a_w; health the largest of 1.4 a_wx, 1.4 a_wy, a_wz."""
    aw = {axis: amp * w / 1000.0 / np.sqrt(2) for axis, _, _, _, amp, w, _ in CASE}
    k = {axis: kk for axis, *_, kk in CASE}

    def rss(axes):
        return float(np.sqrt(sum((k[a] * aw[a]) ** 2 for a in axes)))

    points = {
        "seat": rss(("seat_x", "seat_y", "seat_z")),
        "seat_rotation": rss(("seat_rx", "seat_ry", "seat_rz")),
        "backrest": rss(("backrest_x", "backrest_y", "backrest_z")),
        "feet": rss(("feet_x", "feet_y", "feet_z")),
    }
    health = max(1.4 * aw["seat_x"], 1.4 * aw["seat_y"], aw["seat_z"])
    return aw, points, rss(aw), health


def _write_csv(path, columns):
    header = "time [s]," + ",".join(columns)
    data = np.column_stack([_time(), *columns.values()])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.12g")


def _check_axes(doc):
    """The JSON's axes against the tables and the hand totals: within 1 % (the 40 s records
    include each filter's start, under 1 % of the r.m.s.; the tables round to 0.5 %)."""
    aw, points, overall, health = _expected()
    for axis, value in aw.items():
        assert doc["axes"][axis]["weighted_rms"] == pytest.approx(value, rel=0.01), axis
    for point, value in points.items():
        assert doc["points"][point] == pytest.approx(value, rel=0.01), point
    assert doc["overall"] == pytest.approx(overall, rel=0.01)
    assert doc["health_value"] == pytest.approx(health, rel=0.01)
    # seat z, 1.054 / sqrt(2) = 0.745 m/s2, beats 1.4 x 0.3 x 1.011 / sqrt(2) = 0.300 of
    # seat x: inside the 0.43 to 0.87 m/s2 of 8 h a day
    assert doc["health"]["zone"] == "caution"


def test_a_csv_of_twelve_axes_by_names_and_mapping_gives_the_tables_figures(tmp_path, capsys):
    path = tmp_path / "axes.csv"
    _write_csv(path, _columns())
    js = tmp_path / "r.json"
    argv = ["respond", str(path), "--channels", MAPPING, "--models", "reduced-paper"]
    assert main([*argv, "--json", str(js)]) == 0
    text = capsys.readouterr().out
    doc = json.load(open(js))
    _check_axes(doc["axes"])
    assert doc["signal"]["channels"]["seat_x"] == f"{path}:AccX (in g, x 9.80665 to m/s2)"
    assert doc["signal"]["channels"]["seat_rx"].endswith("(in deg/s2, x 0.0174533 to rad/s2)")
    # the occupant is driven by seat z alone, as a vertical record drives it
    z_only = tmp_path / "z.csv"
    _write_csv(z_only, {"seat_z": _columns()["AccZ [m/s2]"]})
    alone = respond(read_signal(z_only), ["reduced-paper"])
    head = doc["bodies"]["reduced-paper"]["weighted_rms"]
    assert head == pytest.approx(alone.bodies["reduced-paper"].figures.weighted_rms, rel=1e-10)
    assert doc["seat"]["weighted_rms"] == pytest.approx(alone.seat_figures.weighted_rms, rel=1e-10)
    for words in ("seat_ry", "backrest_x", "overall vibration total value", "in the caution zone"):
        assert words in text, words


def test_exposure_moves_the_health_guidance(tmp_path, capsys):
    """The zone scales as T^-1/2 (Annex B, eq. (B.1)): at 0.5 h its bounds are 4 times
    those at 8 h."""
    path = tmp_path / "axes.csv"
    _write_csv(path, _columns())
    js = tmp_path / "r.json"
    argv = ["respond", str(path), "--channels", MAPPING, "--models", "reduced-paper"]
    assert main([*argv, "--exposure", "0.5", "--json", str(js)]) == 0
    health = json.load(open(js))["axes"]["health"]
    assert (health["lower"], health["upper"]) == (pytest.approx(1.72), pytest.approx(3.48))
    assert "at 0.5 h a day" in capsys.readouterr().out


def test_the_csv_and_plot_carry_every_axis(tmp_path, capsys):
    """--csv writes each axis in SI beside seat z (a column in g comes out times 9.80665, one
    in deg/s2 times pi/180), and --plot gets a panel of the other axes' running r.m.s."""
    path = tmp_path / "axes.csv"
    _write_csv(path, _columns())
    out, png = tmp_path / "out.csv", tmp_path / "out.png"
    argv = ["respond", str(path), "--channels", MAPPING, "--models", "reduced-paper"]
    assert main([*argv, "--csv", str(out), "--plot", str(png)]) == 0
    capsys.readouterr()
    header = out.read_text().splitlines()[0].split(",")
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    columns = _columns()
    for axis, column, scale, *_ in CASE:
        unit = "rad/s2" if axis[-2] == "r" else "m/s2"
        name = "seat_acceleration [m/s2]" if axis == "seat_z" else f"{axis} [{unit}]"
        got = data[:, header.index(name)]
        np.testing.assert_allclose(got, columns[column] * scale, rtol=1e-9, atol=1e-12)
    assert png.stat().st_size > 10_000


@pytest.mark.integration
def test_an_mdf4_file_gives_the_figures_of_the_csv(tmp_path):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal

    t = _time()
    signals = []
    for _, column, *_ in CASE:
        name, _, unit = column.partition(" [")
        values = _columns()[column]
        signals.append(Signal(samples=values, timestamps=t, name=name, unit=unit.rstrip("]")))
    path = tmp_path / "axes.mf4"
    with MDF(version="4.10") as mdf:
        mdf.append(signals)
        mdf.save(str(path), overwrite=True)
    signal = read_signal(path, channels=parse_channels(MAPPING))
    result = respond(signal, ["reduced-paper"])
    _check_axes(result.to_dict()["axes"])
    csv = tmp_path / "axes.csv"
    _write_csv(csv, _columns())
    from_csv = respond(read_signal(csv, channels=parse_channels(MAPPING)), ["reduced-paper"])
    assert result.axes.overall == pytest.approx(from_csv.axes.overall, rel=1e-9)


@pytest.mark.integration
def test_mdf_axes_at_other_sample_times_are_refused(tmp_path, capsys):
    pytest.importorskip("asammdf")
    from asammdf import MDF, Signal

    t = _time()
    with MDF(version="4.10") as mdf:
        mdf.append([Signal(samples=np.sin(t), timestamps=t, name="seat_z", unit="m/s2")])
        mdf.append([Signal(samples=np.sin(t[::2]), timestamps=t[::2], name="AccX", unit="g")])
        mdf.save(str(tmp_path / "s.mf4"), overwrite=True)
    assert main(["respond", str(tmp_path / "s.mf4"), "--channels", "seat_x=AccX"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "'AccX' (10000 samples at 250 Hz) is not sampled at the times of 'seat_z'" in err
    assert "(20000 samples at 500 Hz); resample" in err


def _short_columns():
    t = np.arange(0, 3, 1e-3)
    return t, {"seat_z": np.sin(t), "AccX": np.cos(t), "seat_y": 0 * t}


@pytest.mark.parametrize(
    "args, words",
    [
        (["--channels", "seat_x=AccY"], "no column 'AccY' (for seat_x); columns are seat_z, AccX"),
        (["--channels", "seat_q=AccX"], "unknown axis 'seat_q' in --channels AXIS=NAME"),
        (["--channels", "seat_x"], "'seat_x' is not AXIS=NAME"),
        (["--channels", "seat_z=AccX", "--channel", "seat_z"], "name two seat_z channels"),
        (["--channels", "seat_x=AccX", "--exposure", "0"], "--exposure must be a positive"),
        ([], None),
    ],
)
def test_bad_mappings_are_refused_in_one_line(tmp_path, capsys, args, words):
    t, columns = _short_columns()
    path = tmp_path / "s.csv"
    header = "time," + ",".join(columns)
    data = np.column_stack([t, *columns.values()])
    np.savetxt(path, data, delimiter=",", header=header, comments="")
    if words is None:  # unmapped AccX is left out; seat_y is read by its name
        signal = read_signal(path)
        assert set(signal.axes) == {"seat_y"}
        return
    assert main(["respond", str(path), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and words in err, err


def test_columns_of_different_lengths_are_refused(tmp_path, capsys):
    t, columns = _short_columns()
    path = tmp_path / "s.csv"
    lines = ["time,seat_z,seat_y"] + [f"{x:.4f},{np.sin(x):.6f},0" for x in t]
    lines += [f"{x:.4f},{np.sin(x):.6f}," for x in t[-1] + 1e-3 * np.arange(1, 5)]
    path.write_text("\n".join(lines) + "\n")
    assert main(["respond", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a column shorter than the others" in err, err
    with pytest.raises(BodyvibError, match="line 3002 is not 3 numbers"):
        read_signal(path)
