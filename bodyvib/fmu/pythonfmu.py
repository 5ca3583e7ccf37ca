"""Build one pythonfmu FMU from a model: any network, any FMU kind of the contract.

:func:`build_fmu` writes ``<name>.fmu`` with pythonfmu, then finishes its
``modelDescription.xml`` (units, min/max, ModelStructure with Outputs and
InitialUnknowns) so that ``fmpy validate`` reports no problem, and checks that
it does. The project's own set of FMUs (``HumanBody3DOF``, ``HumanBodyISO7962``,
``QuarterCar``) and ``python build_fmu.py`` are :mod:`vehicle.fmus`.

Private module names. A module name loaded inside an FMU is global to the host
process and the first loaded copy wins, so each FMU ships:

* ``resources/bodyvib_rt_<fmu>_<hash>/``: a copy of the numpy-only run-time
  package :mod:`bodyvib.runtime` (relative imports only);
* ``resources/bodyvib_fmu_<fmu>_<hash>.py``: the one slave script of
  ``fmu_src/`` rendered for this FMU (:func:`render_slave_script`), its
  ``RUNTIME`` line pointing at that package;
* ``resources/bodyvib_model.json``: the parameter file baked in;

where ``<hash>`` is a content hash of all three, so an FMU never picks up the
host's ``bodyvib`` (or another FMU's copy of a different version).

Build-time needs: pythonfmu and fmpy. Run-time needs of the FMU: a Python with
numpy (the slave imports pythonfmu, which the FMU carries in its resources).
"""

import hashlib
import io
import json
import os
import re
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import Dict, Iterable
from xml.etree import ElementTree as ET

from .. import __version__
from ..process import interrupts
from ..process.outputs import atomic_write_bytes
from ..runtime.contract import MODEL_FILE
from ..runtime.errors import BodyvibError
from ..runtime.network import Network
from .description import default_stop_time, display_unit, initial_dependencies, unit_definitions
from .sources import RUNTIME_DIR, fmu_src_dir

__all__ = ["SLAVE_SCRIPT", "build_fmu", "build_source_fmu", "render_slave_script",
           "runtime_sources", "write_runtime_package"]

#: The one slave script, rendered per FMU (shipped in the ``fmu_src`` package).
SLAVE_SCRIPT = "bodyvib_fmu_slave.py"


def _slave_template() -> Path:
    return fmu_src_dir() / SLAVE_SCRIPT


def runtime_sources() -> Dict[str, bytes]:
    """The run-time package's modules: file name -> source bytes, sorted by name.

    Returns
    -------
    dict of str to bytes
    """
    return {p.name: p.read_bytes() for p in sorted(RUNTIME_DIR.glob("*.py"))}


def _content_hash(parts: Iterable[bytes]) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(hashlib.sha256(p).digest())
    return h.hexdigest()[:10]


def write_runtime_package(folder, package: str, owner: str = "an FMU") -> Path:
    """Copy the run-time package :mod:`bodyvib.runtime` into ``folder/package/``.

    Parameters
    ----------
    folder : str or path
        Where to create the package folder.
    package : str
        Its (private, unique) name.
    owner : str
        Named in the package docstring.

    Returns
    -------
    Path
        The package folder.
    """
    pkg = Path(folder) / package
    pkg.mkdir(parents=True, exist_ok=True)
    for m, data in runtime_sources().items():
        if m != "__init__.py":
            (pkg / m).write_bytes(data)
    (pkg / "__init__.py").write_text(
        f'"""Private copy of the bodyvib {__version__} run-time package for {owner}."""\n'
        f'__version__ = "{__version__}"\n', encoding="utf-8")
    return pkg


