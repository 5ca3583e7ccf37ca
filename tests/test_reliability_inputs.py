"""Inputs a hostile but realistic user gives: special files, broken MDF4 records, absurd
magnitudes, sweeps too large to plan and contradictory options. Each is refused in one line
(exit 2, no traceback, no library noise), quickly, naming the input and the fix."""

import os
import re
import socket
import subprocess
import sys
import time

import numpy as np
import pytest
from helpers import run_cli

from bodyvib.frequency.measured import read_transmissibility_csv
from bodyvib.runtime.errors import BodyvibError
from bodyvib.runtime.inputfile import check_input_file
from bodyvib.runtime.jsonfile import read_json
from bodyvib.seat.signal import MAX_ACCELERATION, check_signal


def _one_line_error(p, words):
    assert p.returncode == 2, (p.stdout, p.stderr)
    assert words in p.stderr, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr, p.stderr


def _special(tmp_path, kind):
    """A special file of this kind in tmp_path (the socket stays bound while the test runs)."""
    path = tmp_path / f"in-{kind}.csv"
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(path))
        _special.keep = s
    else:
        return "/dev/zero"
    return str(path)


KINDS = {
    "fifo": "a FIFO (named pipe)",
    "folder": "a folder",
    "socket": "a socket",
    "device": "a character device",
}


@pytest.mark.parametrize("kind", KINDS)
def test_the_input_check_names_every_special_file(tmp_path, kind):
    path = _special(tmp_path, kind)
    with pytest.raises(BodyvibError, match=re.escape(f"'{path}' is {KINDS[kind]}")):
        check_input_file(path, "signal file")
    with pytest.raises(BodyvibError, match=re.escape(f"is {KINDS[kind]}")):
        read_json(path, "model file")  # a FIFO here waited for a writer forever
    with pytest.raises(BodyvibError, match=re.escape(f"is {KINDS[kind]}")):
        read_transmissibility_csv(path)  # fit --measured: the same wait


@pytest.mark.integration
@pytest.mark.parametrize("kind", KINDS)
def test_respond_refuses_a_special_file_instead_of_waiting(tmp_path, kind):
    path = _special(tmp_path, kind)
    t0 = time.monotonic()
    p = run_cli("respond", path, "--json", str(tmp_path / "o.json"), timeout=60)
    _one_line_error(p, f"is {KINDS[kind]}, not a file")
    assert time.monotonic() - t0 < 30 and not (tmp_path / "o.json").exists()


def test_absurd_seat_acceleration_is_refused_naming_the_signal():
    t = np.arange(0, 2, 1e-3)
    with pytest.raises(BodyvibError, match="rec: acceleration 1e\\+300 m/s2 at t = 0.5 s"):
        check_signal(t, np.where(t == 0.5, 1e300, np.sin(t)), "rec")
    assert check_signal(t, MAX_ACCELERATION * np.sin(t), "rec").fs == 1000.0  # the bound is in


@pytest.mark.integration
def test_respond_to_a_1e300_signal_prints_one_line_without_numpy_warnings(tmp_path):
    t = np.arange(0, 4, 1 / 200)
    rows = "".join(f"{float(a)!r},{float(1e300 * np.sin(8 * np.pi * a))!r}\n" for a in t)
    (tmp_path / "big.csv").write_text("time,acc\n" + rows)
    p = run_cli("respond", "big.csv", cwd=tmp_path, timeout=120)
    _one_line_error(p, "big.csv:acc: acceleration")
    assert "RuntimeWarning" not in p.stderr


def test_a_profile_beyond_any_road_height_is_refused_by_name():
    """A 1e300 m height is a unit or file error: refused where every profile is made, with
    the sample, instead of overflowing into NaN statistics."""
    from bodyvib.vehicle.road.profile import MAX_ELEVATION_M, ProfileRoad

    z = np.zeros(100)
    z[7] = 1e300
    with pytest.raises(BodyvibError, match=r"'p': sample 8 \(at 0.35 m\) has the height 1e\+300 m"):
        ProfileRoad(z, 0.05, name="p")
    z[7] = MAX_ELEVATION_M  # the bound itself is a height
    assert ProfileRoad(z, 0.05, name="p").elevation[7] == MAX_ELEVATION_M


@pytest.mark.integration
@pytest.mark.parametrize("command", [("road",), ("cosim", "--duration", "1", "--quiet", "--road")])
def test_a_1e300_road_prints_one_line_without_numpy_warnings(tmp_path, command):
    x = np.arange(0, 100, 0.05)
    z = np.where(np.arange(x.size) % 2, 1e300, -1e300)
    rows = "".join(f"{a!r},{b!r}\n" for a, b in zip(x.tolist(), z.tolist()))
    (tmp_path / "huge.csv").write_text("distance_m,elevation_m\n" + rows)
    p = run_cli(*command, "huge.csv", cwd=tmp_path, timeout=120)
    _one_line_error(p, "huge.csv': sample 1 (at 0 m) has the height -1e+300 m")
    assert "RuntimeWarning" not in p.stderr


def _mdf4(path):
    from asammdf import MDF, Signal

    t = np.arange(0, 4, 1 / 200)
    mdf = MDF(version="4.10")
    mdf.append([Signal(np.sin(8 * np.pi * t), t, name="seat_acc", unit="m/s^2")])
    mdf.save(path, overwrite=True)
    mdf.close()
    return path.read_bytes()


