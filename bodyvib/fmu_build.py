"""Build the FMUs (``python build_fmu.py``, ``bodyvib build``).

Writes ``HumanBody3DOF.fmu`` (the paper's reduced model, or any parameter file
given with ``--params``), ``HumanBodyISO7962.fmu`` and ``QuarterCar.fmu`` with
pythonfmu, then finishes each ``modelDescription.xml`` (units, min/max,
ModelStructure with Outputs and InitialUnknowns) so that ``fmpy validate``
reports no problem, and checks that it does.

Private module names. A module name loaded inside an FMU is global to the host
process and the first loaded copy wins, so each FMU ships:

* ``resources/bodyvib_rt_<fmu>_<hash>/``: a copy of the numpy-only run-time
  modules (:data:`RUNTIME_MODULES`, relative imports only);
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
import re
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from typing import Dict, Iterable, Optional
from xml.etree import ElementTree as ET

from . import __version__
from .errors import BodyvibError
from .fileio import atomic_write_bytes
from .fmu_core import MODEL_FILE

__all__ = ["FMUS", "RUNTIME_MODULES", "UNITS", "build_fmu", "build_fmus", "render_slave_script",
           "write_runtime_package",
           "add_command", "main"]

#: FMU name -> (kind, default model, description).
FMUS = {
    "HumanBody3DOF": ("body", "reduced-paper",
                      "Reduced 3-DOF seated human body (Balci & Gundogdu 2025): seat motion in, "
                      "head acceleration and seat force out; exact discretization"),
    "HumanBodyISO7962": ("body", "iso7962",
                         "ISO 7962 four-mass seated human body (reconstructed topology): seat motion "
                         "in, head acceleration and seat force out; exact discretization"),
    "QuarterCar": ("car", "quarter-car",
                   "Quarter car (sprung mass, suspension, unsprung mass, tire): road and seat force "
                   "in, seat motion, suspension deflection and tire force out; exact discretization"),
}

#: The one slave script, rendered per FMU.
SLAVE_SCRIPT = "bodyvib_fmu_slave.py"

#: The numpy-only modules an FMU needs at run time (relative imports only).
RUNTIME_MODULES = ("errors.py", "fileio.py", "network.py", "models.py", "discretize.py", "fmu_core.py",
                   "fmu_teardown.py")

#: SI units used by the FMUs, as exponents of the FMI base units.
UNITS = {
    "m": {"m": 1}, "m/s": {"m": 1, "s": -1}, "m/s2": {"m": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2}, "N/s": {"kg": 1, "m": 1, "s": -3},
    "kg": {"kg": 1}, "N/m": {"kg": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1},
}

PACKAGE_DIR = Path(__file__).resolve().parent
SOURCE_DIR = PACKAGE_DIR.parent / "fmu_src"


def _load_network(kind: str, model: str):
    if kind == "car":
        from vehicle.quarter_car import load_car  # build time only

        return load_car(model)
    from .models import load_model

    return load_model(model)


def _content_hash(parts: Iterable[bytes]) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(hashlib.sha256(p).digest())
    return h.hexdigest()[:10]


def write_runtime_package(folder, package: str, owner: str = "an FMU") -> Path:
    """Copy the numpy-only run-time modules into ``folder/package/``.

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
    for m in RUNTIME_MODULES:
        (pkg / m).write_bytes((PACKAGE_DIR / m).read_bytes())
    (pkg / "__init__.py").write_text(
        f'"""Private copy of the bodyvib {__version__} run-time modules for {owner}."""\n'
        f'__version__ = "{__version__}"\n', encoding="utf-8")
    return pkg


