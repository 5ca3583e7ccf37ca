"""Build ``SkyhookController.fmu``: the skyhook/groundhook law as a native FMI 2.0 FMU.

A stateless co-simulation FMU in C (``fmu_src/native/bodyvib_skyhook.c``, no Python on
the host): per actuator it reads the absolute vertical velocities (and accelerations) of
the actuator's upper and lower points and gives the force

    actuator_force = -c_sky * vu + c_ground * vl                               [N]

(positive pushing the points apart) and its rate ``actuator_force_rate`` (the same law
on the accelerations), set to 0 by the ``semi_active`` parameter where a passive damper
could not give it. ``vu`` and ``vl`` are the velocity inputs extrapolated with the
acceleration inputs over the last communication step ``h``: a Jacobi host (libcosim, fmpy's
SSP runner) hands the controller the car's velocities of the previous communication
point, and the extrapolation turns the force it reads into the one of the current point
(to second order in ``h``); a host that sets the current velocities leaves the
accelerations at 0. The outputs are feedthrough, computed on read. Variable names
follow the car FMU's actuators: for the suffix ``_front`` the inputs are
``upper_velocity_front``, ``lower_velocity_front``, ``upper_acceleration_front``,
``lower_acceleration_front`` (from the car's ``actuator_upper_velocity_front`` ...) and
the outputs ``actuator_force_front`` and ``actuator_force_rate_front`` (to the car's
inputs of the same names).

The FMU ships ``sources/`` (the C file and its generated configuration header) and
``binaries/linux64`` (and ``win64`` when mingw-w64 is installed), and is checked with
``fmpy validate`` before it is written.
"""

import hashlib
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterable, List, Optional, Sequence, Tuple
from xml.etree import ElementTree as ET

from .. import __version__
from ..process import interrupts
from ..process.outputs import atomic_write_bytes
from ..runtime.errors import BodyvibError
from .contents import native_dir
from .description import validate_fmu_file
from .native import COMMON_FLAGS, PLATFORMS, _zip, choose_platforms, fmi_headers

__all__ = ["CONTROLLER_NAME", "CONTROLLER_SOURCE", "controller_variables", "build_controller_fmu"]

#: Model name and identifier of the controller FMU.
CONTROLLER_NAME = "SkyhookController"
#: Its C source in ``fmu_src/native``.
CONTROLLER_SOURCE = "bodyvib_skyhook.c"
_CONFIG = "bodyvib_skyhook_config.h"


def controller_variables(suffixes: Sequence[str]) -> List[Tuple[str, str, str]]:
    """The controller FMU's Real variables by value reference: (name, causality, unit).

    Parameters
    ----------
    suffixes : sequence of str
        The car's actuator suffixes (``""`` for one unnamed actuator, ``"_front"``, ...).

    Returns
    -------
    list of (str, str, str)
        Inputs (two per actuator), outputs (one per actuator), then ``c_sky`` and
        ``c_ground``.

    Examples
    --------
    >>> [v[0] for v in controller_variables([""])][:6]
    ['upper_velocity', 'lower_velocity', 'upper_acceleration', 'lower_acceleration', 'actuator_force', 'actuator_force_rate']
    """
    out = []
    for s in suffixes:
        out += [(f"upper_velocity{s}", "input", "m/s"), (f"lower_velocity{s}", "input", "m/s")]
        out += [(f"upper_acceleration{s}", "input", "m/s2")]
        out += [(f"lower_acceleration{s}", "input", "m/s2")]
    out += [(f"actuator_force{s}", "output", "N") for s in suffixes]
    out += [(f"actuator_force_rate{s}", "output", "N/s") for s in suffixes]
    return out + [("c_sky", "parameter", "N.s/m"), ("c_ground", "parameter", "N.s/m")]


