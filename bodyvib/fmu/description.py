"""The modelDescription.xml facts both FMU kinds share (pythonfmu and native C).

:mod:`bodyvib.fmu.pythonfmu` (pythonfmu, post-processed) and :mod:`bodyvib.fmu.native`
(native, written whole) take these from here, so both kinds declare the same interface:

* units and the display units engineers read them in (:data:`DISPLAY_UNITS`,
  :func:`display_unit`): displacements in mm, velocities in mm/s, the vehicle speed in
  km/h; accelerations stay in m/s2 (ISO 2631-1 states comfort in m/s2) with ``g`` on offer;
* the initial unknowns' dependencies (:func:`initial_dependencies`): an output with direct
  feedthrough depends on those inputs (and on the parameters that scale them), any other
  starts from the zero state and depends on nothing, so a host that checks initialization
  sees no algebraic loop between car and body;
* the default experiment (:func:`default_stop_time`): a source FMU's table duration at its
  default speed, 10 s for a model FMU.
"""

from typing import List, Optional, Sequence
from xml.etree import ElementTree as ET

from ..runtime.contract import UNITS

__all__ = ["DISPLAY_UNITS", "MODEL_STOP_TIME", "default_stop_time", "display_unit",
           "initial_dependencies", "unit_definitions"]

#: Unit -> (display unit, factor) pairs: a value in the unit is factor times the value in the
#: display unit (FMI: ``unit = factor * displayUnit + offset``).
DISPLAY_UNITS = {
    "m": (("mm", 0.001),),
    "m/s": (("mm/s", 0.001), ("km/h", 1 / 3.6)),
    "m/s2": (("g", 9.80665),),
}

#: DefaultExperiment stop time of a model (body, car) FMU, s.
MODEL_STOP_TIME = 10.0


def display_unit(variable) -> Optional[str]:
    """The display unit of a variable: mm, mm/s, km/h (a parameter in m/s: a speed) or None.

    Parameters
    ----------
    variable : bodyvib.runtime.contract.Variable

    Returns
    -------
    str or None

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


def initial_dependencies(output_inputs: Sequence[Sequence[int]], parameters: Sequence[int],
                         source: bool = False) -> List[List[int]]:
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
    return [sorted(set(deps) | set(parameters)) if (deps or source) else []
            for deps in output_inputs]


def default_stop_time(core) -> float:
    """DefaultExperiment stop time: a source's table duration at its speed, else 10 s.

    Parameters
    ----------
    core : bodyvib.runtime.engine.FmuCore or bodyvib.runtime.source.SourceCore

    Returns
    -------
    float
        s.
    """
    table = getattr(core, "table", None)
    if table is None:
        return MODEL_STOP_TIME
    return float(table.length) / float(core.parameters[0].start)
