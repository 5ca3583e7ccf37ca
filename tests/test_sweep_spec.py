"""Sweep specs: expansion, parameter ranges, case keys, refusals."""

import json
import os

import numpy as np
import pytest

from bodyvib.models import MODEL_DIR, load_model
from bodyvib.runtime.errors import BodyvibError
from bodyvib.vehicle.sweep.spec import expand, grid_spec, spec_hash, varied_parameters


def test_product_order_and_defaults():
    cases = expand(
        {
            "road": ["C", "d"],
            "speed": [10, 20],
            "seed": [0, 3],
            "body": ["reduced-paper", "iso7962"],
        }
    )
    assert len(cases) == 2 * 2 * 2 * 2
    assert [c.case_id for c in cases] == list(range(16))
    first, last = cases[0], cases[-1]
    assert (first.road, first.seed, first.speed, first.body) == ("C", 0, 10.0, "reduced-paper")
    assert (last.road, last.seed, last.speed, last.body) == ("D", 3, 20.0, "iso7962")
    assert first.duration == 30.0 and first.step == 1e-3 and first.car == "quarter-car"
    assert first.steps == 30001  # as bodyvib cosim: round(duration / step) + 1
    assert len({c.case_key for c in cases}) == 16


def test_a_case_runs_its_own_settings():
    """Each of a case's five run settings reaches the run it makes, values typed here."""
    spec = {"road": ["D"], "speed": [17.5], "seed": 4, "duration": [6.0], "step": [2e-3]}
    spec["body"] = "reduced-paper"
    (case,) = expand(spec)
    run = case.run_settings()
    assert (run.road, run.seed, run.speed, run.duration, run.step) == ("D", 4, 17.5, 6.0, 2e-3)


def test_latin_hypercube_ranges_around_one_model():
    nominal = load_model("reduced-paper").parameters
    entry = {
        "model": "reduced-paper",
        "vary": {"k1": [0.8, 1.2], "c1": [0.5, 2.0]},
        "samples": 50,
        "seed": 7,
    }
    cases = expand({"road": "C", "speed": 20, "body": [entry]})
    assert len(cases) == 50 and [c.body_sample for c in cases] == list(range(50))
    f = np.array([[dict(c.body_values)[p] / nominal[p] for p in ("k1", "c1")] for c in cases])
    assert np.all((f[:, 0] >= 0.8) & (f[:, 0] <= 1.2) & (f[:, 1] >= 0.5) & (f[:, 1] <= 2.0))
    # one sample in each of the 50 equal strata of every factor
    for col, (lo, hi) in zip(f.T, ([0.8, 1.2], [0.5, 2.0])):
        strata = np.floor((col - lo) / (hi - lo) * 50).astype(int)
        assert sorted(strata) == list(range(50))
    assert varied_parameters(cases) == ["k1", "c1"]
    # reproducible from the seed; the body network carries the values
    again = expand({"road": "C", "speed": 20, "body": [entry]})
    assert [c.case_key for c in again] == [c.case_key for c in cases]
    net = cases[3].body_network()
    assert net.parameters["k1"] == dict(cases[3].body_values)["k1"]
    assert net.parameters["m1"] == nominal["m1"]
    uni = expand({"road": "C", "speed": 20, "body": [{**entry, "method": "uniform"}]})
    assert [c.case_key for c in uni] != [c.case_key for c in cases]


def test_grid_items():
    spec = grid_spec(
        ["road=C,D", "speed=10,20", "seed=0,1", "body=reduced-paper,iso7962"], duration=5
    )
    assert spec == {
        "duration": 5,
        "step": 1e-3,
        "road": ["C", "D"],
        "speed": [10.0, 20.0],
        "seed": [0, 1],
        "body": ["reduced-paper", "iso7962"],
    }
    assert len(expand(spec)) == 16
    for bad, msg in (
        (["road"], "key=v1,v2"),
        (["colour=red"], "unknown"),
        (["speed=1,x"], "numbers"),
        (["road=C", "road=D"], "twice"),
    ):
        with pytest.raises(BodyvibError, match=msg):
            grid_spec(bad)


def test_spec_hash_covers_referenced_files(tmp_path):
    model = tmp_path / "body.json"
    data = json.loads(open(os.path.join(MODEL_DIR, "reduced-paper.json")).read())
    model.write_text(json.dumps(data))
    spec = {"road": "C", "speed": 20, "body": [str(model)]}
    h1 = spec_hash(spec)
    key1 = expand(spec)[0].case_key
    data["parameters"]["k1"] *= 1.1
    model.write_text(json.dumps(data))
    assert spec_hash(spec) != h1
    assert expand(spec)[0].case_key != key1
    assert expand(spec)[0].body == "body"


