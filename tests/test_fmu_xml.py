"""modelDescription.xml facts of both FMU kinds (pythonfmu and native, FMI 2.0 and 3.0).

References: the FMUs themselves, run in fmpy (which outputs an input moves at
initialization, measured, against the InitialUnknowns' dependencies), the loader's
parameter range (bodyvib.runtime.modelfile.PARAMETER_RANGE), the road table's extent, and
FMI's unit arithmetic (``unit = factor * displayUnit``).
"""

import shutil
from pathlib import Path

import numpy as np
import pytest

from bodyvib.runtime.modelfile import PARAMETER_RANGE
from bodyvib.vehicle.ssp import COMPONENTS, CONNECTIONS

pytestmark = pytest.mark.integration

NAMES = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar", "Road")


def all_fmus(native_dist, python_fmus):
    """(label, path) of every FMU: pythonfmu, native FMI 2.0, native FMI 3.0."""
    py = Path(python_fmus["QuarterCar"]).parent
    out = []
    for name in NAMES:
        out += [
            (f"pythonfmu/{name}", py / f"{name}.fmu"),
            (f"native/{name}", native_dist / f"{name}.fmu"),
            (f"native/fmi3/{name}", native_dist / "fmi3" / f"{name}.fmu"),
        ]
    return out


def structure(path):
    """outputs: name -> (input deps, initial deps), names only; and the variables by name."""
    from fmpy import read_model_description

    md = read_model_description(str(path))
    outs = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.outputs}
    init = {u.variable.name: {d.name for d in (u.dependencies or [])} for u in md.initialUnknowns}
    return md, outs, init


def _inputs_only(deps):
    """The unknowns and dependencies without the model-exchange states (``state.*``, their
    derivatives ``der(state.*)``), which only the native FMUs have."""
    return {
        k: {d for d in v if not d.startswith("state.")}
        for k, v in deps.items()
        if not k.startswith("der(state.")
    }


def test_every_fmu_validates_and_both_kinds_declare_the_same_interface(native_dist, python_fmus):
    from fmpy.validation import validate_fmu

    fmus = dict(all_fmus(native_dist, python_fmus))
    for label, path in fmus.items():
        assert validate_fmu(str(path)) == [], label
    for name in NAMES:
        ref_md, ref_out, ref_init = structure(fmus[f"pythonfmu/{name}"])
        ref = {v.name: v for v in ref_md.modelVariables}
        for label in (f"native/{name}", f"native/fmi3/{name}"):
            md, outs, init = structure(fmus[label])
            # the native FMUs' model-exchange states are dependencies the pythonfmu ones
            # (co-simulation only) do not have: compare the rest
            assert (_inputs_only(outs), _inputs_only(init)) == (ref_out, ref_init), label
            assert md.defaultExperiment.stopTime == ref_md.defaultExperiment.stopTime, label
            for v in md.modelVariables:
                if v.name in ref:
                    for attr in ("min", "max", "unit", "displayUnit", "start"):
                        assert str(getattr(v, attr)) == str(getattr(ref[v.name], attr)), (
                            label,
                            v.name,
                            attr,
                        )


def test_limits_are_the_loaders_and_readable(native_dist, python_fmus):
    """Every model parameter declares the loader's range, 1e-6 to 1e12, written as such;
    Road's speed min is 1e-6 m/s."""
    import zipfile

    lo, hi = PARAMETER_RANGE
    for label, path in all_fmus(native_dist, python_fmus):
        md, _, _ = structure(path)
        params = [v for v in md.modelVariables if v.causality == "parameter"]
        assert params, label
        for v in params:
            assert float(v.min) == lo, (label, v.name)
            if not label.endswith("Road"):
                assert float(v.max) == hi, (label, v.name)
        with zipfile.ZipFile(path) as z:
            text = z.read("modelDescription.xml").decode()
        assert "e-308" not in text and 'min="1e-06"' in text, label


def test_default_experiment_fits_each_fmu(native_dist, python_fmus):
    """Road: the 601 m table at its default 20 m/s, 30.05 s; body and car: 10 s; 1 ms steps."""
    for label, path in all_fmus(native_dist, python_fmus):
        de = structure(path)[0].defaultExperiment
        want = 601.0 / 20.0 if label.endswith("Road") else 10.0
        assert float(de.stopTime) == pytest.approx(want, rel=1e-15), label
        assert float(de.stepSize) == 1e-3, label


