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
:mod:`bodyvib.runtime.contract`), ``forces`` (named internal forces:
``{"neck": "upper_body"}`` maps a name to an element; the model then has the
output ``neck_force`` [N], that element's force, positive in compression, and
an FMU built from it the output of the same name), ``actuators`` and ``bodies``.

``actuators`` declares force pairs a controller drives (an active suspension):

.. code-block:: json

    "actuators": [{"name": "front", "from": "front_wheel", "to": "front"}]

Sign convention: a positive actuator force pushes ``to`` up and ``from`` down
(it pushes the two points apart when ``to`` is the upper one). Both points must
be listed in ``force_inputs``. ``name`` is a plain name or empty; a car FMU takes
the force as the input ``actuator_force_<name>`` (``actuator_force`` when the name
is empty).

``bodies`` declares rigid bodies that bounce and pitch, and roll if given a
``roll_inertia`` (a car body):

.. code-block:: json

    "bodies": {"body": {"mass": "ms", "inertia": "Iy", "extent": [-2.6, 2.2],
                        "points": {"front": "lf", "rear": "-lr", "seat": "seat_x"}}}

``mass`` (kg) and ``inertia`` (pitch moment of inertia about the centre of
mass, kg m2) are parameter references. Sign convention: a point's position
``x`` is measured from the centre of mass, positive ahead (towards the front);
pitch ``theta`` is positive nose up; for small angles a point moves
``z + x theta``. A position is a number (any sign), a parameter name, or a
parameter name after ``-`` (a point behind the centre of mass). The optional
``extent`` [rear end, front end] (m) bounds the points. The points are used
in elements, ``force_inputs`` and ``roles`` as masses are. ``base`` may also
be a list of points, all driven (the front and rear road of a half car).

A body with ``"roll_inertia"`` (roll moment of inertia about the centre of mass,
kg m2) also rolls; its points may then be pairs ``[x, y]``, ``y`` positive to
the left, or triples ``[x, y, h]``, ``h`` above the centre of mass (the point then
has the horizontal accelerations ``.ax`` and ``.ay``); roll ``phi`` is positive when
the left side rises, and a point moves ``z + x theta + y phi``. A body that does not
roll takes a triple ``[x, 0, h]`` for a point above its centre of mass (its ``.ay`` is
zero). A position may
scale a parameter: ``"0.5*tf"``, ``"-0.5*tf"``. An ``anti_roll_bar`` element joins two suspensions:
``from``/``to`` the left wheel and body point, ``from_right``/``to_right`` the
right ones, ``k`` its roll stiffness [N m/rad] and ``track`` [m] the distance
between its ends (see :mod:`bodyvib.runtime.network`).

