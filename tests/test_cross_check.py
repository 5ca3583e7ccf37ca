"""``bodyvib build --cross-check DIR``: the native body FMU in the FMI cross-check layout.

The reference is checked against an independent integrator (scipy's DOP853 at rtol 1e-11 on
the same state space driven by the sine), the folder against fmpy's validator of vendor
repositories, and a run of the FMU by fmpy (inputs from ``_in.csv``) against the reference
with fmpy's own cross-check comparison.
"""

import math

import numpy as np
import pytest
from helpers import run_cli

from bodyvib.fmu.crosscheck import CrossCheckSettings, exact_sine_outputs
from bodyvib.models import load_model
from bodyvib.runtime.contract import KINDS
from bodyvib.runtime.network import linear_model


def test_the_exact_reference_equals_a_high_accuracy_integration():
    from scipy.integrate import solve_ivp

    net, s = load_model("reduced-paper"), CrossCheckSettings(duration=2.0)
    lm, iface = linear_model(net), KINDS["body"](net)
    a, w = s.amplitude, 2 * math.pi * s.frequency
    seat = lambda t: np.array([a * np.sin(w * t), a * w * np.cos(w * t), 0.0])  # noqa: E731
    U = iface.input_map
    t = np.linspace(0, s.duration, 201)
    sol = solve_ivp(
        lambda tt, x: lm.A @ x + lm.B @ (U @ seat(tt)),
        (0, s.duration),
        np.zeros(len(lm.A)),
        t_eval=t,
        method="DOP853",
        rtol=1e-11,
        atol=1e-14,
    )
    exact = exact_sine_outputs(net, s, t)
    for name, signal in zip([v.name for v in iface.outputs], iface.output_signals, strict=True):
        if name in exact:
            r = lm.output_index(signal)
            y = sol.y.T @ lm.C[r] + np.array([U @ seat(tt) for tt in t]) @ lm.D[r]
            # the integrator's tolerance, relative to the output's peak
            assert np.max(np.abs(y - exact[name])) <= 1e-8 * np.max(np.abs(y)), name


@pytest.mark.integration
def test_build_cross_check_writes_a_folder_fmpy_validates_and_the_fmu_matches(tmp_path):
    from fmpy import simulate_fmu
    from fmpy.cross_check import validate_result
    from fmpy.cross_check.validate_vendor_repo import validate_repo
    from fmpy.util import read_csv

    p = run_cli("build", "--cross-check", "cc", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    fmus, results, problems = validate_repo(str(tmp_path / "cc"))
    assert (fmus, problems) == (2, []), problems  # the FMU as co-simulation and model exchange
    (folder,) = (tmp_path / "cc" / "fmus" / "2.0" / "cs" / "linux64" / "bodyvib").glob("*/*")
    (twin,) = (tmp_path / "cc" / "fmus" / "2.0" / "me" / "linux64" / "bodyvib").glob("*/*")
    base = folder / folder.name
    names = sorted(p.name for p in folder.iterdir())
    assert names == sorted(
        f"HumanBody3DOF{x}"
        for x in (".fmu", "_in.csv", "_ref.csv", "_ref.opt", "_cc.sh", "_cc.bat")
    ) + ["ReadMe.md"]
    for name in names:
        assert (twin / name).read_bytes() == (folder / name).read_bytes(), name
    s = CrossCheckSettings()
    ref = read_csv(f"{base}_ref.csv")
    outs = list(ref.dtype.names[1:])
    res = simulate_fmu(
        f"{base}.fmu",
        stop_time=s.duration,
        step_size=s.step,
        output_interval=s.output_step,
        input=read_csv(f"{base}_in.csv"),
        output=outs,
    )
    assert validate_result(res, ref, 0.0, s.duration) is None  # fmpy's band check
    # the displacements (no feedthrough) within one communication step of phase, w h,
    # of their peak: the importer applies each input row for the step after it
    for name in ("head_displacement", "torso_displacement"):
        err = np.max(np.abs(np.interp(ref["time"], res["time"], res[name]) - ref[name]))
        assert err <= 2 * math.pi * s.frequency * s.step * np.max(np.abs(ref[name])), name


@pytest.mark.integration
def test_the_cross_check_script_rebuilds_its_tree_from_anywhere(tmp_path):
    """``_cc.sh`` is the command that made the tree, with the tree's own root (no
    placeholder): run from another folder, it writes the same reference again."""
    import os
    import subprocess
    import sys

    p = run_cli("build", "--cross-check", "cc", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    (folder,) = (tmp_path / "cc" / "fmus" / "2.0" / "cs" / "linux64" / "bodyvib").glob("*/*")
    script = folder / "HumanBody3DOF_cc.sh"
    assert (
        "DEST" not in script.read_text()
        and "DEST" not in (folder / "HumanBody3DOF_cc.bat").read_text()
    )
    ref = folder / "HumanBody3DOF_ref.csv"
    before = ref.read_bytes()
    ref.unlink()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {**os.environ, "PATH": os.path.dirname(sys.executable) + os.pathsep + os.environ["PATH"]}
    out = subprocess.run(
        ["sh", str(script)], cwd=elsewhere, env=env, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr
    assert ref.read_bytes() == before and list(elsewhere.iterdir()) == []
