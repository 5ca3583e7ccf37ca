"""User errors end in one line on stderr and status 2, never in a traceback.

Each case is run through the command line's own ``main`` (in process): the status must
be 2, stderr a single line naming the problem, and nothing may have been written.
"""

import json
import os
import time

import pytest

from bodyvib.cli.main import main


def _one_line(capsys, argv, *words):
    status = main(argv)
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2, (argv, status, err)
    assert len(lines) == 1, (argv, err)
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (argv, lines[0], w)
    return lines[0]


@pytest.mark.parametrize(
    "argv,words",
    [
        (["cosim", "--seed", "1.5"], ["bodyvib cosim: error:", "--seed", "1.5"]),
        (["sweep", "s.json", "--workers", "0"], ["bodyvib sweep: error:", "--workers"]),
        (["sweep", "s.json", "--block", "-1"], ["bodyvib sweep: error:", "--block"]),
        (["frf", "--points", "many"], ["bodyvib frf: error:", "--points"]),
        (["no-such-command"], ["bodyvib: error:", "no-such-command"]),
        (["cosim", "--no-such-option"], ["error:", "--no-such-option"]),
    ],
)
def test_argparse_errors_are_one_line_and_status_2(capsys, argv, words):
    _one_line(capsys, argv, *words)


@pytest.mark.parametrize("text", ["[" * 100000 + "]" * 100000, '{"a":' * 40 + "1" + "}" * 40])
def test_deeply_nested_json_is_refused_in_one_line(capsys, tmp_path, text):
    """A nesting Python's parser cannot follow (RecursionError) or no bodyvib file has."""
    deep = tmp_path / "deep.json"
    deep.write_text(text)
    out = tmp_path / "out.json"
    for argv in (
        ["frf", "--models", str(deep), "--json", str(out)],
        ["cosim", "--params", str(deep), "--json", str(out)],
        ["fit", "--config", str(deep), "--out", str(out)],
        ["sweep", str(deep), "--out", str(tmp_path / "r.parquet")],
    ):
        _one_line(capsys, argv, str(deep), "nested")
    assert not out.exists()


@pytest.mark.integration
def test_body_fmu_given_as_the_car_is_named(capsys, python_fmus, tmp_path):
    """``cosim --car-fmu HumanBody3DOF.fmu`` ended in KeyError: 'seat'."""
    line = _one_line(
        capsys,
        [
            "cosim",
            "--car-fmu",
            python_fmus["HumanBody3DOF"],
            "--body",
            python_fmus["HumanBody3DOF"],
            "--duration",
            "1",
        ],
        "lacks the car interface",
        "it is a body FMU",
        "--body",
    )
    assert "HumanBody3DOF.fmu" in line
    _one_line(
        capsys,
        ["cosim", "--body", python_fmus["QuarterCar"], "--duration", "1"],
        "lacks the body interface",
        "it is a car FMU",
        "--car-fmu",
    )


def test_measured_frequency_beyond_any_body_is_refused(capsys, tmp_path):
    """A frequency of 1e308 Hz made scipy raise ValueError deep inside the fit."""
    csv = tmp_path / "m.csv"
    rows = [0.5, 1, 2, 3, 4, 5, 6, 8, 10, 1e308]
    csv.write_text("frequency_hz,modulus\n" + "".join(f"{f!r},1.0\n" for f in rows))
    out = tmp_path / "p.json"
    _one_line(
        capsys,
        ["fit", "--measured", str(csv), "--out", str(out), "--quiet"],
        "line 11",
        "1e+308",
        "1000 Hz",
    )
    assert not out.exists()


def test_sweep_too_large_for_memory_is_refused_before_sampling(capsys, tmp_path):
    """``samples: 1000000000`` ended in MemoryError after minutes of sampling."""
    spec = tmp_path / "s.json"
    spec.write_text(
        json.dumps(
            {
                "road": "C",
                "speed": 20,
                "body": [
                    {"model": "reduced-paper", "vary": {"c1": [0.5, 2]}, "samples": 1000000000}
                ],
            }
        )
    )
    t0 = time.monotonic()
    _one_line(
        capsys,
        ["sweep", str(spec), "--out", str(tmp_path / "r.parquet"), "--scheduler", "serial"],
        "1e+09 cases",
        "TB",
        "half the memory",
    )
    assert time.monotonic() - t0 < 30
    assert not (tmp_path / "r.parquet").exists()


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["sweep", "--grid", "road=C", "speed=10", "--retry-failed", "--csv", "r.csv"],
            "bodyvib sweep: error: --retry-failed needs --resume",
        ),
        (
            ["sweep", "--grid", "road=C", "speed=10", "--resume", "--csv", "r.csv"],
            "bodyvib sweep: error: --resume needs an output file (--out)",
        ),
        (
            ["sweep", "--grid", "road", "--out", "r.parquet"],
            "bodyvib sweep: error: --grid item 'road' must look like key=v1,v2",
        ),
        (
            ["sweep", "--grid", "road=C", "speed=ten", "--out", "r.parquet"],
            "bodyvib sweep: error: --grid speed: 'ten' is not a list of numbers",
        ),
    ],
)
def test_library_errors_name_the_flags_on_the_command_line(
    capsys, tmp_path, monkeypatch, argv, line
):
    # the library names its parameters (retry_failed=True needs resume=True); the command
    # line shows the flags that set them, through bodyvib.cli.flags
    monkeypatch.chdir(tmp_path)
    assert _one_line(capsys, argv) == line
    assert list(tmp_path.iterdir()) == []