The shipped models and loading by name are :mod:`bodyvib.models`. Numpy-free
apart from what :mod:`bodyvib.runtime.network` needs; relative imports only:
the FMUs read their baked parameter file with this module.
"""

import math
import os
import re
from typing import (
    Any,
    Collection,
    Dict,
    Iterator,
    List,
    Mapping,
    Sequence,
    Set,
    Tuple,
    Union,
    overload,
)

from .contract import PARAMETER_LIMITS, UNITS
from .errors import BodyvibError
from .jsonfile import read_json
from .network import (
    ELEMENT_KINDS,
    NONLINEAR_KINDS,
    OPTIONAL_FIELDS,
    Element,
    Network,
    RigidBody,
    Value,
    split_position,
    static_preloads,
)

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
    "forces",
    "bodies",
    "actuators",
    "static_loads",
)
_ACTUATOR_FIELDS = ("name", "from", "to")
_BODY_FIELDS = ("mass", "inertia", "points")
_ELEMENT_FIELDS = ("name", "kind", "from", "to")
_FMU_OUTPUT_FIELDS = ("name", "signal", "unit", "description")
#: A rigid body's outputs: bounce, pitch and (of a body that rolls) roll.
_BODY_QUANTITIES = ("x", "v", "a", "theta", "omega", "alpha", "phi", "phi_rate", "phi_acceleration")

#: A parameter name: it becomes an FMU variable name, so it must be a plain name of the
#: FMI 2.0 "structured" naming convention the FMUs declare (a letter or _, then letters,
#: digits or _), which is also a Python identifier.
PARAMETER_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")

#: Parameter values accepted (SI: kg, N/m, N s/m). Far outside any body or vehicle
#: (the stiffest element shipped is 2.2e9 N/m), the state space and the frequency responses
#: lose every digit: 1e300 gave ``|T|`` of 1e280 or 3e-279 where the true value is about 1.
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

    The checks run as named steps, each on one part of the file: the top level
    (``_check_fields``), the parameters, the base points, the masses, nodes
    and rigid bodies, the elements, the connections to the base, and the
    optional fields.

    Parameters
    ----------
    data : dict
        Parsed JSON (see the module docstring for the fields).
    source : str
        Name used in error messages (the file path).

    Returns
    -------
    Network
        Its elements, masses, bodies, roles and parameter values (SI), as the file says.

    Raises
    ------
    BodyvibError
        The one list of a parameter file's content checks: missing or extra field, a
        parameter name that is not a valid FMU variable name, non-numeric or non-finite
        value, non-positive parameter or mass, a parameter outside
        :data:`PARAMETER_RANGE`, unknown element kind, unknown point or parameter, a
        rigid body without mass or inertia or with a point outside its extent, a mass
        or body not connected to a base, or an unused parameter.

    Examples
    --------
    >>> net = network_from_dict({"name": "one", "parameters": {"m": 1.0, "k": 100.0},
    ...     "masses": {"m": "m"},
    ...     "elements": [{"name": "s", "kind": "spring", "from": "seat", "to": "m", "k": "k"}]})
    >>> net.mass_names, net.base
    (('m',), 'seat')
    """
    where = source
    _check_fields(data, where)
    refs = _References(_parameters(data["parameters"], where), where)
    base, extra_bases = _bases(data.get("base", "seat"), where)
    masses = _masses(data["masses"], refs, where)
    nodes = _nodes(data.get("nodes", []), where)
    bodies = _bodies(data.get("bodies", {}), refs, where)
    if not masses and not bodies:
        raise BodyvibError(f"{where}: 'masses' must be an object of point: parameter")
    body_points = [p for body in bodies.values() for p in body.points]
    named = list(masses) + nodes + list(bodies) + body_points + [base, *extra_bases]
    if len(set(named)) != len(named):
        raise BodyvibError(f"{where}: mass, node, body, body point and base names must all differ")
    points = set(named) - set(bodies)
    elements = _elements(data["elements"], refs, points, where, nodes)
    _check_connected(elements, bodies, masses, nodes, (base, *extra_bases), where)

    force_inputs = _force_inputs(
        data.get("force_inputs", []), set(masses) | set(body_points), where
    )
    roles = _roles(data.get("roles", {}), points | set(bodies), where)
    static_loads = _static_loads(data.get("static_loads", {}), refs, force_inputs, where)
    units = _units(data.get("units", {}), refs, where)
    fmu_outputs = _fmu_outputs(
        data.get("fmu_outputs", []),
        where,
        set(masses) | set(body_points),
        points,
        {el.name for el in elements},
        roles,
        (base, *extra_bases),
        set(bodies),
        {el.name for el in elements if el.kind == "contact"},
    )
    forces = _forces(data.get("forces", {}), where, {el.name for el in elements}, base)
    actuators = _actuators(data.get("actuators", []), where, force_inputs)
    provenance = data.get("provenance", {})
    if not isinstance(provenance, dict):
        raise BodyvibError(f"{where}: 'provenance' must be an object")
    net = Network(
        name=data["name"],
        parameters=refs.params,
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
        bodies=bodies,
        extra_bases=extra_bases,
        forces=forces,
        actuators=actuators,
        static_loads=static_loads,
    )
    _check_load_paths(net, where)
    return net


def _check_load_paths(net: Network, where: str) -> None:
    """A contact must carry a static load: solve the static equilibrium once."""
    if any(el.kind == "contact" for el in net.elements):
        try:
            static_preloads(net)
        except BodyvibError as exc:
            raise BodyvibError(f"{where}: {exc}") from None


