"""The one writer of modelDescription.xml, for both FMU kinds (pythonfmu and native C).

Every FMU's description is written here from one neutral, typed description,
:class:`ModelDescription` (:func:`write_model_description`): the native builder
(:mod:`bodyvib.fmu.native`) fills it from its ``NativeModel``, FMI 2.0 or 3.0, co-simulation
and Model Exchange with the continuous states; the pythonfmu builder
(:mod:`bodyvib.fmu.pythonfmu`) fills it from the slave's core and takes from pythonfmu's own
XML only what pythonfmu decides (GUID, model identifier, co-simulation flags, log categories,
and the value references it assigned, checked against the core's). The facts both kinds
share live here too:

* units and the display units engineers read them in (:data:`DISPLAY_UNITS`,
  :func:`display_unit`): displacements in mm, velocities in mm/s, the vehicle speed in
  km/h; accelerations stay in m/s2 (ISO 2631-1 states comfort in m/s2) with ``g`` on offer;
* the initial unknowns' dependencies (:func:`initial_dependencies`): an output with direct
  feedthrough depends on those inputs (and on the parameters that scale them), any other
  starts from the zero state and depends on nothing, so a host that checks initialization
  sees no algebraic loop between car and body;
* the default experiment (:func:`default_stop_time`): a source FMU's table duration at its
  default speed, 10 s for a model FMU;
* the check every FMU passes before it replaces a previous file (:func:`validate_fmu_file`:
  ``fmpy validate``).
"""

import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, List, Optional, Sequence, Tuple, Union
from xml.etree import ElementTree as ET

from .. import __version__
from ..runtime.contract import UNITS, Variable
from ..runtime.errors import BodyvibError

if TYPE_CHECKING:  # for annotations only: importing the cores costs a build nothing
    from ..runtime.engine import FmuCore
    from ..runtime.network import Network
    from ..runtime.tabulated import SourceCore

__all__ = [
    "DISPLAY_UNITS",
    "MODEL_STOP_TIME",
    "InterfaceElement",
    "ModelDescription",
    "default_stop_time",
    "describe_fmu",
    "display_unit",
    "initial_dependencies",
    "number",
    "state_units",
    "unit_definitions",
    "validate_fmu_file",
    "write_model_description",
]

#: Unit -> (display unit, factor) pairs: a value in the unit is factor times the value in the
#: display unit (FMI: ``unit = factor * displayUnit + offset``).
DISPLAY_UNITS = {
    "m": (("mm", 0.001),),
    "m/s": (("mm/s", 0.001), ("km/h", 1 / 3.6)),
    "m/s2": (("g", 9.80665),),
}

#: DefaultExperiment stop time of a model (body, car) FMU, s.
MODEL_STOP_TIME = 10.0


def display_unit(variable: Variable) -> Optional[str]:
    """The display unit of a variable: mm, mm/s, km/h (a parameter in m/s: a speed) or None.

    Parameters
    ----------
    variable : bodyvib.runtime.contract.Variable
        A contract variable (its unit and causality decide).

    Returns
    -------
    str or None
        None: the variable is shown in its own unit.

    Examples
    --------
    >>> from bodyvib.runtime.contract import Variable
    >>> display_unit(Variable("seat_displacement", "input", "continuous", "m", ""))
    'mm'
    """
    if variable.unit == "m":
        return "mm"
    if variable.unit == "m/s":
        return "km/h" if variable.causality == "parameter" else "mm/s"
    return None


def unit_definitions(units: Sequence[str]) -> ET.Element:
    """``<UnitDefinitions>`` of the units used, with their display units (FMI 2.0 and 3.0).

    Parameters
    ----------
    units : sequence of str
        Keys of :data:`bodyvib.runtime.contract.UNITS` (``"s"`` allowed), in order.

    Returns
    -------
    xml.etree.ElementTree.Element
    """
    root = ET.Element("UnitDefinitions")
    for u in units:
        unit = ET.SubElement(root, "Unit", name=u)
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS.get(u, {"s": 1}).items()})
        for name, factor in DISPLAY_UNITS.get(u, ()):
            ET.SubElement(unit, "DisplayUnit", name=name, factor=repr(float(factor)))
    return root