def test_display_units_convert_as_engineers_read_them(native_dist, python_fmus):
    """Displacements in mm (factor 1e-3: 1 mm = 0.001 m), velocities in mm/s, the speed in
    km/h (20 m/s = 72 km/h), accelerations in m/s2 with g (9.80665 m/s2) defined."""
    for label, path in all_fmus(native_dist, python_fmus):
        md, _, _ = structure(path)
        factors = {(u.name, d.name): d.factor for u in md.unitDefinitions for d in u.displayUnits}
        for v in md.modelVariables:
            if v.name == "time" or v.causality == "local":
                continue  # FMI 3.0's time; the native FMUs' model-exchange states
            want = {"m": "mm", "m/s": "km/h" if v.causality == "parameter" else "mm/s"}.get(v.unit)
            assert v.displayUnit == want, (label, v.name)
            if v.unit == "m/s2":
                assert factors[("m/s2", "g")] == 9.80665, label
        if label.endswith("Road"):
            speed = next(v for v in md.modelVariables if v.name == "speed")
            assert float(speed.start) / factors[("m/s", "km/h")] == pytest.approx(72.0, rel=1e-15)
        if ("m", "mm") in factors:
            assert factors[("m", "mm")] == 1e-3


def measured_feedthrough(path):
    """Which outputs an input moves at initialization: each input set to 1 in turn in fmpy
    (initialization mode, zero state), every output read; name -> set of outputs."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    unzipped = extract(str(path))
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier
    )
    inputs = [v for v in md.modelVariables if v.causality == "input"]
    outputs = [v for v in md.modelVariables if v.causality == "output"]
    moved = {}
    try:
        fmu.instantiate()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        base = np.array(fmu.getReal([v.valueReference for v in outputs]))
        for v in inputs:
            fmu.setReal([v.valueReference], [1.0])
            y = np.array(fmu.getReal([o.valueReference for o in outputs]))
            fmu.setReal([v.valueReference], [0.0])
            moved[v.name] = {o.name for o, a, b in zip(outputs, y, base) if a != b}
        fmu.exitInitializationMode()
        fmu.terminate()
    finally:
        fmu.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    return moved


@pytest.mark.parametrize("name", ["HumanBody3DOF", "HumanBodyISO7962", "QuarterCar"])
def test_initial_dependencies_are_the_measured_feedthrough(native_dist, name):
    """The inputs each initial unknown lists are exactly those that move it in the FMU."""
    _, _, init = structure(native_dist / f"{name}.fmu")
    moved = measured_feedthrough(native_dist / f"{name}.fmu")
    for inp, outs in moved.items():
        # the outputs (the states' derivatives, native only, are not measured here)
        assert outs == {
            o for o, deps in init.items() if inp in deps and not o.startswith("der(state.")
        }, inp


def _cycle(graph):
    """A node on a cycle of the directed graph (node -> set of nodes), or None."""
    state = {}

    def visit(node):
        state[node] = 1
        for nxt in graph.get(node, ()):
            if state.get(nxt) == 1:
                return nxt
            if nxt not in state:
                found = visit(nxt)
                if found is not None:
                    return found
        state[node] = 2
        return None

    for node in list(graph):
        if node not in state:
            found = visit(node)
            if found is not None:
                return found
    return None


def test_car_and_body_have_no_algebraic_loop(native_dist, python_fmus):
    """The SSP's connections with the initial unknowns' dependencies form no cycle (before,
    an initial unknown without dependencies depended on every input: car and body looped)."""
    for label, folder in (
        ("native", native_dist),
        ("native/fmi3", native_dist / "fmi3"),
        ("pythonfmu", Path(python_fmus["QuarterCar"]).parent),
    ):
        graph = {}
        for comp, name in COMPONENTS.items():
            _, _, init = structure(folder / f"{name}.fmu")
            for out, deps in init.items():
                for d in deps:
                    graph.setdefault((comp, d), set()).add((comp, out))
        for a, ac, b, bc in CONNECTIONS:
            graph.setdefault((a, ac), set()).add((b, bc))
        cycle = _cycle(graph)
        assert cycle is None, f"{label}: algebraic loop through {cycle}"
        # not vacuous: the feedthrough chain car -> body -> car is in the graph
        assert ("Body", "seat_force") in graph[("Body", "seat_displacement")], label
        assert ("Car", "sprung_acceleration") in graph[("Car", "seat_force")], label