def _static_loads(
    raw: object, refs: "_References", force_inputs: Collection[str], where: str
) -> Dict[str, Value]:
    """``static_loads``: point -> mass (kg) resting on it, a point that takes a force input."""
    if not isinstance(raw, dict):
        raise BodyvibError(f"{where}: 'static_loads' must be an object of point: mass parameter")
    for p in raw:
        if p not in force_inputs:
            raise BodyvibError(
                f"{where}: static_loads.{p}: '{p}' takes no force input; a static load rests "
                "on a point listed in 'force_inputs' (where the other model pushes)"
            )
    return {p: refs.value(m, f"{where}: static_loads.{p}") for p, m in raw.items()}


def _force_inputs(force_inputs: object, loaded: set, where: str) -> list:
    """``force_inputs``: names of masses (or rigid-body points) a force drives."""
    if not isinstance(force_inputs, list) or any(
        not isinstance(f, str) or f not in loaded for f in force_inputs
    ):
        raise BodyvibError(
            f"{where}: 'force_inputs' must list mass names (or rigid-body point names)"
        )
    return force_inputs


def _roles(roles: object, known: set, where: str) -> dict:
    """``roles``: role -> a point or body of the network."""
    if not isinstance(roles, dict):
        raise BodyvibError(f"{where}: 'roles' must be an object of role: point")
    for r, p in roles.items():
        if not isinstance(p, str) or p not in known:
            raise BodyvibError(f"{where}: roles.{r} names unknown point '{p}'")
    return roles


def _units(units: object, refs: "_References", where: str) -> dict:
    """Every parameter used, and ``units``: parameter -> unit string."""
    unused = [p for p in refs.params if p not in refs.used]
    if unused:
        raise BodyvibError(
            f"{where}: parameter(s) {', '.join(unused)} not used by any mass, body or element"
        )
    if (
        not isinstance(units, dict)
        or any(u not in refs.params for u in units)
        or not all(isinstance(u, str) for u in units.values())
    ):
        raise BodyvibError(f"{where}: 'units' must map parameter names to unit strings")
    return units


def _check_fields(data: object, where: str) -> None:
    """The top level: an object with the required fields, no unknown ones, and a name."""
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


def _parameters(raw: object, where: str) -> Dict[str, float]:
    """The named parameter values: valid names, finite, positive, within range."""
    if not isinstance(raw, dict) or not raw:
        raise BodyvibError(f"{where}: 'parameters' must be an object of name: value")
    params: Dict[str, float] = {}
    lo, hi = PARAMETER_RANGE
    for k, v in raw.items():
        if not PARAMETER_NAME.match(k):
            raise BodyvibError(
                f"{where}: parameter name {k!r} is not a valid FMU variable name; use letters, "
                "digits and _ only, starting with a letter or _ (e.g. k_seat)"
            )
        val = _number(v, f"{where}: parameters.{k}")
        if val <= 0:
            raise BodyvibError(
                f"{where}: parameters.{k} = {val:g} must be positive "
                "(masses in kg, stiffnesses in N/m, damping in N s/m, lengths in m)"
            )
        if not lo <= val <= hi:
            raise BodyvibError(
                f"{where}: parameters.{k} = {val:g} is outside {lo:g} to {hi:g}, the range in "
                "which the model's computations keep their accuracy (SI units: kg, N/m, N s/m)"
            )
        params[k] = val
    return params


class _References:
    """Resolves parameter references (a name or a literal) and records the names used."""

    def __init__(self, params: Dict[str, float], where: str):
        self.params = params
        self.where = where
        self.used: Set[str] = set()

    @overload
    def value(self, value: str, field_where: str) -> str: ...

    @overload
    def value(self, value: object, field_where: str) -> Value: ...

    def value(self, value: object, field_where: str) -> Value:
        """A positive quantity: a parameter name or a positive literal."""
        if isinstance(value, str):
            if value not in self.params:
                raise BodyvibError(
                    f"{field_where}: unknown parameter '{value}'; parameters are "
                    + ", ".join(self.params)
                )
            self.used.add(value)
            return value
        val = _number(value, field_where)
        if val <= 0:
            raise BodyvibError(f"{field_where} = {val:g} must be positive")
        return val

    def position(self, value: object, field_where: str) -> Value:
        """A signed position: a literal, or a parameter name after an optional ``-`` and
        an optional positive factor ``<number>*`` (``"-0.5*tf"``)."""
        if isinstance(value, str):
            try:
                _, factor, name = split_position(value)
            except ValueError:
                factor, name = -1.0, ""
            if not factor > 0 or not math.isfinite(factor):
                raise BodyvibError(
                    f"{field_where}: position {value!r} must be a number, a parameter name, "
                    "or one after '-' and a positive factor '<number>*' (e.g. -0.5*tf)"
                )
            self.value(name, field_where)
            return value
        return _number(value, field_where)

    def resolve(self, ref: Value) -> float:
        """The number a checked reference stands for."""
        if isinstance(ref, str):
            sign, factor, name = split_position(ref)
            return sign * factor * self.params[name]
        return float(ref)