@pytest.mark.integration
def test_respond_to_a_truncated_or_corrupt_mdf4_prints_one_line(tmp_path):
    """asammdf logs an ERROR and leaves a half-built reader whose __del__ fails at exit
    ("Exception ignored in: <function MDF4.__del__>" and a traceback): both silenced."""
    data = _mdf4(tmp_path / "good.mf4")
    cases = {f"cut{n}.mf4": data[:n] for n in (64, 200, len(data) // 2, len(data) - 100)}
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
        p = run_cli("respond", name, "--channel", "seat_acc", cwd=tmp_path, timeout=120)
        _one_line_error(p, f"{name}: not a readable MDF file")
        assert "Exception ignored" not in p.stderr and "ERROR" not in p.stderr, p.stderr


@pytest.mark.integration
@pytest.mark.parametrize(
    "seed", ["0..1000000000", ["0..4", "10..100000000000000000000"], "5..99999999999"]
)
def test_a_sweep_with_a_huge_seed_range_is_refused_at_once(tmp_path, seed):
    import json

    spec = {"road": "C", "speed": 20, "seed": seed, "body": "reduced-paper", "duration": 2}
    (tmp_path / "s.json").write_text(json.dumps(spec))
    t0 = time.monotonic()
    p = run_cli("sweep", "s.json", "--out", "r.parquet", cwd=tmp_path, timeout=120)
    _one_line_error(p, "cases needs about")
    assert time.monotonic() - t0 < 30  # counted, not expanded (it ran past 180 s before)


def test_the_case_count_does_not_expand_seed_ranges():
    from bodyvib.vehicle.sweep.spec import count_cases

    t0 = time.monotonic()
    with pytest.raises(BodyvibError, match="a sweep of 1e\\+09 cases"):
        count_cases({"road": "C", "speed": 20, "seed": "1..1000000000", "body": "reduced-paper"})
    assert time.monotonic() - t0 < 10


@pytest.mark.integration
@pytest.mark.parametrize(
    "args, words",
    [
        (["--out", "r.parquet", "--resume", "--overwrite"], "give one of them"),
        (["--out", "r.txt"], "--out 'r.txt' must end in .parquet"),
    ],
)
def test_sweep_refuses_contradictory_options(tmp_path, args, words):
    (tmp_path / "s.json").write_text('{"road": "C", "speed": 20, "body": "reduced-paper"}')
    p = run_cli("sweep", "s.json", *args, cwd=tmp_path, timeout=120)
    _one_line_error(p, words)
    assert sorted(os.listdir(tmp_path)) == ["s.json"]


def test_uri_unsafe_characters_are_those_pythonfmu_cannot_read_back():
    """Independent: every printable ASCII character and two letters beyond ASCII, put in a
    folder name, made into a file: URI by pathlib (RFC 8089 percent-encoding) and decoded as
    pythonfmu 0.7.0's binary does (strip ``file://``, ``%20`` -> space)."""
    import pathlib
    import string

    from bodyvib.process.scratch import uri_unsafe_characters

    for ch in string.printable.strip() + " éß":
        if ch in "/\\":
            continue
        path = f"/tmp/a{ch}b/resources"
        uri = pathlib.PurePosixPath(path).as_uri()
        read = uri[len("file://") :].replace("%20", " ")
        assert (uri_unsafe_characters(path) == "") == (read == path), ch


@pytest.mark.integration
@pytest.mark.parametrize("name", ["a:b", "a%20b", "a#b", "a?b", "é"])
def test_cosim_runs_with_any_temporary_folder_and_leaves_nothing(tmp_path, name):
    """A TMPDIR whose path percent-encodes in a file: URI crashed the pythonfmu FMU in
    fmi2Instantiate (SIGSEGV), leaving bodyvib-run-* in TMPDIR and a .tmp-* CSV."""
    tmp = tmp_path / name
    tmp.mkdir()
    out = tmp_path / "out"
    env = {**os.environ, "TMPDIR": str(tmp)}
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "bodyvib.cli",
            "cosim",
            "--duration",
            "1",
            "--quiet",
            "--json",
            str(out / "r.json"),
            "--csv",
            str(out / "r.csv"),
        ],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert p.returncode == 0, p.stderr
    assert sorted(os.listdir(out)) == ["r.csv", "r.json"] and os.listdir(tmp) == []


@pytest.mark.integration
def test_the_library_refuses_an_unsafe_extraction_folder_in_one_error(python_fmus, tmp_path):
    """Without the command's private folder (a library call), a pythonfmu FMU extracted to a
    folder it cannot read back is refused before fmi2Instantiate, not a segfault."""
    tmp = tmp_path / "a:b"
    tmp.mkdir()
    code = (
        "import tempfile, sys\n"
        f"tempfile.tempdir = {str(tmp)!r}\n"
        "from bodyvib.vehicle.cosim import open_fmu\n"
        "from bodyvib.runtime.errors import BodyvibError\n"
        "try:\n"
        f"    with open_fmu({python_fmus['HumanBody3DOF']!r}, 'body'):\n"
        "        pass\n"
        "except BodyvibError as exc:\n"
        "    print(exc)\n"
        "    sys.exit(2)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert "':' a pythonfmu FMU cannot read back" in p.stdout and os.listdir(tmp) == []
