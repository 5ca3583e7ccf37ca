"""One name per concept: the renamed parameters, fields and keys still work, warned.

Each case calls the same thing by its old name and by its new one: the old call must warn
with a ``DeprecationWarning`` naming both names and give the same result as the new call,
which must not warn (the test configuration turns bodyvib's warnings into errors).
"""

import json
import warnings

import numpy as np
import pytest

from bodyvib.comfort import ComfortFigures, basic_method_checks
from bodyvib.fit import load_config
from bodyvib.fit.objective import impulse_response, objective_time_domain
from bodyvib.fmu.crosscheck import CrossCheckSettings
from bodyvib.models import load_model
from bodyvib.runtime.discretize import Discretization, check_step, discretize
from bodyvib.runtime.renames import renamed_fields, renamed_parameters
from bodyvib.vehicle.road.driven import RunSettings
from bodyvib.vehicle.road.iri import IriResult

REDUCED = load_model("reduced-paper")
LM = Discretization(REDUCED).model

#: (what, call by the old names, call by the new names, old name -> new name)
CALLS = [
    (
        "RunSettings",
        lambda: RunSettings(step_s=2e-3, duration_s=5.0, speed_m_s=10.0),
        lambda: RunSettings(step=2e-3, duration=5.0, speed=10.0),
        {"step_s": "step", "duration_s": "duration", "speed_m_s": "speed"},
    ),
    (
        "discretize",
        lambda: discretize(LM.A, LM.B, h=1e-3),
        lambda: discretize(LM.A, LM.B, step=1e-3),
        {"h": "step"},
    ),
    (
        "Discretization.step",
        lambda: Discretization(REDUCED).step(np.zeros(5), [0.01, 0], [0, 0], h=1e-3),
        lambda: Discretization(REDUCED).step(np.zeros(5), [0.01, 0], [0, 0], step=1e-3),
        {"h": "step"},
    ),
    (
        "impulse_response",
        lambda: impulse_response(REDUCED, t_end=0.5, dt=1e-3),
        lambda: impulse_response(REDUCED, duration=0.5, step=1e-3),
        {"t_end": "duration", "dt": "step"},
    ),
    (
        "objective_time_domain",
        lambda: objective_time_domain(REDUCED, REDUCED, dt=1e-3, t_end=0.5),
        lambda: objective_time_domain(REDUCED, REDUCED, step=1e-3, duration=0.5),
        {"t_end": "duration", "dt": "step"},
    ),
    (
        "CrossCheckSettings",
        lambda: CrossCheckSettings(stop_time=2.0),
        lambda: CrossCheckSettings(duration=2.0),
        {"stop_time": "duration"},
    ),
    (
        "basic_method_checks",
        lambda: basic_method_checks(ComfortFigures(1.0, 1.0, 10.0, 10.0, "", 1.2), duration_s=4.0),
        lambda: basic_method_checks(ComfortFigures(1.0, 1.0, 10.0, 10.0, "", 1.2), duration=4.0),
        {"duration_s": "duration"},
    ),
]


def _same(a, b):
    if (
        isinstance(a, tuple)
        and not hasattr(a, "_fields")
        and not hasattr(a, "__dataclass_fields__")
    ):
        return all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    return a == b


@pytest.mark.parametrize("what, old, new, renames", CALLS, ids=[c[0] for c in CALLS])
def test_old_name_warns_and_means_the_new(what, old, new, renames):
    with pytest.warns(DeprecationWarning) as record:
        by_old = old()
    told = sorted(str(w.message) for w in record)
    assert told == sorted(
        f"{what}: '{o}' is renamed '{n}'; the old name will be removed in the next release"
        for o, n in renames.items()
    )
    assert all(w.filename == __file__ for w in record)  # points at the caller
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        by_new = new()
    assert _same(by_old, by_new)


def test_old_attributes_read_the_new_fields():
    s = RunSettings(step=2e-3, duration=5.0, speed=10.0)
    for old, value in (("step_s", 2e-3), ("duration_s", 5.0), ("speed_m_s", 10.0)):
        with pytest.warns(DeprecationWarning, match=f"RunSettings: '{old}' is renamed"):
            assert getattr(s, old) == value
    iri = IriResult(iri_m_per_km=1.0, length_m=50.0, speed=80 / 3.6, smoothing_samples=1)
    with pytest.warns(DeprecationWarning, match="'speed_m_s' is renamed 'speed'"):
        assert iri.speed_m_s == iri.speed
    with pytest.warns(DeprecationWarning, match="'stop_time' is renamed 'duration'"):
        assert CrossCheckSettings().stop_time == CrossCheckSettings().duration


def test_old_and_new_name_together_are_refused():
    with pytest.raises(TypeError, match="got 'h' and its new name 'step'"):
        check_step(h=1e-3, step=1e-3)
    with pytest.raises(TypeError, match="got 'step_s' and its new name 'step'"):
        RunSettings(step_s=1e-3, step=1e-3)