def _bases(raw: Any, where: str) -> Tuple[str, Tuple[str, ...]]:
    """The driven point (a name) or points (a list of names): the first and the others."""
    names = raw if isinstance(raw, list) else [raw]
    if not names or not all(isinstance(b, str) and b for b in names):
        raise BodyvibError(f"{where}: 'base' must be a point name or a list of point names")
    return names[0], tuple(names[1:])


def _masses(raw: object, refs: _References, where: str) -> Dict[str, Value]:
    """Mass point -> parameter name (or literal), each positive."""
    if not isinstance(raw, dict):
        raise BodyvibError(f"{where}: 'masses' must be an object of point: parameter")
    return {m: refs.value(r, f"{where}: masses.{m}") for m, r in raw.items()}


def _nodes(raw: object, where: str) -> List[str]:
    """Declared massless node names."""
    if not isinstance(raw, list) or not all(isinstance(n, str) for n in raw):
        raise BodyvibError(f"{where}: 'nodes' must be a list of node names")
    return list(raw)


def _bodies(raw: object, refs: _References, where: str) -> Dict[str, RigidBody]:
    """Rigid bodies: mass, pitch inertia, points at positions within the optional extent."""
    if not isinstance(raw, dict):
        raise BodyvibError(f"{where}: 'bodies' must be an object of body name: body")
    bodies = {}
    for name, b in raw.items():
        bw = f"{where}: body '{name}'"
        if not isinstance(b, dict):
            raise BodyvibError(f"{bw}: expected an object with {', '.join(_BODY_FIELDS)}")
        missing = [k for k in _BODY_FIELDS if k not in b]
        if missing:
            raise BodyvibError(
                f"{bw}: missing field(s) {', '.join(missing)} (mass in kg, inertia: the pitch "
                "moment of inertia in kg m2, points: name -> position in m ahead of the "
                "centre of mass)"
            )
        extra = sorted(set(b) - set(_BODY_FIELDS) - {"extent", "roll_inertia"})
        if extra:
            raise BodyvibError(
                f"{bw}: unknown field(s) {', '.join(extra)}; its fields are "
                f"{', '.join(_BODY_FIELDS)}, extent, roll_inertia"
            )
        points = b["points"]
        if not isinstance(points, dict) or len(points) < 2:
            raise BodyvibError(
                f"{bw}: 'points' must name at least two points (name -> position in m), "
                "or its pitch is not held"
            )
        rolls = "roll_inertia" in b
        positions = {p: _place(x, refs, f"{bw}: points.{p}", rolls) for p, x in points.items()}
        extent = b.get("extent")
        if extent is not None:
            extent = _extent(extent, bw)
            for p, ref in positions.items():
                x = refs.resolve(ref[0] if isinstance(ref, tuple) else ref)
                if not extent[0] <= x <= extent[1]:
                    raise BodyvibError(
                        f"{bw}: point '{p}' at x = {x:g} m is outside the body's extent "
                        f"{extent[0]:g} to {extent[1]:g} m; move the point or widen the extent"
                    )
        lateral = {refs.resolve(r[1]) if isinstance(r, tuple) else 0.0 for r in positions.values()}
        if rolls and len(lateral) < 2:
            raise BodyvibError(
                f"{bw}: a body with a roll_inertia needs points at two lateral positions "
                "(points [x, y], y to the left), or its roll is not held"
            )
        bodies[name] = RigidBody(
            mass=refs.value(b["mass"], f"{bw}.mass"),
            inertia=refs.value(b["inertia"], f"{bw}.inertia"),
            points=positions,
            extent=extent,
            roll_inertia=refs.value(b["roll_inertia"], f"{bw}.roll_inertia") if rolls else None,
        )
    return bodies


