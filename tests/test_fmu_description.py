"""One modelDescription.xml writer for both FMU kinds (bodyvib.fmu.description).

References: the FMU contract's cores (bodyvib.runtime.engine.FmuCore,
bodyvib.runtime.tabulated.SourceCore: variables by value reference, output dependencies),
the native FMI 2.0 FMU of the same model (co-simulation and Model Exchange), and the
pythonfmu FMU run with and without its modelDescription.xml.
"""

import subprocess
import sys
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import pytest

from bodyvib import __version__
from bodyvib.runtime.errors import BodyvibError

pytestmark = pytest.mark.integration

NAMES = ("HumanBody3DOF", "HumanBodyISO7962", "QuarterCar", "Road")

#: Co-simulation flags whose meaning both kinds share (the others differ by design: the
#: native FMU interpolates inputs, gives output derivatives and directional derivatives).
SHARED_FLAGS = (
    "modelIdentifier",
    "needsExecutionTool",
    "canHandleVariableCommunicationStepSize",
    "canBeInstantiatedOnlyOncePerProcess",
    "canNotUseMemoryManagementFunctions",
    "canGetAndSetFMUstate",
    "canSerializeFMUstate",
)


def _root(path):
    with zipfile.ZipFile(path) as zf:
        return ET.fromstring(zf.read("modelDescription.xml"))


def _core(name):
    """The core a pythonfmu FMU of the project runs (the contract both kinds declare)."""
    from bodyvib.runtime.engine import FmuCore
    from bodyvib.runtime.tabulated import SourceCore
    from bodyvib.vehicle.fmus import FMUS, ROAD_DEFAULTS, _road_source, load_fmu_model

    kind = FMUS[name][0]
    if kind == "source":
        meta, table = _road_source(**ROAD_DEFAULTS)
        return SourceCore(meta, table, name)
    return FmuCore(kind, load_fmu_model(name), name)


def _text(element):
    """An element's XML, without the whitespace that follows it (its place in the file)."""
    return ET.tostring(element).rstrip()


def _unknowns(root, group, n):
    """``index -> dependencies`` of a ModelStructure group, the contract's variables only
    (indices 1..n: the native FMUs' states and derivatives follow them)."""
    out = {}
    for u in root.find(f"ModelStructure/{group}"):
        index = int(u.get("index"))
        if index <= n:
            out[index] = [int(d) for d in u.get("dependencies").split() if int(d) <= n]
    return out


def test_the_native_car_has_the_python_cars_nonlinear_elements(python_fmu_dir, native_dist):
    """The native QuarterCar steps the tire contact and the stops as the pythonfmu car does:
    the same variables (the stops' parameters, the contact flag, the occupant's static load),
    and its model exchange declares the three switching functions as event indicators."""
    py, nat = _root(python_fmu_dir / "QuarterCar.fmu"), _root(native_dist / "QuarterCar.fmu")
    names = lambda root: {v.get("name") for v in root.findall("ModelVariables/ScalarVariable")}  # noqa: E731
    assert {n for n in names(nat) if not n.startswith(("state.", "der("))} == names(py)
    assert nat.get("numberOfEventIndicators") == "3"


@pytest.mark.parametrize("name", NAMES)
def test_both_kinds_write_the_same_description_of_the_contract(python_fmu_dir, native_dist, name):
    """The pythonfmu FMU's description is the native FMI 2.0 one without what only the native
    kind has (Model Exchange, states, derivatives, its own capabilities): the same variables
    to the byte, value references equal to the core's order, the same units, default
    experiment and dependencies; and those dependencies are the core's."""
    py, nat = _root(python_fmu_dir / f"{name}.fmu"), _root(native_dist / f"{name}.fmu")
    core = _core(name)
    n = len(core.variables)
    for attr in (
        "fmiVersion",
        "modelName",
        "description",
        "author",
        "version",
        "variableNamingConvention",
    ):
        assert py.get(attr) == nat.get(attr), attr
    assert py.find("ModelExchange") is None and nat.find("ModelExchange") is not None
    assert [py.find("CoSimulation").get(f) for f in SHARED_FLAGS] == [
        nat.find("CoSimulation").get(f) for f in SHARED_FLAGS
    ]
    assert py.find("DefaultExperiment").attrib == nat.find("DefaultExperiment").attrib

    py_vars = py.findall("ModelVariables/ScalarVariable")
    nat_vars = nat.findall("ModelVariables/ScalarVariable")
    assert len(py_vars) == n and all(v.get("causality") == "local" for v in nat_vars[n:])
    assert [_text(v) for v in py_vars] == [_text(v) for v in nat_vars[:n]]
    assert [(v.get("name"), int(v.get("valueReference"))) for v in py_vars] == [
        (v.name, vr) for vr, v in enumerate(core.variables)
    ]

    units = {u.get("name"): _text(u) for u in nat.iterfind("UnitDefinitions/Unit")}
    assert [_text(u) for u in py.iterfind("UnitDefinitions/Unit")] == [
        units[u] for u in dict.fromkeys(v.unit for v in core.variables)
    ]

    outputs = _unknowns(py, "Outputs", n)
    assert outputs == _unknowns(nat, "Outputs", n)
    assert _unknowns(py, "InitialUnknowns", n) == _unknowns(nat, "InitialUnknowns", n)
    index = {v.name: vr + 1 for vr, v in enumerate(core.variables)}
    assert outputs == {
        index[v.name]: [d + 1 for d in deps]
        for v, deps in zip(core.interface.outputs, core.output_dependencies())
    }