def initial_dependencies(
    output_inputs: Sequence[Sequence[int]], parameters: Sequence[int], source: bool = False
) -> List[List[int]]:
    """Dependencies of each output at initialization (the InitialUnknowns).

    Parameters
    ----------
    output_inputs : sequence of sequence of int
        Per output: the inputs it depends on directly (the Outputs' dependencies).
    parameters : sequence of int
        The parameters.
    source : bool
        A source FMU (no inputs): its outputs are the table at the start time, so they
        depend on the speed.

    Returns
    -------
    list of list of int
        Per output: its inputs and, if it has any (or for a source), the parameters;
        an output without feedthrough of a model FMU is ``C x`` at the zero state: none.
    """
    return [
        sorted(set(deps) | set(parameters)) if (deps or source) else [] for deps in output_inputs
    ]


def describe_fmu(
    line: str, network: Optional["Network"] = None, source: Optional[dict] = None
) -> str:
    """The ``description`` attribute of an FMU: its one-line description and its content's.

    Parameters
    ----------
    line : str
        The FMU's one-line description.
    network : bodyvib.runtime.network.Network, optional
        The model a model FMU bakes in.
    source : dict, optional
        The description of a source FMU's table (:mod:`bodyvib.runtime.tabulated`).

    Returns
    -------
    str

    Examples
    --------
    >>> describe_fmu("Road profile", source={"name": "C", "description": "ISO 8608 class C"})
    "Road profile. Source 'C': ISO 8608 class C"
    """
    if network is not None:
        return f"{line}. Model '{network.name}': {network.description}".strip()
    if source is not None:
        return f"{line}. Source '{source['name']}': {source['description']}"
    return line


def default_stop_time(core: Union["FmuCore", "SourceCore"]) -> float:
    """DefaultExperiment stop time: a source's table duration at its speed, else 10 s.

    Parameters
    ----------
    core : bodyvib.runtime.engine.FmuCore or bodyvib.runtime.tabulated.SourceCore
        The FMU's core: a source's has a ``table`` (its length in the coordinate, m) and
        the speed as its one parameter (m/s).

    Returns
    -------
    float
        s.
    """
    table = getattr(core, "table", None)
    speed = core.parameters[0].start if table is not None else None
    if table is None or speed is None:
        return MODEL_STOP_TIME
    return float(table.length) / float(speed)


def number(x: float) -> str:
    """A real as modelDescription.xml writes it: the shortest text that reads back exactly.

    Parameters
    ----------
    x : float
        The value (a start, min, max or time in the variable's unit).

    Returns
    -------
    str

    Examples
    --------
    >>> number(1e-6), number(20)
    ('1e-06', '20.0')
    """
    return repr(float(x))


#: Per state quantity (the last part of a state name): its unit and its derivative's.
_STATE_UNITS = {
    "x": ("m", "m/s"),
    "y": ("m", "m/s"),
    "v": ("m/s", "m/s2"),
    "theta": ("rad", "rad/s"),
    "omega": ("rad/s", "rad/s2"),
    "phi": ("rad", "rad/s"),
    "phi_rate": ("rad/s", "rad/s2"),
}
_STATE_WORDS = {
    "x": "displacement",
    "y": "displacement",
    "v": "velocity",
    "theta": "pitch angle",
    "omega": "pitch rate",
    "phi": "roll angle",
    "phi_rate": "roll rate",
}

#: The order FMI's schemas want the interface elements in.
_INTERFACE_ORDER = ("ModelExchange", "CoSimulation")


def state_units(state: str) -> Tuple[str, str]:
    """Units of a continuous state and of its time derivative.

    Parameters
    ----------
    state : str
        ``"<mass>.x"`` or ``"<node>.y"`` (a displacement), ``"<mass>.v"`` (a velocity).

    Returns
    -------
    (str, str)
        The state's unit and its derivative's.

    Examples
    --------
    >>> state_units("m1.v")
    ('m/s', 'm/s2')
    """
    return _STATE_UNITS[state.rpartition(".")[2]]


@dataclass(frozen=True)
class InterfaceElement:
    """One interface element of an FMU: what it offers a co-simulation or model-exchange host.

    Attributes
    ----------
    element : {"CoSimulation", "ModelExchange"}
        The element's tag.
    flags : tuple of (str, str)
        Its capability attributes besides ``modelIdentifier`` (name, XML value), in order.
    source_files : tuple of str
        FMI 2.0's ``SourceFiles`` (C files ``fmpy compile`` builds); empty: none listed.
    """

    element: str
    flags: Tuple[Tuple[str, str], ...]
    source_files: Tuple[str, ...] = ()