def _place(raw: object, refs: _References, where: str, rolls: bool) -> Any:
    """A body point: a position ``x``, or (on a body that rolls) a pair ``[x, y]``, or a
    triple ``[x, y, h]`` (``y`` = 0 on a body that does not roll)."""
    if not isinstance(raw, list):
        return refs.position(raw, where)
    flat = not rolls and len(raw) == 3 and refs.resolve(refs.position(raw[1], where)) == 0
    if not (rolls and len(raw) in (2, 3)) and not flat:
        raise BodyvibError(
            f"{where}: a point is a position x in m ahead of the centre of mass, or "
            "[x, y] or [x, y, h] (y in m to the left, h above) on a body with a roll_inertia, "
            "or [x, 0, h] on one without"
        )
    return tuple(refs.position(q, where) for q in raw)


def _extent(raw: object, where: str) -> Tuple[float, float]:
    """A body's [rear end, front end], m from the centre of mass."""
    if not (isinstance(raw, list) and len(raw) == 2):
        raise BodyvibError(f"{where}.extent must be [rear end, front end] in m")
    lo, hi = (_number(x, f"{where}.extent") for x in raw)
    if not lo < hi:
        raise BodyvibError(f"{where}.extent must be [rear end, front end] with rear < front")
    return (lo, hi)


def _elements(
    raw: object, refs: _References, points: Set[str], where: str, nodes: Collection[str] = ()
) -> List[Element]:
    """The elements: fields by kind, unique names, known points; adds internal nodes to points."""
    if not isinstance(raw, list) or not raw:
        raise BodyvibError(f"{where}: 'elements' must be a non-empty list")
    elements, names = [], set()
    nodes = set(nodes)  # declared, and below the internal ones
    for i, e in enumerate(raw):
        el = _element(e, refs, f"{where}: elements[{i}]", where)
        if el.name in names:
            raise BodyvibError(f"{where}: element '{el.name}': duplicate element name")
        names.add(el.name)
        if el.internal_node is not None:
            if el.internal_node in points:
                raise BodyvibError(
                    f"{where}: element '{el.name}': node name '{el.internal_node}' is already used"
                )
            points.add(el.internal_node)
            nodes.add(el.internal_node)
        elements.append(el)
    for el in elements:
        for p in (el.a, el.b) + (el.right or ()):
            if p not in points:
                raise BodyvibError(
                    f"{where}: element '{el.name}' connects unknown point '{p}'; "
                    f"points are {', '.join(sorted(points))}"
                )
            if el.kind in NONLINEAR_KINDS and p in nodes:
                raise BodyvibError(
                    f"{where}: element '{el.name}' ({el.kind}) connects the massless node "
                    f"'{p}'; a {el.kind} acts between masses, rigid-body points and bases"
                )
        if el.a == el.b:
            raise BodyvibError(f"{where}: element '{el.name}' connects '{el.a}' to itself")
    return elements


