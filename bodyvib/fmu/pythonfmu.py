"""Build one pythonfmu FMU from a model: any network, any FMU kind of the contract.

:func:`build_fmu` writes ``<name>.fmu`` with pythonfmu, then replaces its
``modelDescription.xml`` with the one the native FMUs' writer writes
(:func:`bodyvib.fmu.description.write_model_description`; units, min/max, ModelStructure with
Outputs and InitialUnknowns, which pythonfmu 0.7.0 does not write), keeping what pythonfmu
decides (:func:`pythonfmu_description`), and checks it with ``fmpy validate``. The
project's own set of FMUs (``HumanBody3DOF``, ``HumanBodyISO7962``, ``QuarterCar``) and
``python build_fmu.py`` are :mod:`bodyvib.vehicle.fmus`.

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
import os
import re
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Dict, Iterable, Union
from xml.etree import ElementTree as ET

from .. import __version__
from ..process import interrupts
from ..process.outputs import atomic_write_bytes
from ..runtime.errors import BodyvibError
from ..runtime.network import Network
from ..runtime.renames import renamed_parameters

if TYPE_CHECKING:  # for annotations only: the cores are imported where a build needs them
    from ..runtime.engine import FmuCore
    from ..runtime.tabulated import HermiteTable, SourceCore
from .contents import RUNTIME_DIR, fmu_src_dir, model_resources, source_resources
from .description import (
    InterfaceElement,
    ModelDescription,
    default_stop_time,
    describe_fmu,
    validate_fmu_file,
    write_model_description,
)

__all__ = [
    "SLAVE_SCRIPT",
    "build_fmu",
    "build_source_fmu",
    "pythonfmu_description",
    "render_slave_script",
    "runtime_sources",
    "write_runtime_package",
]

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


@renamed_parameters(folder="dest")
def write_runtime_package(
    dest: Union[str, os.PathLike], package: str, owner: str = "an FMU"
) -> Path:
    """Copy the run-time package :mod:`bodyvib.runtime` into ``dest/package/``.

    Its modules as they are (they import each other relatively), and an ``__init__.py``
    of its own that names the copy's version and ``owner``.

    Parameters
    ----------
    dest : str or path
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
    pkg = Path(dest) / package
    pkg.mkdir(parents=True, exist_ok=True)
    for m, data in runtime_sources().items():
        if m != "__init__.py":
            (pkg / m).write_bytes(data)
    (pkg / "__init__.py").write_text(
        f'"""Private copy of the bodyvib {__version__} run-time package for {owner}."""\n'
        f'__version__ = "{__version__}"\n',
        encoding="utf-8",
    )
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
        (r"^KIND = .*$", f"KIND = {kind!r}"),
        (r"^DESCRIPTION = .*$", f"DESCRIPTION = {description!r}"),
        (r"^class BodyvibSlave\(Fmi2Slave\):.*$", f"class {name}(Fmi2Slave):"),
    ):
        text, count = re.subn(pattern, line.replace("\\", "\\\\"), text, count=1, flags=re.M)
        if count != 1:
            raise BodyvibError(f"{script}: no line matching {pattern!r} to render")
    return text


