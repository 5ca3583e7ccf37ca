"""The parameter-file format: a model as JSON, validated on load, written back.

A parameter file holds a :class:`~bodyvib.runtime.network.Network`:

.. code-block:: json

    {
      "name": "reduced-paper",
      "description": "...",
      "provenance": {"source": "..."},
      "base": "seat",
      "parameters": {"m1": 4.88, "k1": 61800.0, "c1": 333.0},
      "masses": {"m1": "m1"},
      "nodes": [],
      "elements": [{"name": "neck", "kind": "kelvin", "from": "seat", "to": "m1",
                    "k": "k1", "c": "c1"}],
      "roles": {"head": "m1"}
    }

``parameters`` are named values in SI units (kg, N/m, N s/m), all finite and
positive; ``masses`` and element fields refer to them by name (or give a
literal number). Optional fields: ``description``, ``provenance``, ``base``
(default ``seat``), ``nodes``, ``force_inputs``, ``roles``, ``units``
(parameter name -> unit string, kept when the model is written back) and
``fmu_outputs`` (extra outputs of an FMU built from the model: a list of
``{"name", "signal", "unit", "description"}``, ``signal`` an output of the
state space such as ``"seat.a"``, ``"tire.force"``; see
:mod:`bodyvib.runtime.contract`).

The shipped models and loading by name are :mod:`bodyvib.models`. Numpy-free
apart from what :mod:`bodyvib.runtime.network` needs; relative imports only:
the FMUs read their baked parameter file with this module.
"""

import math
import os
import re
from typing import Collection, Dict, Mapping, Tuple, Union

from .contract import PARAMETER_LIMITS, UNITS
from .errors import BodyvibError
from .jsonfile import read_json
from .network import ELEMENT_KINDS, Element, Network

__all__ = [
    "network_from_dict",
    "network_from_file",
    "network_to_dict",
]

_REQUIRED = ("name", "parameters", "masses", "elements")
_OPTIONAL = (
    "description",
    "provenance",
    "base",
    "nodes",
    "force_inputs",
    "roles",
    "units",
    "fmu_outputs",
)
_ELEMENT_FIELDS = ("name", "kind", "from", "to")
_FMU_OUTPUT_FIELDS = ("name", "signal", "unit", "description")

#: A parameter name: it becomes an FMU variable name, so it must be a plain name of the
#: FMI 2.0 "structured" naming convention the FMUs declare (a letter or _, then letters,
#: digits or _), which is also a Python identifier.
PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

#: Parameter values accepted (SI: kg, N/m, N s/m). Far outside any body or vehicle
#: (the stiffest element shipped is 2.2e9 N/m), the state space and the frequency responses
#: lose every digit: 1e300 gave |T| of 1e280 or 3e-279 where the true value is about 1.
PARAMETER_RANGE = PARAMETER_LIMITS