def _element(e: object, refs: _References, ew: str, where: str) -> Element:
    """One element: its fields for its kind, its parameter references."""
    if not isinstance(e, dict):
        raise BodyvibError(f"{ew}: expected an object")
    miss = [k for k in _ELEMENT_FIELDS if k not in e]
    if miss:
        raise BodyvibError(f"{ew}: missing field(s) {', '.join(miss)}")
    for k in _ELEMENT_FIELDS + (("node",) if "node" in e else ()):
        if not isinstance(e[k], str) or not e[k]:
            raise BodyvibError(f"{ew}.{k}: expected a non-empty string, got {e[k]!r}")
    ew = f"{where}: element '{e['name']}'"
    kind = e["kind"]
    if kind not in ELEMENT_KINDS:
        raise BodyvibError(f"{ew}: unknown kind '{kind}'; kinds are {', '.join(ELEMENT_KINDS)}")
    need = ELEMENT_KINDS[kind]
    allowed = set(_ELEMENT_FIELDS) | set(need) | set(OPTIONAL_FIELDS.get(kind, ()))
    if kind in ("series_kelvin", "zener"):
        allowed.add("node")
    right = None
    if kind == "anti_roll_bar":
        allowed |= {"from_right", "to_right"}
        for k in ("from_right", "to_right"):
            if not isinstance(e.get(k), str) or not e[k]:
                raise BodyvibError(
                    f"{ew}: an anti_roll_bar needs '{k}', the right-hand wheel ('from_right') "
                    "and body point ('to_right') beside the left-hand 'from' and 'to'"
                )
        right = (e["from_right"], e["to_right"])
    miss = [k for k in need if k not in e]
    if miss:
        raise BodyvibError(f"{ew}: a {kind} needs field(s) {', '.join(miss)}")
    extra = sorted(set(e) - allowed)
    if extra:
        raise BodyvibError(
            f"{ew}: unknown field(s) {', '.join(extra)} for a {kind}; "
            f"its fields are {', '.join(sorted(allowed))}"
        )
    if kind in NONLINEAR_KINDS:
        _check_nonlinear(e, refs, ew)
    fields = [p for p in need + OPTIONAL_FIELDS.get(kind, ()) if p in e]
    return Element(
        name=e["name"],
        kind=kind,
        a=e["from"],
        b=e["to"],
        values={p: refs.value(e[p], f"{ew}.{p}") for p in fields},
        node=e.get("node"),
        right=right,
    )


def _check_nonlinear(e: Dict[str, Any], refs: "_References", ew: str) -> None:
    """The values of a contact, stop or asymmetric damper, each refused with its own reason."""
    for key in ("gap_compression", "gap_rebound"):
        if key in e:
            gap = refs.params.get(e[key], e[key]) if isinstance(e[key], str) else e[key]
            if isinstance(gap, (int, float)) and not isinstance(gap, bool) and gap < 0:
                raise BodyvibError(
                    f"{ew}: {key} = {gap:g} m is negative; a gap is the clearance from "
                    "static equilibrium to the stop, give a positive number of metres"
                )
    if e["kind"] == "stop":
        k = refs.params.get(e["k"], e["k"]) if isinstance(e["k"], str) else e["k"]
        if isinstance(k, (int, float)) and not isinstance(k, bool) and k <= 0:
            raise BodyvibError(
                f"{ew}: a stop with stiffness k = {k:g} N/m stops nothing; give k > 0 N/m "
                "(or remove the stop)"
            )


def _check_connected(
    elements: Sequence[Element],
    bodies: Mapping[str, RigidBody],
    masses: Mapping[str, Value],
    nodes: List[str],
    bases: Sequence[str],
    where: str,
) -> None:
    """Every mass, node and rigid body is connected to a base by elements (or its body)."""
    adj: Dict[str, Set[str]] = {}

    def link(p: str, q: str) -> None:
        adj.setdefault(p, set()).add(q)
        adj.setdefault(q, set()).add(p)

    for el in elements:
        chain = [el.a, el.b] if el.internal_node is None else [el.a, el.internal_node, el.b]
        for p, q in zip(chain, chain[1:]):
            link(p, q)
        if el.right is not None:
            link(*el.right)
    for b, body in bodies.items():
        for p in body.points:
            link(b, p)
    seen, todo = set(bases), list(bases)
    while todo:
        for q in adj.get(todo.pop(), ()):
            if q not in seen:
                seen.add(q)
                todo.append(q)
    loose = [p for p in list(masses) + nodes + list(bodies) if p not in seen]
    if loose:
        raise BodyvibError(
            f"{where}: {', '.join(loose)} not connected to the {' or '.join(bases)} by any element"
        )


def _forces(items: object, where: str, element_names: Collection[str], base: str) -> Dict[str, str]:
    """Validate ``forces``: an object of force name -> element name."""
    if not isinstance(items, dict):
        raise BodyvibError(
            f"{where}: 'forces' must be an object of force name: element name, "
            'e.g. {"neck": "upper_body"}'
        )
    for name, element in items.items():
        if not PARAMETER_NAME.match(name) or name == base:
            raise BodyvibError(
                f"{where}: forces name '{name}' must be a plain name (letters, digits, _) "
                f"other than the base '{base}'"
            )
        if element not in element_names:
            raise BodyvibError(
                f"{where}: forces.{name} names unknown element '{element}'; "
                f"elements are {', '.join(sorted(element_names))}"
            )
    return dict(items)