@dataclass(frozen=True)
class ModelDescription:
    """Everything a modelDescription.xml says, independent of the FMU kind that built it.

    The value reference of a contract variable is its position in ``variables``; after them
    come FMI 3.0's ``time``, then (model exchange) the states and their derivatives
    (:meth:`state_vr`, :meth:`derivative_vr`; ``BV_STATE_VR``/``BV_DER_VR`` of the native
    core).

    Attributes
    ----------
    fmi : int
        FMI version, 2 or 3.
    model_name : str
        The FMU's model name.
    model_identifier : str
        The binaries' name (the same for every interface element).
    token : str
        GUID (FMI 2.0) or instantiation token (FMI 3.0).
    description : str
        The FMU's description (its one-line description and the model's).
    generation_tool : str
        Who wrote the FMU.
    variables : tuple of bodyvib.runtime.contract.Variable
        The contract's variables, by value reference.
    output_dependencies : tuple of tuple of int
        Per output (in value-reference order): the input value references it depends on
        directly.
    interfaces : tuple of InterfaceElement
        The interface elements.
    log_categories : tuple of (str, str)
        Log category names and descriptions the FMU accepts.
    stop_time : float
        The DefaultExperiment's stop time, s.
    source : bool
        A source FMU (no inputs; its outputs depend on its parameters at initialization).
    states : tuple of str
        Model exchange: the continuous states (``"<mass>.x"`` ...), in the core's order.
    output_state_dependencies : tuple of tuple of int
        Per output: the states (indices) it depends on (empty: none for every output).
    derivative_dependencies : tuple of (tuple of int, tuple of int)
        Per state: the states (indices) and input value references its derivative
        depends on.
    step_size : float
        The DefaultExperiment's step size, s.
    booleans : tuple of (str, str, bool)
        FMI 2.0 Boolean parameters (name, description, start), value references 0, 1, ...
        of the Boolean type, after the real variables (the controller's ``semi_active``).
    event_indicators : tuple of str
        Model exchange: the switching functions of a nonlinear model (FMI 2.0:
        ``numberOfEventIndicators``; FMI 3.0: also local variables after the derivatives,
        :meth:`event_vr`, listed as ``EventIndicator`` in ``ModelStructure``).
    """

    fmi: int
    model_name: str
    model_identifier: str
    token: str
    description: str
    generation_tool: str
    variables: Tuple[Variable, ...]
    output_dependencies: Tuple[Tuple[int, ...], ...]
    interfaces: Tuple[InterfaceElement, ...]
    log_categories: Tuple[Tuple[str, str], ...]
    stop_time: float
    source: bool = False
    states: Tuple[str, ...] = ()
    output_state_dependencies: Tuple[Tuple[int, ...], ...] = ()
    derivative_dependencies: Tuple[Tuple[Tuple[int, ...], Tuple[int, ...]], ...] = ()
    step_size: float = 0.001
    booleans: Tuple[Tuple[str, str, bool], ...] = ()
    event_indicators: Tuple[str, ...] = ()

    @property
    def outputs(self) -> Tuple[int, ...]:
        """Value references of the outputs, in order."""
        return tuple(vr for vr, v in enumerate(self.variables) if v.causality == "output")

    @property
    def parameters(self) -> Tuple[int, ...]:
        """Value references of the parameters, in order."""
        return tuple(vr for vr, v in enumerate(self.variables) if v.causality == "parameter")

    def state_vr(self, i: int) -> int:
        """Value reference of state ``i`` (after the variables and FMI 3.0's time)."""
        return len(self.variables) + 1 + i

    def derivative_vr(self, i: int) -> int:
        """Value reference of the derivative of state ``i`` (after the states)."""
        return len(self.variables) + 1 + len(self.states) + i

    def event_vr(self, i: int) -> int:
        """Value reference of event indicator ``i`` (FMI 3.0, after the derivatives)."""
        return len(self.variables) + 1 + 2 * len(self.states) + i

    def reference(self, vr: int) -> str:
        """How ModelStructure names a variable: FMI 2.0 by index (position + 1, no time
        variable), FMI 3.0 by value reference."""
        if self.fmi == 3:
            return str(vr)
        return str(vr + 1 if vr < len(self.variables) else vr)


