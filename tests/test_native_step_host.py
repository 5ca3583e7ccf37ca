"""The step benchmark's C host (benchmarks/native_step_host.c): what a native FMU's step does
besides its arithmetic, counted, not timed."""

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_native_step as bench  # noqa: E402


@pytest.mark.integration
@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("name", ["HumanBody3DOF", "QuarterCar", "FullCar"])
def test_a_step_allocates_nothing_and_is_the_plain_step(native_fmus, tmp_path, name, fmi):
    """2000 steps of set (two inputs; the full car's eight, its four corners' road) + doStep
    + get (two outputs; the full car's four) in the host: no malloc/calloc/realloc/free call
    while stepping (the host interposes them and counts), and the outputs after the last
    step equal those of a plain loop x <- Sc z, s <- Ms s, y = Y z on the library's own
    step matrices (bodyvib.runtime.engine.FmuCore, independent of the C core's exponential)
    to 1e-9 relative: the two exponentials agree to about 1e-14, and 2000 steps of a
    stable recursion (4-14 states, modes of damping ratio 0.1-0.5) carry that to far below
    1e-9; a step of the wrong matrices or inputs is off by the response itself. The cars'
    plain loop evaluates their switching functions as the FMU does, each times its sign at
    rest, and on this road (a 1.7 Hz sine) none comes near zero: its sign test passes in
    every step (a function of the wrong sign or row fails it at once)."""
    exe = bench.compile_host(tmp_path / "host")
    key = name if fmi == 2 else f"fmi3/{name}"
    binary, token, vr, _ = bench.unpack(Path(native_fmus[key]), tmp_path / "fmu")
    sets, gets = bench.SIGNALS[name]
    data = tmp_path / "plain.txt"
    bench.plain_matrices(name, [vr[s] for s in sets], [vr[g] for g in gets], data)
    res = bench.measure(
        exe,
        fmi,
        binary,
        token,
        ",".join(str(vr[s]) for s in sets),
        ",".join(str(vr[g]) for g in gets),
        str(data),
        2000,
        1,
    )
    assert res["allocations"] == 0
    assert res["check"] <= 1e-9
    assert res["unclear"] == 0