def render_slave_script(name: str, runtime_package: str) -> str:
    """The slave script of one FMU: ``fmu_src/bodyvib_fmu_slave.py`` rendered.

    Parameters
    ----------
    name : str
        FMU model name (a key of :data:`FMUS`); becomes the slave class name.
    runtime_package : str
        Package the script imports the run-time modules from (the FMU's
        private copy; ``"bodyvib"`` to run the script against the library).

    Returns
    -------
    str
        Python source.

    Raises
    ------
    BodyvibError
        Unknown FMU, or ``fmu_src/`` missing (building needs a source checkout).
    """
    if name not in FMUS:
        raise BodyvibError(f"unknown FMU '{name}'; FMUs are {', '.join(FMUS)}")
    kind, _, description = FMUS[name]
    script = SOURCE_DIR / SLAVE_SCRIPT
    if not script.is_file():
        raise BodyvibError(
            f"slave script {script} not found: build the FMUs from a source checkout "
            "(git clone, then pip install -e .)"
        )
    text = script.read_text(encoding="utf-8")
    for pattern, line in (
        (r'^RUNTIME = "bodyvib".*$', f"RUNTIME = {runtime_package!r}"),
        (r'^KIND = .*$', f"KIND = {kind!r}"),
        (r'^DESCRIPTION = .*$', f"DESCRIPTION = {description!r}"),
        (r'^class BodyvibSlave\(Fmi2Slave\):.*$', f"class {name}(Fmi2Slave):"),
    ):
        text, count = re.subn(pattern, line.replace("\\", "\\\\"), text, count=1, flags=re.M)
        if count != 1:
            raise BodyvibError(f"{script}: no line matching {pattern!r} to render")
    return text


def build_fmu(name: str, dest="dist", model: Optional[str] = None) -> Path:
    """Build one FMU.

    Parameters
    ----------
    name : str
        ``"HumanBody3DOF"``, ``"HumanBodyISO7962"`` or ``"QuarterCar"``.
    dest : str or path
        Output folder (created if missing).
    model : str, optional
        Shipped model name or parameter-file path to bake in (the FMU's
        default model if None).

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        Unknown FMU, invalid parameter file, missing ``fmu_src/``, or an FMU
        that ``fmpy validate`` finds problems in.
    """
    if name not in FMUS:
        raise BodyvibError(f"unknown FMU '{name}'; FMUs are {', '.join(FMUS)}")
    kind, default_model, _ = FMUS[name]
    from .fmu_core import FmuCore
    from .models import network_to_dict

    network = _load_network(kind, model or default_model)
    core = FmuCore(kind, network, name)  # refuses a model the FMU could not run
    core.check_parameters()

    sources = {m: (PACKAGE_DIR / m).read_bytes() for m in RUNTIME_MODULES}
    model_bytes = (json.dumps(network_to_dict(network), indent=2) + "\n").encode()
    template = render_slave_script(name, "bodyvib")
    digest = _content_hash([template.encode(), model_bytes] + [sources[m] for m in RUNTIME_MODULES])
    package = f"bodyvib_rt_{name.lower()}_{digest}"
    module = f"bodyvib_fmu_{name.lower()}_{digest}"
    script_text = render_slave_script(name, package)

    dest = Path(dest)
    with tempfile.TemporaryDirectory(prefix="bodyvib_build_") as tmp:
        stage = Path(tmp) / "stage"
        pkg = write_runtime_package(stage, package, f"{name}.fmu")
        (stage / f"{module}.py").write_text(script_text, encoding="utf-8")
        (stage / MODEL_FILE).write_bytes(model_bytes)
        out = Path(tmp) / "out"
        # pythonfmu runs in a fresh process: in a process that has run a pythonfmu FMU,
        # 'pythonfmu' may be the FMU's embedded copy, which has no binaries to package.
        cmd = [sys.executable, "-m", "pythonfmu", "build", "-f", str(stage / f"{module}.py"),
               "-d", str(out), "--no-external-tool", "--handle-state", "--serialize-state",
               str(pkg), str(stage / MODEL_FILE)]
        proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True)
        built = out / f"{name}.fmu"
        if proc.returncode != 0 or not built.is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
            raise BodyvibError(f"pythonfmu could not build {name}.fmu (is pythonfmu installed? "
                               f"pip install pythonfmu): {' | '.join(tail)}")
        data = _finish(built, core, network)
    target = dest / f"{name}.fmu"
    atomic_write_bytes(target, data)
    problems = _validate(target)
    if problems:
        raise BodyvibError(f"{target}: fmpy validate found problems: " + "; ".join(problems))
    return target


def _num(x: float) -> str:
    return repr(float(x))