def test_helpers_leave_a_call_by_the_new_name_alone():
    calls = []

    @renamed_parameters(old="new")
    def f(new=0, other=0):
        calls.append((new, other))

    @renamed_fields(a_s="a")
    class K:
        def __init__(self, a=0):
            self.a = a

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f(1, other=2)
        f(new=3)
        assert K(a=4).a == 4
    assert calls == [(1, 2), (3, 0)]
    assert f.__name__ == "f"


def test_fit_configuration_file_takes_the_old_time_step_key(tmp_path):
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"time_domain": {"dt_s": 1e-3}}))
    with pytest.warns(DeprecationWarning, match="time_domain: 'dt_s' is renamed 'step'"):
        cfg = load_config(path)
    assert cfg.time_domain.step == 1e-3
    assert load_config(overrides={"time_domain": {"step": 1e-3}}).time_domain == cfg.time_domain


def test_sweep_table_of_the_old_columns_reads_with_the_new_names(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    from bodyvib.vehicle.sweep.run import read_results, run_sweep

    out = str(tmp_path / "r.parquet")
    spec = {"road": "C", "speed": [10, 20], "body": "reduced-paper"}
    new = run_sweep(spec, engine="spectral", scheduler="serial", out=out)
    table = pq.read_table(out)  # as an older bodyvib wrote it
    old_names = {"speed": "speed_m_s", "duration": "duration_s", "step": "step_s"}
    pq.write_table(table.rename_columns([old_names.get(n, n) for n in table.column_names]), out)
    with pytest.warns(DeprecationWarning) as record:
        again = read_results(out)
    told = {str(w.message).split(": ", 1)[1].split(";")[0] for w in record}
    assert told == {f"'{o}' is renamed '{n}'" for n, o in old_names.items()}
    assert list(again.columns) == list(new.columns)
    assert again["speed"].tolist() == [10.0, 20.0]


def test_output_folder_is_dest(tmp_path):
    from bodyvib.fmu.pythonfmu import write_runtime_package

    with pytest.warns(DeprecationWarning, match="'folder' is renamed 'dest'"):
        old = write_runtime_package(folder=tmp_path / "a", package="rt_x")
    new = write_runtime_package(dest=tmp_path / "b", package="rt_x")
    assert sorted(p.name for p in old.iterdir()) == sorted(p.name for p in new.iterdir())


def test_sweep_status_lines_go_to_progress():
    from bodyvib.vehicle.sweep.run import run_sweep

    spec = {"road": "C", "speed": 20, "body": "reduced-paper"}
    by_old, by_new = [], []
    with pytest.warns(DeprecationWarning, match="run_sweep: 'echo' is renamed 'progress'"):
        run_sweep(spec, engine="spectral", scheduler="serial", echo=by_old.append)
    run_sweep(spec, engine="spectral", scheduler="serial", progress=by_new.append)
    assert by_old == by_new and by_new[-1] == "sweep: 1 cases"


def test_quiet_is_the_opposite_of_progress():
    from bodyvib.runtime.renames import NOT

    @renamed_parameters(quiet=NOT("progress"))
    def run(progress=False):
        return progress

    with pytest.warns(DeprecationWarning, match="'quiet' is renamed 'progress'"):
        assert run(quiet=False) is True
    with pytest.warns(DeprecationWarning):
        assert run(quiet=True) is False
    with pytest.warns(DeprecationWarning):  # both, as the old command line gave them
        assert run(progress=True, quiet=True) is True


def test_road_options_take_the_old_taper_and_track():
    from bodyvib.runtime.errors import BodyvibError
    from bodyvib.vehicle.fmus import fmu_road, road_with_defaults
    from bodyvib.vehicle.sweep.spec import expand

    spec = {"road": "C", "body": "reduced-paper", "duration": 1.0}
    with pytest.warns(DeprecationWarning, match="'taper' is renamed 'taper_m'"):
        old = expand(dict(spec, road_options={"taper": 2.0}))
    assert old == expand(dict(spec, road_options={"taper_m": 2.0}))
    assert old[0].road_settings().taper_m == 2.0
    with pytest.warns(DeprecationWarning, match="fmu_road: 'taper' is renamed 'taper_m'"):
        by_old = fmu_road("bump", 40.0, taper=3.0)
    assert by_old.taper == fmu_road("bump", 40.0, taper_m=3.0).taper == 3.0
    with pytest.warns(DeprecationWarning, match="'track' is renamed 'track_m'"):
        assert road_with_defaults({"track": 0.5})["track_m"] == 0.5
    with pytest.raises(BodyvibError, match="'taper' and its new name 'taper_m'"):
        expand(dict(spec, road_options={"taper": 2.0, "taper_m": 2.0}))