def _description(
    suffixes: Sequence[str], c_sky: float, c_ground: float, semi: bool, token: str
) -> bytes:
    root = ET.Element(
        "fmiModelDescription",
        fmiVersion="2.0",
        modelName=CONTROLLER_NAME,
        guid=token,
        description="Skyhook/groundhook actuator force law (stateless feedthrough): "
        "actuator_force = -c_sky upper_velocity + c_ground lower_velocity",
        generationTool=f"bodyvib {__version__}",
        variableNamingConvention="structured",
        numberOfEventIndicators="0",
    )
    ET.SubElement(
        root,
        "CoSimulation",
        modelIdentifier=CONTROLLER_NAME,
        needsExecutionTool="false",
        canHandleVariableCommunicationStepSize="true",
        canInterpolateInputs="false",
        maxOutputDerivativeOrder="0",
        canBeInstantiatedOnlyOncePerProcess="false",
        canNotUseMemoryManagementFunctions="true",
        canGetAndSetFMUstate="false",
        canSerializeFMUstate="false",
        providesDirectionalDerivative="false",
    ).append(_files())
    units = ET.SubElement(root, "UnitDefinitions")
    for unit, exps in (
        ("m/s", {"m": "1", "s": "-1"}),
        ("m/s2", {"m": "1", "s": "-2"}),
        ("N", {"kg": "1", "m": "1", "s": "-2"}),
        ("N/s", {"kg": "1", "m": "1", "s": "-3"}),
        ("N.s/m", {"kg": "1", "s": "-1"}),
    ):
        ET.SubElement(ET.SubElement(units, "Unit", name=unit), "BaseUnit", exps)
    ET.SubElement(root, "DefaultExperiment", startTime="0", stopTime="10", stepSize="0.001")
    mv = ET.SubElement(root, "ModelVariables")
    starts = {"c_sky": c_sky, "c_ground": c_ground}
    variables = controller_variables(suffixes)
    text = {
        "input": "Absolute vertical {} of the actuator's {} point",
        "output": "Actuator force, positive pushing the two points apart",
        "rate": "Time derivative of the actuator force (the law on the accelerations)",
    }
    for vr, (name, causality, unit) in enumerate(variables):
        attrs = {"name": name, "valueReference": str(vr), "causality": causality}
        real = {"unit": unit}
        if causality == "parameter":
            attrs.update(variability="fixed", initial="exact")
            attrs["description"] = f"{'Skyhook' if name == 'c_sky' else 'Groundhook'} gain"
            real.update(start=repr(float(starts[name])), min="0")
        elif causality == "input":
            attrs.update(variability="continuous")
            which, quantity = name.split("_")[:2]
            attrs["description"] = text["input"].format(quantity, which)
            real["start"] = "0.0"
        else:
            attrs.update(variability="continuous", initial="calculated")
            attrs["description"] = text["rate" if "_rate" in name else "output"]
        ET.SubElement(ET.SubElement(mv, "ScalarVariable", attrs), "Real", real)
    sv = ET.SubElement(
        mv,
        "ScalarVariable",
        name="semi_active",
        valueReference="0",
        causality="parameter",
        variability="fixed",
        initial="exact",
        description="Semi-active (on-off) clipping: 0 where a passive damper cannot give the force",
    )
    ET.SubElement(sv, "Boolean", start="true" if semi else "false")
    structure = ET.SubElement(root, "ModelStructure")
    outputs = ET.SubElement(structure, "Outputs")
    n = len(suffixes)
    # (1-based index over ModelVariables, the inputs it depends on): the force on its
    # actuator's four inputs, the rate on its two accelerations
    unknowns = [(4 * n + i + 1, range(4 * i + 1, 4 * i + 5)) for i in range(n)]
    unknowns += [(5 * n + i + 1, range(4 * i + 3, 4 * i + 5)) for i in range(n)]
    for index, deps in unknowns:
        ET.SubElement(
            outputs,
            "Unknown",
            index=str(index),
            dependencies=" ".join(str(d) for d in deps),
            dependenciesKind=" ".join("constant" for _ in deps),
        )
    init = ET.SubElement(structure, "InitialUnknowns")
    for index, _ in unknowns:
        ET.SubElement(init, "Unknown", index=str(index), dependencies="")
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def _files() -> ET.Element:
    files = ET.Element("SourceFiles")
    ET.SubElement(files, "File", name=CONTROLLER_SOURCE)
    return files