def test_an_error_keeps_the_parameters_it_names_across_processes():
    # a sweep's worker raises, the client prints: the names travel pickled with the message
    import pickle

    from bodyvib.runtime.errors import BodyvibError
    from bodyvib.vehicle.sweep.cluster import ClusterLost

    for error in (BodyvibError("'out' is bad", parameters=("out",)), ClusterLost("lost")):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and str(again) == str(error)
        assert again.parameters == error.parameters


def test_a_road_warning_names_the_flags_on_the_command_line(capsys):
    # the warning's own words are the library's (duration=12.5); the command line's line
    # shows the flag, once however often the road is checked
    import warnings

    from bodyvib.cli.main import _one_line
    from bodyvib.vehicle.road.base import RoadWarning

    show = _one_line("bodyvib cosim")
    w = RoadWarning("faded in once; duration=12.5 drives it once", parameters=("duration",))
    for _ in range(2):
        show(w, RoadWarning, __file__, 1)
    assert capsys.readouterr().err == (
        "bodyvib cosim: warning: faded in once; --duration 12.5 drives it once\n"
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.warn(w, stacklevel=1)
    assert caught[0].message.parameters == ("duration",)


@pytest.mark.parametrize(
    "argv,words",
    [
        # empty values were taken as no seat, the default car, a plain build into ./dist
        (["cosim", "--seat", ""], ["argument --seat: empty value"]),
        (["cosim", "--car", " "], ["argument --car: empty value"]),
        (["build", "--cross-check", ""], ["argument --cross-check: empty value"]),
        (["build", "--control", ""], ["argument --control: empty value"]),
        (["frf", "--models", "reduced-paper", ""], ["argument --models: empty value"]),
        # duplicate keys: the last one won
        (["cosim", "--road", "hump:h=0.1,h=0.2"], ["bump 'hump' gives h twice"]),
        (
            ["cosim", "--car", "quarter-car-active", "--control", "skyhook:c=1,c=2"],
            ["controller 'skyhook:c=1,c=2' gives c twice"],
        ),
        # a key without its value was "no key 'h'"
        (["cosim", "--road", "hump:h"], ["key 'h' needs a value", "hump:h=0.075"]),
        (
            ["cosim", "--car", "quarter-car-active", "--control", "skyhook:c"],
            ["option 'c' needs a value"],
        ),
        # 18 numpy warnings and "acceleration contains NaN"; a generic discard in cosim
        (["control", "--laws", "skyhook:c=1e300"], ["c_sky = 1e+300", "beyond 1e+08 N s/m"]),
        (
            ["cosim", "--car", "quarter-car-active", "--control", "skyhook:c=1e6"],
            ["by 3.45 times", "0.001 s communication step", "at most 0.000116 s"],
        ),
    ],
)
def test_empty_duplicate_and_absurd_options_are_refused(capsys, tmp_path, monkeypatch, argv, words):
    """Each refused in one line, status 2, before any FMU is built or file written."""
    monkeypatch.chdir(tmp_path)
    _one_line(capsys, argv + ["--duration", "1"] if argv[0] != "build" else argv, *words)
    assert os.listdir(tmp_path) == []  # build wrote no ./dist


def test_folder_given_as_an_fmu_is_named_a_folder(capsys, tmp_path):
    """``--control-fmu FOLDER`` said the FMU file "does not exist"."""
    for option in ("--control-fmu", "--body", "--car-fmu"):
        extra = ["--car", "quarter-car-active"] if option == "--control-fmu" else []
        _one_line(
            capsys,
            ["cosim", option, str(tmp_path), "--duration", "1", *extra],
            f"'{tmp_path}' is a folder, not an FMU ({option})",
        )


@pytest.mark.parametrize("name", ["road-bumps", "tandem-cam-205-60R15"])
def test_road_data_files_are_not_listed_or_taken_as_cars(capsys, name):
    """``--car`` listed the bump library and the tire's data as cars; choosing one failed on
    missing fields. They live with the roads; the list names the cars alone."""
    line = _one_line(capsys, ["cosim", "--car", name], f"unknown vehicle model '{name}'")
    listed = line.split("one of: ")[1].split(", ")
    assert listed == [
        "full-car",
        "full-car-active",
        "half-car",
        "half-car-active",
        "quarter-car",
        "quarter-car-active",
        "quarter-car-cushion",
    ]


@pytest.mark.parametrize(
    "argv,words",
    [
        (["--body", "b.fmu", "--params", "p.json"], ["--params", "with --body FMU", "one of"]),
        (["--car-fmu", "c.fmu", "--car", "half-car"], ["--car chooses", "with --car-fmu FMU"]),
        (["--car-fmu", "c.fmu", "--linear"], ["--linear linearizes", "with --car-fmu FMU"]),
        (["--car-fmu", "c.fmu", "--seat", "cushion"], ["--seat goes", "leave out --car-fmu"]),
    ],
)
def test_cosim_refuses_an_option_another_makes_moot(capsys, argv, words):
    _one_line(capsys, ["cosim", *argv], *words)


def test_a_command_line_runs_its_own_settings():
    """Each of the five run settings a command line parses reaches its RunSettings."""
    import argparse

    from bodyvib.cli.options import add_road_options, run_settings_from_args

    p = argparse.ArgumentParser()
    add_road_options(p)
    args = p.parse_args([])
    args.road, args.speed, args.duration, args.step, args.seed = "E", 12.5, 7.0, 5e-4, 9
    s = run_settings_from_args(args)
    assert (s.road, s.speed, s.duration, s.step, s.seed) == ("E", 12.5, 7.0, 5e-4, 9)