@pytest.mark.parametrize(
    "spec, msg",
    [
        ({"speed": 10, "body": "reduced-paper"}, "'road' is required"),
        ({"road": "C", "speed": 10, "body": "reduced-paper", "colour": 1}, "unknown key"),
        ({"road": "Z", "speed": 10, "body": "reduced-paper"}, "unknown road"),
        ({"road": "C", "speed": -1, "body": "reduced-paper"}, "speed must be a positive"),
        ({"road": "C", "speed": 10, "seed": 1.5, "body": "reduced-paper"}, "non-negative integer"),
        ({"road": "C", "speed": 10, "body": "nobody"}, "unknown model"),
        ({"road": "C", "speed": 10, "body": "reduced-paper", "car": "truck"}, "unknown vehicle"),
        (
            {
                "road": "C",
                "speed": 10,
                "body": [],
            },
            "empty list",
        ),
        (
            {"road": "C", "speed": 10, "body": "reduced-paper", "duration": 1, "step": 0.6},
            "too long",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": [{"model": "reduced-paper", "vary": {"k9": [1, 2]}}],
            },
            "no parameter 'k9'",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": [{"model": "reduced-paper", "vary": {"k1": [1.2, 0.8]}}],
            },
            "low <= high",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": [{"model": "reduced-paper", "vary": {"k1": [1, 2]}, "samples": 0}],
            },
            "positive integer",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": [{"model": "reduced-paper", "vary": {"k1": [1, 2]}, "method": "sobol"}],
            },
            "lhs",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": ["reduced-paper", {"model": "reduced-paper", "vary": {"k1": [1, 2]}}],
            },
            "named",
        ),
        (
            {
                "road": "C",
                "speed": 10,
                "body": ["reduced-paper"],
                "car": ["quarter-car", "quarter-car"],
            },
            "same case",
        ),
    ],
)
def test_refusals_name_the_problem(spec, msg):
    with pytest.raises(BodyvibError, match=msg):
        expand(spec)


def test_the_documented_spec_example_expands():
    from helpers import ROOT

    path = os.path.join(ROOT, "docs", "tutorials", "sweep.md")
    text = open(path, encoding="utf-8").read()
    section = text.split("## Sweeps", 1)[1].split("\n## ", 1)[0]
    spec = json.loads(section.split("```json\n", 1)[1].split("```", 1)[0])
    # the tutorial's `bodyvib sweep examples/study.json` runs this spec
    with open(os.path.join(ROOT, "examples", "study.json"), encoding="utf-8") as f:
        assert json.load(f) == spec
    cases = expand(spec)
    assert len(cases) == 5 * 5 * (1 + 400) * 2
    assert {c.body for c in cases} == {"iso7962", "reduced-varied"}


def test_seed_ranges_in_specs_and_grids():
    from bodyvib.vehicle.sweep.spec import count_cases, iter_cases

    spec = {"road": "C", "speed": [10, 20], "seed": "0..24", "body": "reduced-paper"}
    cases = expand(spec)
    assert sorted({c.seed for c in cases}) == list(range(25)) and len(cases) == 50
    assert count_cases(spec) == 50 and [c.case_key for c in iter_cases(spec)] == [
        c.case_key for c in cases
    ]
    listed = expand({**spec, "seed": list(range(25))})
    assert [c.case_key for c in listed] == [c.case_key for c in cases]
    mixed = expand({**spec, "seed": ["0..2", 7]})
    assert sorted({c.seed for c in mixed}) == [0, 1, 2, 7]
    assert grid_spec(["seed=0..3,9"])["seed"] == ["0..3", 9]
    assert sorted(
        {
            c.seed
            for c in expand(
                {**grid_spec(["road=C", "speed=10", "seed=0..3,9", "body=reduced-paper"])}
            )
        }
    ) == [0, 1, 2, 3, 9]
    for bad in ("3..1", "a..b", "-1..2", "0..", "0...3"):
        with pytest.raises(BodyvibError, match="FIRST..LAST"):
            expand({**spec, "seed": bad})
    with pytest.raises(BodyvibError, match="listed twice"):
        expand({**spec, "seed": ["0..3", 2]})