def _finish(fmu: Path, core, network) -> bytes:
    """The FMU's bytes with its modelDescription.xml completed."""
    with zipfile.ZipFile(fmu) as zf:
        entries = [(info, zf.read(info)) for info in zf.infolist()]
    md = next(data for info, data in entries if info.filename == "modelDescription.xml")
    if not any(info.filename.startswith("binaries/") for info, _ in entries):
        raise BodyvibError(f"{fmu.name}: pythonfmu packaged no binaries (pythonfmu without "
                           "its resources/binaries?); reinstall pythonfmu")
    root = ET.fromstring(md)
    root.set("description", f"{root.get('description', '')}. Model '{network.name}': "
             f"{network.description}".strip())
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
        if v.unit not in used:
            used.append(v.unit)

    units = ET.Element("UnitDefinitions")
    for u in used:
        unit = ET.SubElement(units, "Unit", name=u)
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
    children = list(root)
    root.insert(children.index(root.find("CoSimulation")) + 1, units)

    structure = root.find("ModelStructure")
    for child in list(structure):
        structure.remove(child)
    index = {sv.get("name"): i + 1 for i, sv in enumerate(svs)}
    deps = core.output_dependencies()
    outputs = ET.SubElement(structure, "Outputs")
    initial = ET.SubElement(structure, "InitialUnknowns")
    for j, v in enumerate(core.interface.outputs):
        ET.SubElement(outputs, "Unknown", index=str(index[v.name]),
                      dependencies=" ".join(str(index[core.variables[i].name]) for i in deps[j]))
        # at initialization an output depends on inputs and parameters: all knowns
        ET.SubElement(initial, "Unknown", index=str(index[v.name]))

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


def build_fmus(dest="dist", params: Optional[str] = None, names: Optional[Iterable[str]] = None,
               echo=None) -> Dict[str, Path]:
    """Build the FMUs.

    Parameters
    ----------
    dest : str or path
        Output folder (``dist`` by default).
    params : str, optional
        Parameter file (or shipped model name) baked into ``HumanBody3DOF.fmu``;
        the paper's Table 2 (``reduced-paper``) by default.
    names : iterable of str, optional
        Which FMUs (all by default).
    echo : callable, optional
        Called with one line per FMU written.

    Returns
    -------
    dict of str to Path

    Raises
    ------
    BodyvibError
        See :func:`build_fmu`.

    Examples
    --------
    >>> paths = build_fmus("dist")  # doctest: +SKIP
    >>> sorted(paths)  # doctest: +SKIP
    ['HumanBody3DOF', 'HumanBodyISO7962', 'QuarterCar']
    """
    out = {}
    for name in names or FMUS:
        model = params if (name == "HumanBody3DOF" and params) else None
        out[name] = build_fmu(name, dest, model)
        if echo:
            echo(f"wrote {out[name]} (model {model or FMUS[name][1]}; fmpy validate: no problems)")
    return out


def _run(args) -> int:
    if getattr(args, "native", False):
        from .native_build import build_native_fmus

        build_native_fmus(Path(args.dest) / "native", args.params, args.fmus, echo=print)
        return 0
    build_fmus(args.dest, args.params, args.fmus, echo=print)
    return 0


def add_command(subparsers):
    """Register ``bodyvib build``."""
    p = subparsers.add_parser(
        "build", help="build the FMUs (HumanBody3DOF, HumanBodyISO7962, QuarterCar) into dist/",
        description="Build HumanBody3DOF.fmu, HumanBodyISO7962.fmu and QuarterCar.fmu with "
        "pythonfmu and check them with fmpy validate. --params bakes a parameter file into "
        "HumanBody3DOF.fmu (default: the paper's Table 2).",
    )
    p.add_argument("--params", metavar="FILE", help="parameter file for HumanBody3DOF.fmu "
                   "(default: reduced-paper, the paper's Table 2)")
    p.add_argument("--dest", default="dist", help="output folder (default: dist)")
    p.add_argument("--fmus", nargs="+", choices=list(FMUS), metavar="NAME",
                   help=f"build only these ({', '.join(FMUS)})")
    p.add_argument("--native", action="store_true",
                   help="build the native C FMUs instead (FMI 2.0 into DEST/native, FMI 3.0 "
                   "into DEST/native/fmi3; linux64 + win64 binaries and sources; no Python "
                   "needed by the host)")
    p.set_defaults(func=_run)
    return p


def main(argv=None) -> int:
    """``python build_fmu.py [options]``: the same as ``bodyvib build [options]``."""
    from .cli import main as cli_main

    return cli_main(["build"] + list(sys.argv[1:] if argv is None else argv))