def render_slave_script(name: str, kind: str, description: str, runtime_package: str) -> str:
    """The slave script of one FMU: ``fmu_src/bodyvib_fmu_slave.py`` rendered.

    Parameters
    ----------
    name : str
        FMU model name; becomes the slave class name.
    kind : str
        FMU kind of the contract (``"body"`` or ``"car"``).
    description : str
        One-line description of the FMU.
    runtime_package : str
        Package the script imports the run-time modules from (the FMU's
        private copy; ``"bodyvib.runtime"`` to run the script against the library).

    Returns
    -------
    str
        Python source.

    Raises
    ------
    BodyvibError
        An FMU name that is not a Python identifier, or the slave source missing.
    """
    if not name.isidentifier():
        raise BodyvibError(f"FMU name '{name}' is not a valid identifier (letters, digits, _)")
    script = _slave_template()
    if not script.is_file():
        raise BodyvibError(f"slave script {script} not found; reinstall bodyvib")
    text = script.read_text(encoding="utf-8")
    for pattern, line in (
        (r'^RUNTIME = "bodyvib.runtime".*$', f"RUNTIME = {runtime_package!r}"),
        (r'^KIND = .*$', f"KIND = {kind!r}"),
        (r'^DESCRIPTION = .*$', f"DESCRIPTION = {description!r}"),
        (r'^class BodyvibSlave\(Fmi2Slave\):.*$', f"class {name}(Fmi2Slave):"),
    ):
        text, count = re.subn(pattern, line.replace("\\", "\\\\"), text, count=1, flags=re.M)
        if count != 1:
            raise BodyvibError(f"{script}: no line matching {pattern!r} to render")
    return text



def build_fmu(network: Network, kind: str, name: str, description: str, dest="dist") -> Path:
    """Build one pythonfmu FMU of a model.

    Parameters
    ----------
    network : Network
        The model to bake in (its parameter values become the parameters' start values).
    kind : str
        FMU kind of the contract: ``"body"`` or ``"car"``
        (:data:`bodyvib.runtime.contract.KINDS`).
    name : str
        FMU model name (``"HumanBody3DOF"``); the file is ``dest/<name>.fmu``.
    description : str
        One-line description written into the model description.
    dest : str or path
        Output folder (created if missing).

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        A model the FMU kind cannot run, invalid parameters, pythonfmu
        failing, or an FMU that ``fmpy validate`` finds problems in.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> build_fmu(load_model("reduced-paper"), "body", "HumanBody3DOF",
    ...           "reduced body", "dist")  # doctest: +SKIP
    PosixPath('dist/HumanBody3DOF.fmu')
    """
    from ..runtime.engine import FmuCore
    from ..runtime.modelfile import network_to_dict

    core = FmuCore(kind, network, name)  # refuses a model the FMU could not run
    core.check_parameters()
    model_bytes = (json.dumps(network_to_dict(network), indent=2) + "\n").encode()
    return _build(core, kind, name, description, {MODEL_FILE: model_bytes},
                  f"Model '{network.name}': {network.description}", dest)


def build_source_fmu(meta: dict, table, name: str, description: str, dest="dist") -> Path:
    """Build one pythonfmu FMU of the ``source`` kind: a tabulated signal and its rate.

    Parameters
    ----------
    meta : dict
        The source description (:mod:`bodyvib.runtime.source`), without
        ``table`` and ``periodic``.
    table : bodyvib.runtime.source.HermiteTable
        The profiles and their slopes over the coordinate.
    name, description, dest
        As :func:`build_fmu`.

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        As :func:`build_fmu`.
    """
    from ..runtime.source import SOURCE_FILE, SourceCore, write_source

    core = SourceCore(meta, table, name)
    core.check_parameters()
    with tempfile.TemporaryDirectory(prefix="bodyvib_source_") as tmp:
        files = {os.path.basename(p): Path(p).read_bytes() for p in write_source(tmp, meta, table)}
    assert SOURCE_FILE in files
    return _build(core, "source", name, description, files,
                  f"Source '{meta['name']}': {meta['description']}", dest)


