"""The one build entry, bodyvib.fmu.builder.build: refusals before any work.

The builds themselves (every kind with both backends) run through it in the FMU fixtures
and in test_fmu_integration, test_native_fmu and test_native_system.
"""

import pytest

from bodyvib.fmu.builder import build
from bodyvib.models import load_model
from bodyvib.runtime.errors import BodyvibError


@pytest.mark.parametrize(
    "args, kwargs, words",
    [
        (("body",), {"backend": "pythonfmu", "fmi": 3}, "pythonfmu FMUs are FMI 2.0 only"),
        (("seat",), {}, "unknown FMU kind 'seat'; kinds are body, car, source"),
        (("body",), {"backend": "modelica"}, "unknown FMU backend 'modelica'"),
        (("body",), {"backend": "native", "fmi": 1}, "FMI version must be 2 or 3"),
        (("source",), {}, "a source FMU is built from (meta, table)"),
    ],
)
def test_build_refuses_what_does_not_exist_before_any_work(tmp_path, args, kwargs, words):
    with pytest.raises(BodyvibError) as err:
        build(load_model("reduced-paper"), *args, "X", "", tmp_path / "out", **kwargs)
    assert words in str(err.value)
    assert not (tmp_path / "out").exists()  # nothing built, no folder made


def test_a_model_fmu_needs_a_network(tmp_path):
    with pytest.raises(BodyvibError, match="a body FMU is built from a Network"):
        build({"name": "reduced-paper"}, "body", "X", "", tmp_path)