def test_pythonfmu_value_references_are_checked_and_the_writer_is_the_only_author(python_fmu_dir):
    """Written again from its own XML, the pythonfmu FMU's description is byte for byte the
    same (nothing of pythonfmu's layout is left; the generation tool, read from pythonfmu's
    XML, aside); value references other than the core's are refused by name."""
    from dataclasses import replace

    from bodyvib.fmu.description import write_model_description
    from bodyvib.fmu.pythonfmu import pythonfmu_description

    with zipfile.ZipFile(python_fmu_dir / "HumanBody3DOF.fmu") as zf:
        xml = zf.read("modelDescription.xml")
    core = _core("HumanBody3DOF")
    text = ET.fromstring(xml).get("description")
    md = pythonfmu_description(xml, core, text)
    tool = ET.fromstring(xml).get("generationTool")
    assert md.generation_tool == f"bodyvib {__version__} with {tool}"
    assert write_model_description(replace(md, generation_tool=tool)) == xml
    assert md.fmi == 2 and [i.element for i in md.interfaces] == ["CoSimulation"]

    root = ET.fromstring(xml)
    first, second = root.findall("ModelVariables/ScalarVariable")[:2]
    vr1, vr2 = first.get("valueReference"), second.get("valueReference")
    first.set("valueReference", vr2)
    second.set("valueReference", vr1)
    with pytest.raises(BodyvibError, match="value references other than the core's"):
        pythonfmu_description(ET.tostring(root), core, text)


_RUN = r"""
import os, shutil, sys, tempfile
import numpy as np
from fmpy import extract
from fmpy.fmi2 import FMU2Slave

path, drop = sys.argv[1], sys.argv[2] == "drop"
folder = extract(path, unzipdir=tempfile.mkdtemp(prefix="bodyvib-test-md-"))
try:
    if drop:
        os.remove(os.path.join(folder, "modelDescription.xml"))
    fmu = FMU2Slave(guid="{not-the-guid}" if drop else "", unzipDirectory=folder,
                    modelIdentifier="HumanBody3DOF", instanceName="md")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    out = []
    for k in range(200):
        t = k * 1e-3
        fmu.setReal([0, 1], [0.01 * np.sin(30 * t), 0.3 * np.cos(30 * t)])
        fmu.doStep(currentCommunicationPoint=t, communicationStepSize=1e-3)
        out.append(fmu.getReal([3, 6, 7]))
    fmu.terminate()
    fmu.freeInstance()
    print(repr(np.array(out).tolist()))
finally:
    shutil.rmtree(folder, ignore_errors=True)
"""


def test_pythonfmu_wrapper_reads_no_model_description_at_run_time(python_fmu_dir):
    """What the writer relies on: pythonfmu's C wrapper finds the slave through
    resources/slavemodule.txt, not the XML, and checks no GUID. Without its
    modelDescription.xml (and with a wrong GUID) the FMU computes the same outputs, bit for
    bit (the same code runs), as with it; each run in its own process."""
    path = str(python_fmu_dir / "HumanBody3DOF.fmu")
    runs = []
    for how in ("keep", "drop"):
        out = subprocess.run(
            [sys.executable, "-c", _RUN, path, how],
            capture_output=True,
            text=True,
            timeout=300,
            cwd=Path(__file__).parent,
        )
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(out.stdout.strip().splitlines()[-1])
    assert runs[0] == runs[1]
    assert any(abs(y) > 0 for row in eval(runs[0]) for y in row)  # not vacuous