def _config(suffixes: Sequence[str], c_sky: float, c_ground: float, semi: bool, token: str) -> str:
    return "\n".join(
        [
            f"/* Generated by bodyvib {__version__} (bodyvib.fmu.controller): do not edit. */",
            f"#define BV_ACTUATORS {len(suffixes)}",
            f'#define BV_TOKEN "{token}"',
            f"#define BV_C_SKY {float(c_sky)!r}",
            f"#define BV_C_GROUND {float(c_ground)!r}",
            f"#define BV_SEMI_ACTIVE {1 if semi else 0}",
            "",
        ]
    )


def build_controller_fmu(
    dest: "str | os.PathLike[str]",
    suffixes: Sequence[str] = ("",),
    c_sky: float = 0.0,
    c_ground: float = 0.0,
    semi_active: bool = False,
    platforms: Optional[Iterable[str]] = None,
) -> Path:
    """Build ``SkyhookController.fmu`` (FMI 2.0 co-simulation, native C).

    Parameters
    ----------
    dest : str or path
        Output folder.
    suffixes : sequence of str
        One per actuator of the car it drives: ``("",)`` for the quarter car,
        ``("_front", "_rear")`` for the half car.
    c_sky, c_ground : float
        Start values of the gains, N s/m (parameters of the FMU, tunable before
        initialization).
    semi_active : bool
        Start value of the ``semi_active`` parameter.
    platforms : iterable of str, optional
        Keys of :data:`bodyvib.fmu.native.PLATFORMS` (default: every one with a compiler).

    Returns
    -------
    Path
        ``dest/SkyhookController.fmu``.

    Raises
    ------
    BodyvibError
        A gain that is not a finite number >= 0, no actuator, a missing compiler, a
        compiler error, or fmpy validate finding a problem.
    """
    for name, value in (("c_sky", c_sky), ("c_ground", c_ground)):
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise BodyvibError(f"controller gain {name} = {value!r} must be a finite number >= 0")
    suffixes = tuple(suffixes)
    if not suffixes or len(set(suffixes)) != len(suffixes):
        raise BodyvibError("the controller FMU needs one distinct suffix per actuator")
    chosen = choose_platforms(platforms).platforms
    source = (native_dir() / CONTROLLER_SOURCE).read_text(encoding="utf-8")
    digest = hashlib.sha256(
        (source + repr((suffixes, float(c_sky), float(c_ground), bool(semi_active)))).encode()
    ).hexdigest()
    token = (
        "{" + f"{digest[:8]}-{digest[8:12]}-{digest[12:16]}-{digest[16:20]}-{digest[20:32]}" + "}"
    )
    target = Path(dest) / f"{CONTROLLER_NAME}.fmu"
    with tempfile.TemporaryDirectory(prefix="bodyvib-controller-") as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        shutil.copy(native_dir() / CONTROLLER_SOURCE, src / CONTROLLER_SOURCE)
        (src / _CONFIG).write_text(
            _config(suffixes, c_sky, c_ground, semi_active, token), encoding="utf-8"
        )
        (root / "modelDescription.xml").write_bytes(
            _description(suffixes, c_sky, c_ground, semi_active, token)
        )
        for platform in chosen:
            compiler, flags, ext, folder2, _ = PLATFORMS[platform]
            out = root / "binaries" / folder2 / f"{CONTROLLER_NAME}{ext}"
            out.parent.mkdir(parents=True)
            cmd = [compiler, *COMMON_FLAGS, *flags, f"-I{src}", f"-I{fmi_headers()}"]
            cmd += ["-o", str(out), str(src / CONTROLLER_SOURCE), "-lm"]
            proc = interrupts.run_process(cmd, scratch=Path(tmp) / "compiler-tmp")
            if proc.returncode != 0 or not out.is_file() or proc.stderr.strip():
                raise BodyvibError(
                    f"{compiler} failed or warned for {out.name} ({platform}): "
                    + " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-4:])
                )
        staged = Path(tmp) / f"{CONTROLLER_NAME}.fmu"
        staged.write_bytes(_zip(root))
        validate_fmu_file(staged, f"{CONTROLLER_NAME}.fmu")
        os.makedirs(dest, exist_ok=True)
        atomic_write_bytes(target, staged.read_bytes())
    return target