def _build(core, kind: str, name: str, description: str, resources: Dict[str, bytes],
           about: str, dest) -> Path:
    """Package a slave over ``core`` with pythonfmu, finish and validate its model description."""
    sources = runtime_sources()
    template = render_slave_script(name, kind, description, "bodyvib.runtime")
    digest = _content_hash([template.encode()] + [resources[k] for k in sorted(resources)]
                           + list(sources.values()))
    package = f"bodyvib_rt_{name.lower()}_{digest}"
    module = f"bodyvib_fmu_{name.lower()}_{digest}"
    script_text = render_slave_script(name, kind, description, package)
    dest = Path(dest)
    with tempfile.TemporaryDirectory(prefix="bodyvib_build_") as tmp:
        stage = Path(tmp) / "stage"
        pkg = write_runtime_package(stage, package, f"{name}.fmu")
        (stage / f"{module}.py").write_text(script_text, encoding="utf-8")
        for fname, data in resources.items():
            (stage / fname).write_bytes(data)
        out = Path(tmp) / "out"
        # pythonfmu runs in a fresh process: in a process that has run a pythonfmu FMU,
        # 'pythonfmu' may be the FMU's embedded copy, which has no binaries to package.
        cmd = [sys.executable, "-m", "pythonfmu", "build", "-f", str(stage / f"{module}.py"),
               "-d", str(out), "--no-external-tool", "--handle-state", "--serialize-state",
               str(pkg)] + [str(stage / fname) for fname in resources]
        # a signal kills its process group; its temporary files stay in the build's folder
        proc = interrupts.run_process(cmd, cwd=tmp, scratch=Path(tmp) / "pythonfmu-tmp")
        built = out / f"{name}.fmu"
        if proc.returncode != 0 or not built.is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
            raise BodyvibError(f"pythonfmu could not build {name}.fmu (is pythonfmu installed? "
                               f"pip install pythonfmu): {' | '.join(tail)}")
        data = _finish(built, core, about)
        checked = Path(tmp) / f"{name}.fmu"  # validated before it may replace a good FMU
        checked.write_bytes(data)
        problems = _validate(checked)
    target = dest / f"{name}.fmu"
    if problems:
        raise BodyvibError(f"{target}: fmpy validate found problems: " + "; ".join(problems))
    atomic_write_bytes(target, data)
    return target


def _num(x: float) -> str:
    return repr(float(x))


def _finish(fmu: Path, core, about: str) -> bytes:
    """The FMU's bytes with its modelDescription.xml completed."""
    with zipfile.ZipFile(fmu) as zf:
        entries = [(info, zf.read(info)) for info in zf.infolist()]
    md = next(data for info, data in entries if info.filename == "modelDescription.xml")
    if not any(info.filename.startswith("binaries/") for info, _ in entries):
        raise BodyvibError(f"{fmu.name}: pythonfmu packaged no binaries (pythonfmu without "
                           "its resources/binaries?); reinstall pythonfmu")
    root = ET.fromstring(md)
    root.set("description", f"{root.get('description', '')}. {about}".strip())
    root.set("version", __version__)

    by_name = {v.name: v for v in core.variables}
    used = []
    svs = root.find("ModelVariables").findall("ScalarVariable")
    for sv in svs:
        v = by_name[sv.get("name")]
        real = sv.find("Real")
        real.set("unit", v.unit)
        if real.get("start") is not None and v.start is not None:
            real.set("start", _num(v.start))  # pythonfmu writes 16 digits: may be 1 ulp off
        if v.min is not None:
            real.set("min", _num(v.min))
        if v.max is not None:
            real.set("max", _num(v.max))
        if display_unit(v):
            real.set("displayUnit", display_unit(v))
        if v.unit not in used:
            used.append(v.unit)

    children = list(root)
    root.insert(children.index(root.find("CoSimulation")) + 1, unit_definitions(used))
    root.find("DefaultExperiment").set("stopTime", _num(default_stop_time(core)))

    structure = root.find("ModelStructure")
    for child in list(structure):
        structure.remove(child)
    index = {sv.get("name"): i + 1 for i, sv in enumerate(svs)}
    deps = [[index[core.variables[i].name] for i in d] for d in core.output_dependencies()]
    initial_deps = initial_dependencies(deps, [index[p.name] for p in core.parameters],
                                        core.kind == "source")
    outputs = ET.SubElement(structure, "Outputs")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for j, v in enumerate(core.interface.outputs):
        ET.SubElement(outputs, "Unknown", index=str(index[v.name]),
                      dependencies=" ".join(str(d) for d in deps[j]))
    for j, v in sorted(enumerate(core.interface.outputs), key=lambda jv: index[jv[1].name]):
        ET.SubElement(initial, "Unknown", index=str(index[v.name]),
                      dependencies=" ".join(str(d) for d in initial_deps[j]))

    ET.indent(root)
    xml = ET.tostring(root, encoding="UTF-8", xml_declaration=True)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for info, data in entries:
            if info.filename == "modelDescription.xml":
                data = xml
            zf.writestr(info.filename, data, compress_type=zipfile.ZIP_DEFLATED)
    return buf.getvalue()


def _validate(path: Path):
    from fmpy.validation import validate_fmu

    return validate_fmu(str(path))