def _typed(v: Variable) -> dict:
    """The unit, display unit, start and limits of a contract variable."""
    typed = {"unit": v.unit}
    shown = display_unit(v)
    if shown:
        typed["displayUnit"] = shown
    if v.start is not None and v.causality != "output":
        typed["start"] = number(v.start)
    if v.min is not None:
        typed["min"] = number(v.min)
    if v.max is not None:
        typed["max"] = number(v.max)
    return typed


def _real(parent: ET.Element, fmi: int, attrs: dict, typed: dict) -> None:
    """One real variable: a ``ScalarVariable`` with its ``Real`` (2.0), a ``Float64`` (3.0)."""
    if fmi == 2:
        ET.SubElement(ET.SubElement(parent, "ScalarVariable", attrs), "Real", typed)
    else:
        ET.SubElement(parent, "Float64", dict(attrs, **typed))


def _variables(root: ET.Element, md: ModelDescription) -> None:
    """``ModelVariables``: the contract's, FMI 3.0's time, the states and their derivatives."""
    mv = ET.SubElement(root, "ModelVariables")
    for vr, v in enumerate(md.variables):
        attrs = {
            "name": v.name,
            "valueReference": str(vr),
            "description": v.description,
            "causality": v.causality,
            "variability": v.variability,
        }
        if v.causality == "output":
            attrs["initial"] = "calculated"
        _real(mv, md.fmi, attrs, _typed(v))
    if md.fmi == 3:  # the independent variable, after the contract's value references
        ET.SubElement(
            mv,
            "Float64",
            {
                "name": "time",
                "valueReference": str(len(md.variables)),
                "causality": "independent",
                "variability": "continuous",
                "unit": "s",
                "description": "Simulation time",
            },
        )
    for i, state in enumerate(md.states):
        point, _, q = state.rpartition(".")
        _real(
            mv,
            md.fmi,
            {
                "name": f"state.{state}",
                "valueReference": str(md.state_vr(i)),
                "description": f"Continuous state: {point} {_STATE_WORDS[q]} (model exchange)",
                "causality": "local",
                "variability": "continuous",
                "initial": "exact",
            },
            {"unit": state_units(state)[0], "start": "0.0"},
        )
    for i, state in enumerate(md.states):
        _real(
            mv,
            md.fmi,
            {
                "name": f"der(state.{state})",
                "valueReference": str(md.derivative_vr(i)),
                "description": f"Time derivative of state.{state}",
                "causality": "local",
                "variability": "continuous",
                "initial": "calculated",
            },
            {"unit": state_units(state)[1], "derivative": md.reference(md.state_vr(i))},
        )
    for i, name in enumerate(md.event_indicators if md.fmi == 3 else ()):
        _real(
            mv,
            md.fmi,
            {
                "name": f"event.{name}",
                "valueReference": str(md.event_vr(i)),
                "description": f"Event indicator: switching function of {name} (model exchange)",
                "causality": "local",
                "variability": "continuous",
                "initial": "calculated",
            },
            {"unit": "1"},
        )
    for vr, (name, text, start) in enumerate(md.booleans):  # FMI 2.0 (write_model_description)
        attrs = {"name": name, "valueReference": str(vr), "description": text}
        attrs.update(causality="parameter", variability="fixed", initial="exact")
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        ET.SubElement(sv, "Boolean", start="true" if start else "false")