def _objects(
    items: object, where: str, key: str, fields: Sequence[str]
) -> Iterator[Tuple[str, Dict[str, Any]]]:
    """The entries of a list field ``key`` whose entries are objects of exactly ``fields``,
    each with its place in the file (for messages); refuses any other shape."""
    if not isinstance(items, list):
        raise BodyvibError(
            f"{where}: '{key}' must be a list of objects with fields {', '.join(fields)}"
        )
    for i, item in enumerate(items):
        w = f"{where}: {key}[{i}]"
        if not isinstance(item, dict) or set(item) != set(fields):
            raise BodyvibError(f"{w} must be an object with exactly the fields {', '.join(fields)}")
        yield w, item


def _actuators(
    items: object, where: str, force_inputs: Collection[str]
) -> Tuple[Dict[str, str], ...]:
    """Validate ``actuators``: a list of ``{"name", "from", "to"}`` between force inputs."""
    out, names = [], set()
    for w, item in _objects(items, where, "actuators", _ACTUATOR_FIELDS):
        name, lower, upper = item["name"], item["from"], item["to"]
        if not isinstance(name, str) or (name and not PARAMETER_NAME.match(name)):
            raise BodyvibError(f"{w}.name must be empty or a plain name (letters, digits, _)")
        if name in names:
            raise BodyvibError(f"{w}.name '{name}' is used twice; actuator names must differ")
        names.add(name)
        for key, point in (("from", lower), ("to", upper)):
            if point not in force_inputs:
                raise BodyvibError(
                    f"{w}.{key} '{point}' takes no force: list it in 'force_inputs' "
                    "(an actuator acts between two points that take force inputs)"
                )
        if lower == upper:
            raise BodyvibError(f"{w}: 'from' and 'to' are the same point '{lower}'")
        out.append({"name": name, "from": lower, "to": upper})
    return tuple(out)


def _fmu_outputs(
    items: object,
    where: str,
    masses: Collection[str],
    points: Collection[str],
    element_names: Collection[str],
    roles: Mapping[str, str],
    bases: Sequence[str],
    bodies: Collection[str] = (),
    contacts: Collection[str] = (),
) -> Tuple[Dict[str, str], ...]:
    """Validate ``fmu_outputs``: each an object of name, signal, unit, description."""
    out, names = [], set()
    for w, item in _objects(items, where, "fmu_outputs", _FMU_OUTPUT_FIELDS):
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
            signal in {f"{b}_force" for b in bases}
            or (point in masses and quantity in ("x", "v", "a"))
            or (point in points and quantity in ("ax", "ay"))
            or (point in bodies and quantity in _BODY_QUANTITIES)
            or (point in points and point not in masses and point not in bases and quantity == "y")
            or (point in element_names and quantity in ("deflection", "force"))
            or (point in contacts and quantity == "contact")
        )
        if not ok:
            raise BodyvibError(
                f"{w}.signal '{signal}' is not an output of the model: use <mass, body point "
                "or role>.x/.v/.a, <body>.theta/.omega/.alpha, <node>.y, "
                f"<element>.deflection/.force, <contact>.contact or {bases[0]}_force"
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
        if el.right is not None:
            d["from_right"], d["to_right"] = el.right
        elements.append(d)
    out = {
        "name": net.name,
        "description": net.description,
        "provenance": dict(net.provenance),
        "base": list(net.bases) if net.extra_bases else net.base,
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
    if net.forces:
        out["forces"] = dict(net.forces)
    if net.actuators:
        out["actuators"] = [dict(a) for a in net.actuators]
    if net.static_loads:
        out["static_loads"] = dict(net.static_loads)
    if net.bodies:
        out["bodies"] = {
            name: {
                "mass": b.mass,
                "inertia": b.inertia,
                "points": {p: list(x) if isinstance(x, tuple) else x for p, x in b.points.items()},
                **({"extent": list(b.extent)} if b.extent is not None else {}),
                **({"roll_inertia": b.roll_inertia} if b.roll_inertia is not None else {}),
            }
            for name, b in net.bodies.items()
        }
    return out