def build_fmu(
    network: Network,
    kind: str,
    name: str,
    description: str,
    dest: Union[str, os.PathLike] = "dist",
) -> Path:
    """Build one pythonfmu FMU of a model.

    The FMU carries a copy of :mod:`bodyvib.runtime` (:func:`write_runtime_package`), under
    a name of its own, and the model's parameter file; its slave steps the model with
    :class:`bodyvib.runtime.engine.FmuCore` in the host's Python.

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
        The FMU written, ``dest/<name>.fmu``: FMI 2.0 co-simulation, the slave in Python.

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

    core = FmuCore(kind, network, name)  # refuses a model the FMU could not run
    core.check_parameters()
    return _build(
        core,
        kind,
        name,
        description,
        model_resources(network),
        describe_fmu(description, network),
        dest,
    )


def build_source_fmu(
    meta: dict,
    table: "HermiteTable",
    name: str,
    description: str,
    dest: Union[str, os.PathLike] = "dist",
) -> Path:
    """Build one pythonfmu FMU of the ``source`` kind: a tabulated signal and its rate.

    Parameters
    ----------
    meta : dict
        The source description (:mod:`bodyvib.runtime.tabulated`), without
        ``table`` and ``periodic``.
    table : bodyvib.runtime.tabulated.HermiteTable
        The profiles and their slopes over the coordinate.
    name, description, dest
        As :func:`build_fmu`.

    Returns
    -------
    Path
        The FMU written, ``dest/<name>.fmu``, a source FMU (no inputs).

    Raises
    ------
    BodyvibError
        As :func:`build_fmu`; a source the contract refuses (signals not matching the
        table, a bad speed).
    """
    from ..runtime.tabulated import SourceCore

    core = SourceCore(meta, table, name)
    core.check_parameters()
    return _build(
        core,
        "source",
        name,
        description,
        source_resources(meta, table),
        describe_fmu(description, source=meta),
        dest,
    )


def _build(
    core: Union["FmuCore", "SourceCore"],
    kind: str,
    name: str,
    description: str,
    resources: Dict[str, bytes],
    described: str,
    dest: Union[str, os.PathLike],
) -> Path:
    """Package a slave over ``core`` with pythonfmu, write and validate its model description
    (``described``: its description attribute, :func:`describe_fmu`)."""
    sources = runtime_sources()
    template = render_slave_script(name, kind, description, "bodyvib.runtime")
    digest = _content_hash(
        [template.encode()] + [resources[k] for k in sorted(resources)] + list(sources.values())
    )
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
        cmd = [
            sys.executable,
            "-m",
            "pythonfmu",
            "build",
            "-f",
            str(stage / f"{module}.py"),
            "-d",
            str(out),
            "--no-external-tool",
            "--handle-state",
            "--serialize-state",
            str(pkg),
        ] + [str(stage / fname) for fname in resources]
        # a signal kills its process group; its temporary files stay in the build's folder
        proc = interrupts.run_process(cmd, cwd=tmp, scratch=Path(tmp) / "pythonfmu-tmp")
        built = out / f"{name}.fmu"
        if proc.returncode != 0 or not built.is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
            raise BodyvibError(
                f"pythonfmu could not build {name}.fmu (is pythonfmu installed? "
                f"pip install pythonfmu): {' | '.join(tail)}"
            )
        data = _finish(built, core, described)
        checked = Path(tmp) / f"{name}.fmu"  # validated before it may replace a good FMU
        checked.write_bytes(data)
        target = dest / f"{name}.fmu"
        validate_fmu_file(checked, str(target))
    atomic_write_bytes(target, data)
    return target


def _declared(element: ET.Element, name: str) -> str:
    """An attribute that pythonfmu 0.7 always writes into its modelDescription.xml.

    Raises
    ------
    BodyvibError
        The attribute is missing: a pythonfmu this module was not written for.
    """
    value = element.get(name)
    if value is None:
        raise BodyvibError(
            f"pythonfmu's modelDescription.xml has no attribute {name!r} where pythonfmu 0.7 "
            "writes one; use pythonfmu 0.7.x (pip install 'pythonfmu>=0.7,<0.8')"
        )
    return value


def pythonfmu_description(
    generated: bytes, core: Union["FmuCore", "SourceCore"], description: str
) -> ModelDescription:
    """What a pythonfmu FMU's modelDescription.xml declares: the core's interface, and from
    the XML pythonfmu generated only what pythonfmu decides.

    pythonfmu decides the GUID, the model identifier, the co-simulation capability flags,
    the log categories its slave accepts, and the value references (checked here to be the
    core's). Its C wrapper reads only ``resources/slavemodule.txt`` at run time, never the
    XML, so the rest is written from the core (units, limits, display units, the default
    experiment, the dependencies pythonfmu 0.7.0 does not write).

    Parameters
    ----------
    generated : bytes
        The modelDescription.xml pythonfmu wrote.
    core : bodyvib.runtime.engine.FmuCore or bodyvib.runtime.tabulated.SourceCore
        The core the slave runs.
    description : str
        The FMU's description.

    Returns
    -------
    bodyvib.fmu.description.ModelDescription
        FMI 2.0, co-simulation only.

    Raises
    ------
    BodyvibError
        pythonfmu assigned value references other than the core's.
    """
    root = ET.fromstring(generated)
    cs = root.find("CoSimulation")
    if cs is None:
        raise BodyvibError(
            "pythonfmu's modelDescription.xml has no CoSimulation element where pythonfmu 0.7 "
            "writes one; use pythonfmu 0.7.x (pip install 'pythonfmu>=0.7,<0.8')"
        )
    assigned = {
        _declared(sv, "name"): int(_declared(sv, "valueReference"))
        for sv in root.iter("ScalarVariable")
    }
    wanted = {v.name: vr for vr, v in enumerate(core.variables)}
    if assigned != wanted:
        moved = sorted(set(assigned.items()) ^ set(wanted.items()))
        raise BodyvibError(
            f"{root.get('modelName')}.fmu: pythonfmu assigned value references "
            f"other than the core's order ({moved[:4]}): the slave's "
            "register_variable order changed; use pythonfmu 0.7.0 (pip install "
            "pythonfmu==0.7.0) or register the variables in core order"
        )
    per_output = dict(zip((v.name for v in core.interface.outputs), core.output_dependencies()))
    return ModelDescription(
        fmi=2,
        model_name=_declared(root, "modelName"),
        model_identifier=_declared(cs, "modelIdentifier"),
        token=_declared(root, "guid"),
        description=description,
        generation_tool=f"bodyvib {__version__} with {root.get('generationTool')}",
        variables=tuple(core.variables),
        output_dependencies=tuple(
            tuple(per_output[v.name]) for v in core.variables if v.causality == "output"
        ),
        interfaces=(
            InterfaceElement(
                "CoSimulation",
                tuple((k, v) for k, v in cs.attrib.items() if k != "modelIdentifier"),
            ),
        ),
        log_categories=tuple(
            (_declared(c, "name"), _declared(c, "description"))
            for c in root.iterfind("LogCategories/Category")
        ),
        stop_time=default_stop_time(core),
        source=core.kind == "source",
    )


def _finish(fmu: Path, core: Union["FmuCore", "SourceCore"], description: str) -> bytes:
    """The FMU's bytes with its modelDescription.xml written by the one writer."""
    with zipfile.ZipFile(fmu) as zf:
        entries = [(info, zf.read(info)) for info in zf.infolist()]
    if not any(info.filename.startswith("binaries/") for info, _ in entries):
        raise BodyvibError(
            f"{fmu.name}: pythonfmu packaged no binaries (pythonfmu without "
            "its resources/binaries?); reinstall pythonfmu"
        )
    generated = next(data for info, data in entries if info.filename == "modelDescription.xml")
    xml = write_model_description(pythonfmu_description(generated, core, description))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for info, data in entries:
            if info.filename == "modelDescription.xml":
                data = xml
            zf.writestr(info.filename, data, compress_type=zipfile.ZIP_DEFLATED)
    return buf.getvalue()