def _structure(root: ET.Element, md: ModelDescription) -> None:
    """``ModelStructure``: outputs, state derivatives and initial unknowns with dependencies.

    FMI 2.0 refers to variables by index, FMI 3.0 by value reference; the states follow the
    contract's variables (and FMI 3.0's time), so both are monotonic.
    """
    ms = ET.SubElement(root, "ModelStructure")
    ders = [md.derivative_vr(i) for i in range(len(md.states))]
    state_deps = md.output_state_dependencies or tuple(() for _ in md.outputs)

    def text(inputs: Sequence[int], states: Sequence[int]) -> str:
        return " ".join(
            [md.reference(d) for d in inputs] + [md.reference(md.state_vr(j)) for j in states]
        )

    outputs = [
        (vr, text(d, sd)) for vr, d, sd in zip(md.outputs, md.output_dependencies, state_deps)
    ]
    derivatives = [(vr, text(d, sd)) for vr, (sd, d) in zip(ders, md.derivative_dependencies)]
    # at initialization: the feedthrough inputs and the parameters scaling them, and the
    # states' start values (exposed for model exchange)
    initial = initial_dependencies(
        list(md.output_dependencies) + [d for _, d in md.derivative_dependencies],
        md.parameters,
        md.source,
    )
    initial_rows = [
        (vr, text(i, sd))
        for vr, i, sd in zip(
            list(md.outputs) + ders,
            initial,
            list(state_deps) + [sd for sd, _ in md.derivative_dependencies],
        )
    ]
    if md.fmi == 2:
        for group, rows in (
            ("Outputs", outputs),
            ("Derivatives", derivatives),
            ("InitialUnknowns", sorted(initial_rows)),
        ):
            if rows or group != "Derivatives":
                element = ET.SubElement(ms, group)
                for vr, deps in rows:
                    ET.SubElement(element, "Unknown", index=md.reference(vr), dependencies=deps)
    else:
        for tag, rows in (
            ("Output", outputs),
            ("ContinuousStateDerivative", derivatives),
            ("InitialUnknown", initial_rows),
        ):
            for vr, deps in rows:
                ET.SubElement(ms, tag, valueReference=str(vr), dependencies=deps)
        for i in range(len(md.event_indicators)):
            ET.SubElement(ms, "EventIndicator", valueReference=str(md.event_vr(i)))


def write_model_description(md: ModelDescription) -> bytes:
    """The complete ``modelDescription.xml`` of an FMU, any kind, FMI 2.0 or 3.0.

    Parameters
    ----------
    md : ModelDescription
        What the FMU declares.

    Returns
    -------
    bytes
        UTF-8 XML.

    Raises
    ------
    BodyvibError
        An FMI version other than 2 or 3, or an interface element FMI does not have.
    """
    if md.fmi not in (2, 3):
        raise BodyvibError(f"FMI version must be 2 or 3, got {md.fmi!r}")
    if md.booleans and md.fmi != 2:
        raise BodyvibError(f"{md.model_name}: Boolean parameters are written for FMI 2.0 only")
    unknown = [i.element for i in md.interfaces if i.element not in _INTERFACE_ORDER]
    if unknown or not md.interfaces:
        raise BodyvibError(
            f"{md.model_name}: interface elements must be among "
            f"{', '.join(_INTERFACE_ORDER)}, got {unknown or 'none'}"
        )
    root = ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": f"{md.fmi}.0",
            "modelName": md.model_name,
            ("guid" if md.fmi == 2 else "instantiationToken"): md.token,
            "description": md.description,
            "author": "bodyvib",
            "version": __version__,
            "generationTool": md.generation_tool,
            "variableNamingConvention": "flat",
        },
    )
    interfaces = sorted(md.interfaces, key=lambda i: _INTERFACE_ORDER.index(i.element))
    if md.fmi == 2 and interfaces[0].element == "ModelExchange":
        root.set("numberOfEventIndicators", str(len(md.event_indicators)))
    for interface in interfaces:
        element = ET.SubElement(
            root,
            interface.element,
            dict((("modelIdentifier", md.model_identifier),) + interface.flags),
        )
        if interface.source_files:
            files = ET.SubElement(element, "SourceFiles")
            for s in interface.source_files:
                ET.SubElement(files, "File", name=s)
    used = [v.unit for v in md.variables] + [u for s in md.states for u in state_units(s)]
    used += ["1"] if md.event_indicators and md.fmi == 3 else []
    root.append(unit_definitions(list(dict.fromkeys((["s"] if md.fmi == 3 else []) + used))))
    if md.log_categories:
        cats = ET.SubElement(root, "LogCategories")
        for name, text in md.log_categories:
            ET.SubElement(cats, "Category", name=name, description=text)
    ET.SubElement(
        root,
        "DefaultExperiment",
        startTime="0.0",
        stopTime=number(md.stop_time),
        stepSize=number(md.step_size),
    )
    _variables(root, md)
    _structure(root, md)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def validate_fmu_file(path: Union[str, os.PathLike], label: str) -> None:
    """Check a built FMU with ``fmpy validate`` before it may replace a previous file.

    Parameters
    ----------
    path : str or path
        The staged FMU.
    label : str
        How the error names the FMU (its target path, or name and kind).

    Raises
    ------
    BodyvibError
        fmpy validate found problems (each named).
    """
    from fmpy.validation import validate_fmu

    problems = validate_fmu(str(Path(path)))
    if problems:
        raise BodyvibError(f"{label}: fmpy validate found problems: " + "; ".join(problems))