def network_from_file(path: Union[str, os.PathLike]) -> Network:
    """Read and validate a parameter file; see :func:`network_from_dict`.

    Parameters
    ----------
    path : str or os.PathLike
        A JSON parameter file.

    Returns
    -------
    Network
        The validated network; messages about it name ``path``.

    Raises
    ------
    BodyvibError
        What :func:`bodyvib.runtime.jsonfile.read_json` refuses (an unreadable file,
        not UTF-8, not JSON) or :func:`network_from_dict` refuses (the content).
    """
    path = os.fspath(path)
    return network_from_dict(read_json(path, "model file"), source=path)


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BodyvibError(f"{where}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise BodyvibError(f"{where}: must be finite, got {value}")
    return value


def network_from_dict(data: dict, source: str = "<model>") -> Network:
    """Validate a parameter-file dictionary and build its network.

    Parameters
    ----------
    data : dict
        Parsed JSON (see the module docstring for the fields).
    source : str
        Name used in error messages (the file path).

    Returns
    -------
    Network
        Its elements, masses, roles and parameter values (SI), as the file says.

    Raises
    ------
    BodyvibError
        The one list of a parameter file's content checks: missing or extra field, a parameter name that is not a valid FMU
        variable name, non-numeric or non-finite value, non-positive
        parameter or mass, a parameter outside :data:`PARAMETER_RANGE`, unknown element kind, unknown point or parameter,
        a mass not connected to the base, or an unused parameter.
    """
    where = source
    if not isinstance(data, dict):
        raise BodyvibError(f"{where}: expected a JSON object at the top level")
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise BodyvibError(f"{where}: missing field(s) {', '.join(missing)}")
    extra = sorted(set(data) - set(_REQUIRED) - set(_OPTIONAL))
    if extra:
        raise BodyvibError(
            f"{where}: unknown field(s) {', '.join(extra)}; allowed fields are "
            + ", ".join(_REQUIRED + _OPTIONAL)
        )
    if not isinstance(data["name"], str) or not data["name"]:
        raise BodyvibError(f"{where}: 'name' must be a non-empty string")

    raw_params = data["parameters"]
    if not isinstance(raw_params, dict) or not raw_params:
        raise BodyvibError(f"{where}: 'parameters' must be an object of name: value")
    params: Dict[str, float] = {}
    for k, v in raw_params.items():
        if not PARAMETER_NAME.match(k):
            raise BodyvibError(
                f"{where}: parameter name {k!r} is not a valid FMU variable name; use letters, "
                "digits and _ only, starting with a letter or _ (e.g. k_seat)"
            )
        val = _number(v, f"{where}: parameters.{k}")
        if val <= 0:
            raise BodyvibError(
                f"{where}: parameters.{k} = {val:g} must be positive "
                "(masses in kg, stiffnesses in N/m, damping in N s/m)"
            )
        lo, hi = PARAMETER_RANGE
        if not lo <= val <= hi:
            raise BodyvibError(
                f"{where}: parameters.{k} = {val:g} is outside {lo:g} to {hi:g}, the range in "
                "which the model's computations keep their accuracy (SI units: kg, N/m, N s/m)"
            )
        params[k] = val
    used = set()

    def ref(value: object, field_where: str) -> Union[str, float]:
        if isinstance(value, str):
            if value not in params:
                raise BodyvibError(
                    f"{field_where}: unknown parameter '{value}'; parameters are "
                    + ", ".join(params)
                )
            used.add(value)
            return value
        val = _number(value, field_where)
        if val <= 0:
            raise BodyvibError(f"{field_where} = {val:g} must be positive")
        return val

    base = data.get("base", "seat")
    if not isinstance(base, str) or not base:
        raise BodyvibError(f"{where}: 'base' must be a point name")

    masses_raw = data["masses"]
    if not isinstance(masses_raw, dict) or not masses_raw:
        raise BodyvibError(f"{where}: 'masses' must be an object of point: parameter")
    masses = {}
    for m, r in masses_raw.items():
        masses[m] = ref(r, f"{where}: masses.{m}")  # positive: ref() and the parameters checked
    nodes = data.get("nodes", [])
    if not isinstance(nodes, list) or not all(isinstance(n, str) for n in nodes):
        raise BodyvibError(f"{where}: 'nodes' must be a list of node names")
    points = set(masses) | set(nodes) | {base}
    if len(points) != len(masses) + len(nodes) + 1:
        raise BodyvibError(f"{where}: mass, node and base names must all differ")

    elements_raw = data["elements"]
    if not isinstance(elements_raw, list) or not elements_raw:
        raise BodyvibError(f"{where}: 'elements' must be a non-empty list")
    elements = []
    names = set()
    for i, e in enumerate(elements_raw):
        ew = f"{where}: elements[{i}]"
        if not isinstance(e, dict):
            raise BodyvibError(f"{ew}: expected an object")
        miss = [k for k in _ELEMENT_FIELDS if k not in e]
        if miss:
            raise BodyvibError(f"{ew}: missing field(s) {', '.join(miss)}")
        for k in _ELEMENT_FIELDS + (("node",) if "node" in e else ()):
            if not isinstance(e[k], str) or not e[k]:
                raise BodyvibError(f"{ew}.{k}: expected a non-empty string, got {e[k]!r}")
        ew = f"{where}: element '{e['name']}'"
        if e["name"] in names:
            raise BodyvibError(f"{ew}: duplicate element name")
        names.add(e["name"])
        kind = e["kind"]
        if kind not in ELEMENT_KINDS:
            raise BodyvibError(f"{ew}: unknown kind '{kind}'; kinds are {', '.join(ELEMENT_KINDS)}")
        need = ELEMENT_KINDS[kind]
        allowed = set(_ELEMENT_FIELDS) | set(need)
        if kind in ("series_kelvin", "zener"):
            allowed.add("node")
        miss = [k for k in need if k not in e]
        if miss:
            raise BodyvibError(f"{ew}: a {kind} needs field(s) {', '.join(miss)}")
        extra = sorted(set(e) - allowed)
        if extra:
            raise BodyvibError(
                f"{ew}: unknown field(s) {', '.join(extra)} for a {kind}; "
                f"its fields are {', '.join(sorted(allowed))}"
            )
        node = e.get("node")
        el = Element(
            name=e["name"],
            kind=kind,
            a=e["from"],
            b=e["to"],
            values={p: ref(e[p], f"{ew}.{p}") for p in need},
            node=node,
        )
        if el.internal_node is not None:
            if el.internal_node in points:
                raise BodyvibError(f"{ew}: node name '{el.internal_node}' is already used")
            points.add(el.internal_node)
        elements.append(el)
    for el in elements:
        for p in (el.a, el.b):
            if p not in points:
                raise BodyvibError(
                    f"{where}: element '{el.name}' connects unknown point '{p}'; "
                    f"points are {', '.join(sorted(points))}"
                )
        if el.a == el.b:
            raise BodyvibError(f"{where}: element '{el.name}' connects '{el.a}' to itself")

    # every mass and node must be connected to the base
    adj: Dict[str, set[str]] = {p: set() for p in points}
    for el in elements:
        chain = [el.a, el.b] if el.internal_node is None else [el.a, el.internal_node, el.b]
        for p, q in zip(chain, chain[1:] + [chain[0]]):
            adj[p].add(q)
            adj[q].add(p)
    seen, todo = {base}, [base]
    while todo:
        for q in adj[todo.pop()]:
            if q not in seen:
                seen.add(q)
                todo.append(q)
    loose = [p for p in list(masses) + nodes if p not in seen]
    if loose:
        raise BodyvibError(
            f"{where}: {', '.join(loose)} not connected to the {base} by any element"
        )

    force_inputs = data.get("force_inputs", [])
    if not isinstance(force_inputs, list) or any(
        not isinstance(f, str) or f not in masses for f in force_inputs
    ):
        raise BodyvibError(f"{where}: 'force_inputs' must list mass names")
    roles = data.get("roles", {})
    if not isinstance(roles, dict):
        raise BodyvibError(f"{where}: 'roles' must be an object of role: point")
    for r, p in roles.items():
        if not isinstance(p, str) or p not in points:
            raise BodyvibError(f"{where}: roles.{r} names unknown point '{p}'")
    unused = [p for p in params if p not in used]
    if unused:
        raise BodyvibError(
            f"{where}: parameter(s) {', '.join(unused)} not used by any mass or element"
        )
    units = data.get("units", {})
    if (
        not isinstance(units, dict)
        or any(u not in params for u in units)
        or not all(isinstance(u, str) for u in units.values())
    ):
        raise BodyvibError(f"{where}: 'units' must map parameter names to unit strings")
    fmu_outputs = _fmu_outputs(
        data.get("fmu_outputs", []),
        where,
        masses,
        points,
        {el.name for el in elements},
        roles,
        base,
    )
    provenance = data.get("provenance", {})
    if not isinstance(provenance, dict):
        raise BodyvibError(f"{where}: 'provenance' must be an object")

    return Network(
        name=data["name"],
        parameters=params,
        masses=masses,
        elements=tuple(elements),
        nodes=tuple(nodes),
        base=base,
        force_inputs=tuple(force_inputs),
        roles=dict(roles),
        description=str(data.get("description", "")),
        provenance=dict(provenance),
        units=dict(units),
        fmu_outputs=fmu_outputs,
    )


def _fmu_outputs(
    items: object,
    where: str,
    masses: Collection[str],
    points: Collection[str],
    element_names: Collection[str],
    roles: Mapping[str, str],
    base: str,
) -> Tuple[Dict[str, str], ...]:
    """Validate ``fmu_outputs``: each an object of name, signal, unit, description."""
    if not isinstance(items, list):
        raise BodyvibError(
            f"{where}: 'fmu_outputs' must be a list of objects with fields "
            f"{', '.join(_FMU_OUTPUT_FIELDS)}"
        )
    out, names = [], set()
    for i, item in enumerate(items):
        w = f"{where}: fmu_outputs[{i}]"
        if not isinstance(item, dict) or set(item) != set(_FMU_OUTPUT_FIELDS):
            raise BodyvibError(
                f"{w} must be an object with exactly the fields {', '.join(_FMU_OUTPUT_FIELDS)}"
            )
        for key in _FMU_OUTPUT_FIELDS:
            if not isinstance(item[key], str) or not item[key]:
                raise BodyvibError(f"{w}.{key} must be a non-empty string")
        name, signal, unit = item["name"], item["signal"], item["unit"]
        if not name.isidentifier() or name in names:
            raise BodyvibError(f"{w}.name '{name}' must be a unique identifier")
        names.add(name)
        if unit not in UNITS:  # the units the FMU contract defines
            raise BodyvibError(f"{w}.unit '{unit}' is not one of {', '.join(UNITS)}")
        point, _, quantity = signal.rpartition(".")
        point = roles.get(point, point)
        ok = (
            signal == f"{base}_force"
            or (point in masses and quantity in ("x", "v", "a"))
            or (point in points and point not in masses and point != base and quantity == "y")
            or (point in element_names and quantity in ("deflection", "force"))
        )
        if not ok:
            raise BodyvibError(
                f"{w}.signal '{signal}' is not an output of the model: use <mass or role>.x/.v/.a, "
                f"<node>.y, <element>.deflection/.force or {base}_force"
            )
        out.append({k: item[k] for k in _FMU_OUTPUT_FIELDS})
    return tuple(out)


def network_to_dict(net: Network) -> dict:
    """The parameter-file dictionary of a network (inverse of :func:`network_from_dict`).

    Parameters
    ----------
    net : Network
        Any network, e.g. one :func:`network_from_dict` built.

    Returns
    -------
    dict
        JSON-serializable; :func:`network_from_dict` builds ``net`` back from it.
    """
    elements = []
    for el in net.elements:
        d: Dict[str, Union[str, float]] = {
            "name": el.name,
            "kind": el.kind,
            "from": el.a,
            "to": el.b,
        }
        d.update(el.values)
        if el.node is not None:
            d["node"] = el.node
        elements.append(d)
    out = {
        "name": net.name,
        "description": net.description,
        "provenance": dict(net.provenance),
        "base": net.base,
        "parameters": dict(net.parameters),
        "masses": dict(net.masses),
        "nodes": list(net.nodes),
        "elements": elements,
        "roles": dict(net.roles),
    }
    if net.units:
        out["units"] = dict(net.units)
    if net.force_inputs:
        out["force_inputs"] = list(net.force_inputs)
    if net.fmu_outputs:
        out["fmu_outputs"] = [dict(o) for o in net.fmu_outputs]
    return out
