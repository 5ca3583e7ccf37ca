"""Lumped mass-spring-damper networks and their linear state-space form.

A *network* is a vibration model written as data: named masses, named
massless nodes, and two-terminal elements between named points, driven by the
prescribed vertical motion of one *base* point (``seat`` for a human-body
model, ``road`` for a vehicle). Optional external forces act on listed masses
(the occupant's seat force on a car body, for example).

Every element is expanded into primitive springs and dampers:

================= ============================== ==================================
kind              parameters                     meaning (``from`` -> ``to``)
================= ============================== ==================================
spring            k [N/m]                        k
damper            c [N s/m]                      c
kelvin            k, c                           k parallel c
series_kelvin     k_series, k, c                 k_series, then node, then (k || c)
zener             k, c, k_series                 k parallel (c in series with k_series)
contact           k, optional c                  k (|| c) that can only push
stop              k, gap_compression,            nothing within the gaps, k (|| c)
                  gap_rebound [m], optional c    beyond either
asymmetric_damper c_compression, c_rebound       c by the sign of the rate
anti_roll_bar     k [N m/rad], track [m]         see below
================= ============================== ==================================

The last three are *nonlinear* (:data:`NONLINEAR_KINDS`): each is linear within a
regime, and :mod:`bodyvib.runtime.regimes` steps the piecewise-affine model they make.
A contact's force (compression-positive) is ``max(0, F0 + k (x_from - x_to) + c
(v_from - v_to))`` with ``F0`` its static preload under gravity
(:func:`static_preloads`); a stop's side ``s`` (+1 compression, -1 rebound) pushes
with ``max(0, -k gap + s (k (x_from - x_to) + c (v_from - v_to)))``, gaps measured
from static equilibrium; an asymmetric damper uses ``c_rebound`` while it extends and
``c_compression`` while it shortens. Here (:func:`linear_model`) they are linearized
about static equilibrium: a contact as ``k`` (|| ``c``), a stop as nothing, an
asymmetric damper as the mean of its two coefficients.

An ``anti_roll_bar`` has four terminals: ``from`` and ``to`` (left wheel, left body
point) and ``from_right`` and ``to_right`` (the same on the right). With ``d =
(x_to - x_from) - (x_to_right - x_from_right)``, the two suspensions' deflection
difference, it pushes ``to`` down and ``from`` up by ``(k / track^2) d`` and the
right pair the other way: the potential ``k / (2 track^2) d^2``, which is six
primitive springs of ``+-k / track^2`` (a bar of roll stiffness ``k`` between
points ``track`` apart).

``series_kelvin`` and ``zener`` create a massless internal node, named by the
element's ``node`` field (``<element>.node`` by default).

A *rigid body* (:class:`RigidBody`) is a mass with a pitch inertia and named
points at longitudinal positions ``x`` along it, measured from its centre of
mass, positive ahead (towards the front). It has two degrees of freedom, bounce
``z`` (up) and pitch ``theta`` (rad, positive nose up), and for small angles a
point at ``x`` moves ``w = z + x theta``. Elements connect a body's points as
they connect masses; a force ``F`` (up) at ``x`` enters the bounce equation as
``F`` and the pitch equation as ``x F``. A network may be driven at several
base points (the front and rear road of a half car): each has its own
displacement and velocity inputs.

A rigid body with a roll inertia (``roll_inertia``, ``Ix``) also rolls: its points
then sit at ``(x, y)``, ``y`` positive to the left, and a point moves ``w = z +
x theta + y phi``. Roll ``phi`` (rad) is positive when the left side rises: a
right-handed rotation about the forward axis. A force ``F`` (up) at ``(x, y)``
enters the roll equation as ``y F``; the roll outputs are ``.phi``,
``.phi_rate`` and ``.phi_acceleration``. A point given a height ``h`` above the
centre of mass, ``(x, y, h)``, also has the outputs ``.ax`` (forward) and ``.ay``
(to the left), its inertial horizontal accelerations for small angles, ``-h
theta''`` and ``-h phi''`` (gravity not included: an accelerometer fixed to the
tilting body would also read ``g theta`` and ``g phi``); a body that does not roll
takes ``(x, 0, h)``, its ``.ay`` zero.

Equations (SI units, z up, perturbations about static equilibrium): a mass
obeys ``m a = sum of element forces (+ external force)``, a rigid body
``m z'' = sum of F`` and ``Iy theta'' = sum of x F`` over its points; a massless node
obeys ``0 = sum of element forces``, which, since every node touches at
least one damper, is a first-order equation for its displacement. The state
vector is ``[x of each mass, z and theta of each body, v of each mass,
z' and theta' of each body, y of each node]``; the input vector is ``[base
displacement, base velocity (for each base), external forces...]`` (the base
velocity is an input of its own so that dampers attached to the base are
exact). Outputs are every mass's displacement, velocity and absolute
acceleration (``.x``, ``.v``, ``.a``), every body's bounce (the same three)
and pitch (``.theta``, ``.omega``, ``.alpha``), the same three of every body
point, every node's displacement, every element's deflection
(``x_to - x_from``, positive when it lengthens) and force (the force it
exerts on its ``to`` point, positive in compression, i.e. pushing ``to``
up), and the *base force* of each base: the force the network exerts on it,
positive in compression (pushing the base down). Then, in the order the
network lists them, its *named forces* ``"<name>_force"`` (``"neck_force"``):
the force of the element each names, the same compression-positive force as
``"<element>.force"``, under the name users ask for.

This module is numpy-only and uses relative imports only, so that FMUs can
ship it under a private name (see ``build_fmu.py``).
"""

from dataclasses import dataclass, field, replace
from typing import Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from .errors import BodyvibError

__all__ = [
    "ELEMENT_KINDS",
    "OPTIONAL_FIELDS",
    "NONLINEAR_KINDS",
    "ELEMENT_MODES",
    "GRAVITY",
    "Element",
    "RigidBody",
    "Network",
    "SignalNames",
    "LinearModel",
    "DescriptorModel",
    "descriptor_model",
    "linear_model",
    "regime_model",
    "static_preloads",
    "linearized",
    "as_linear_model",
    "mount",
    "split_position",
]

#: Element kinds and the parameters each needs (all in SI: N/m, N s/m).
ELEMENT_KINDS: Dict[str, Tuple[str, ...]] = {
    "spring": ("k",),
    "damper": ("c",),
    "kelvin": ("k", "c"),
    "series_kelvin": ("k_series", "k", "c"),
    "zener": ("k", "c", "k_series"),
    "anti_roll_bar": ("k", "track"),
    "contact": ("k",),
    "stop": ("k", "gap_compression", "gap_rebound"),
    "asymmetric_damper": ("c_compression", "c_rebound"),
}

#: Fields an element kind may have beyond :data:`ELEMENT_KINDS`' (its damping).
OPTIONAL_FIELDS: Dict[str, Tuple[str, ...]] = {"contact": ("c",), "stop": ("c",)}

#: Element kinds that switch between linear regimes (module docstring).
NONLINEAR_KINDS: Tuple[str, ...] = ("contact", "stop", "asymmetric_damper")

#: Standard acceleration of gravity (m/s2), for the static preloads of contacts
#: (ISO 80000-3 standard value).
GRAVITY = 9.80665

#: The regimes of each nonlinear kind; the first is the one at static equilibrium.
ELEMENT_MODES: Dict[str, Tuple[str, ...]] = {
    "contact": ("engaged", "free"),
    "stop": ("free", "compression", "rebound"),
    "asymmetric_damper": ("compression", "rebound"),
}

Value = Union[str, float]
#: A primitive spring or damper: its two points and its stiffness (N/m) or damping (N s/m).
Primitive = Tuple[str, str, float]


def split_position(ref: str) -> Tuple[float, float, str]:
    """A position reference ``[-][<factor>*]<name>`` as (sign, factor, parameter name).

    Examples
    --------
    >>> split_position("-0.5*tf")
    (-1.0, 0.5, 'tf')
    """
    sign = -1.0 if ref.startswith("-") else 1.0
    body = ref[1:] if ref.startswith("-") else ref
    factor, star, name = body.rpartition("*")
    return sign, float(factor) if star else 1.0, name


@dataclass(frozen=True)
class Element:
    """A two-terminal element between points ``a`` (``from``) and ``b`` (``to``).

    Parameters
    ----------
    name : str
        Unique element name.
    kind : str
        One of :data:`ELEMENT_KINDS`.
    a, b : str
        The two points it connects (mass, node or base names).
    values : dict
        Element parameter -> parameter name (str, looked up in the network's
        ``parameters``) or a literal number in SI units.
    node : str, optional
        Name of the internal massless node of a ``series_kelvin`` or ``zener``
        element; ``"<name>.node"`` by default.
    right : (str, str), optional
        An ``anti_roll_bar``'s right-hand ``from`` and ``to`` points.
    """

    name: str
    kind: str
    a: str
    b: str
    values: Mapping[str, Value]
    node: Optional[str] = None
    right: Optional[Tuple[str, str]] = None

    @property
    def internal_node(self) -> Optional[str]:
        """Name of the internal node, or None for kinds without one."""
        if self.kind in ("series_kelvin", "zener"):
            return self.node or f"{self.name}.node"
        return None


@dataclass(frozen=True)
class RigidBody:
    """A rigid body that bounces and pitches, with named points along it.

    Parameters
    ----------
    mass : str or float
        Parameter name (or literal) of its mass, kg.
    inertia : str or float
        Parameter name (or literal) of its pitch moment of inertia about the
        centre of mass, kg m^2.
    points : dict of str to str or float
        Point name -> longitudinal position from the centre of mass, m,
        positive ahead: a literal number (any sign), a parameter name, or a
        parameter name with a leading ``-`` (behind the centre of mass).
    extent : (float, float), optional
        Rear and front end of the body, m from the centre of mass; the points
        must lie within it.
    roll_inertia : str or float, optional
        Parameter name (or literal) of its roll moment of inertia about the
        centre of mass, kg m^2: the body then also rolls, and a point may be a
        pair ``(x, y)`` of positions (``y`` positive to the left, each a position
        as ``x`` is) or a triple ``(x, y, h)`` (``h`` above the centre of mass: the
        point then also has horizontal accelerations ``.ax`` and ``.ay``); a single
        position stands for ``(x, 0)``.

    Examples
    --------
    >>> RigidBody("ms", "Iy", {"front": "lf", "rear": "-lr"}).points["rear"]
    '-lr'
    """

    mass: Value
    inertia: Value
    points: Mapping[str, Union[Value, Tuple[Value, ...]]]
    extent: Optional[Tuple[float, float]] = None
    roll_inertia: Optional[Value] = None


@dataclass(frozen=True)
class Network:
    """A lumped vibration model as data: topology plus named parameter values.

    Parameters
    ----------
    name : str
        Model name.
    parameters : dict of str to float
        Named parameter values in SI units (kg, N/m, N s/m). These are the
        numbers a fit changes and an FMU exposes.
    masses : dict of str to str or float
        Mass point name -> parameter name (or literal mass in kg).
    elements : sequence of Element
        The springs, dampers and compound elements.
    nodes : sequence of str
        Declared massless nodes (internal nodes of compound elements are added
        automatically).
    base : str
        The driven point (``"seat"`` for a body model).
    force_inputs : sequence of str
        Masses (or rigid-body points) on which an external force input acts (N,
        positive up).
    roles : dict of str to str
        Field names for points, e.g. ``{"head": "m1", "torso": "m2"}``.
    description : str
        One paragraph on what the model is.
    provenance : dict
        Where the numbers come from (source, assumptions, fit settings).
    units : dict of str to str
        Parameter name -> unit as the parameter file states it (``"kg"``,
        ``"N/m"``, ``"N.s/m"``); kept so that files written back (refits, the
        model file baked into an FMU) keep it. Informative: the numbers are SI.
    fmu_outputs : tuple of dict
        Extra outputs of an FMU built from this model, in order: ``{"name",
        "signal", "unit", "description"}`` with ``signal`` an output of
        :func:`linear_model` (a role may stand for its mass, ``"seat.a"``).
    forces : dict of str to str
        Named internal forces: name (``"neck"``) -> element name. Each becomes the
        output ``"<name>_force"`` [N], the element's force, positive in compression.
    bodies : dict of str to RigidBody
        Rigid bodies by name (bounce and pitch), their points usable wherever a
        mass is.
    extra_bases : sequence of str
        Further driven points after ``base`` (the rear road of a half car), each
        with its own displacement and velocity inputs.
    actuators : tuple of dict
        Force pairs between two points, each ``{"name", "from", "to"}`` (``name``
        may be empty): a positive actuator force pushes ``to`` up and ``from`` down
        with equal magnitude, so it pushes the two apart when ``to`` is the upper
        point (the sprung side of a suspension). Both points are in
        ``force_inputs``; a car FMU takes each as the input
        ``actuator_force[_<name>]``.
    static_loads : dict of str to str or float
        Point -> mass (kg, a parameter name or literal) that rests on it under gravity
        without being part of this model (the occupant of a car FMU, who is another
        FMU): it loads the contacts' static preloads (:func:`static_preloads`) only.
        :func:`mount` drops the one at the mount point, whose masses it brings.
    """

    name: str
    parameters: Mapping[str, float]
    masses: Mapping[str, Value]
    elements: Tuple[Element, ...]
    nodes: Tuple[str, ...] = ()
    base: str = "seat"
    force_inputs: Tuple[str, ...] = ()
    roles: Mapping[str, str] = field(default_factory=dict)
    description: str = ""
    provenance: Mapping[str, object] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    fmu_outputs: Tuple[Mapping[str, str], ...] = ()
    forces: Mapping[str, str] = field(default_factory=dict)
    bodies: Mapping[str, RigidBody] = field(default_factory=dict)
    extra_bases: Tuple[str, ...] = ()
    actuators: Tuple[Mapping[str, str], ...] = ()
    static_loads: Mapping[str, Value] = field(default_factory=dict)

    # -- derived views -----------------------------------------------------
    @property
    def mass_names(self) -> Tuple[str, ...]:
        """Mass point names, in state order."""
        return tuple(self.masses)

    @property
    def node_names(self) -> Tuple[str, ...]:
        """Declared and internal massless node names, in state order."""
        names = list(self.nodes)
        for el in self.elements:
            if el.internal_node is not None and el.internal_node not in names:
                names.append(el.internal_node)
        return tuple(names)

    @property
    def bases(self) -> Tuple[str, ...]:
        """All driven points: ``base``, then ``extra_bases``."""
        return (self.base,) + tuple(self.extra_bases)

    @property
    def body_points(self) -> Dict[str, Tuple[str, float]]:
        """Rigid-body point name -> (body name, position in m ahead of its centre of mass)."""
        return {p: (b, x) for p, (b, x, _) in self.body_point_places.items()}

    @property
    def body_point_places(self) -> Dict[str, Tuple[str, float, float]]:
        """Rigid-body point name -> (body name, m ahead of and m left of its centre of mass)."""
        return {p: (b, x, y) for p, (b, x, y, _) in self.body_point_heights.items()}

    @property
    def body_point_heights(self) -> Dict[str, Tuple[str, float, float, Optional[float]]]:
        """Rigid-body point -> (body, m ahead, m left, m above its centre of mass or None)."""
        out = {}
        for b, body in self.bodies.items():
            for p, ref in body.points.items():
                x, y, *h = ref if isinstance(ref, tuple) else (ref, 0.0)
                height = self.position(h[0]) if h else None
                out[p] = (b, self.position(x), self.position(y), height)
        return out

    def value(self, ref: Value) -> float:
        """Resolve a parameter reference (name or literal) to a float."""
        if isinstance(ref, str):
            return float(self.parameters[ref])
        return float(ref)

    def position(self, ref: Value) -> float:
        """Resolve a point position: a literal, or a parameter name after an optional
        ``-`` and an optional factor ``<number>*`` (``"-0.5*tf"``), m."""
        if isinstance(ref, str):
            sign, factor, name = split_position(ref)
            return sign * factor * self.value(name)
        return self.value(ref)

    def mass_values(self) -> Dict[str, float]:
        """Mass point name -> mass in kg."""
        return {m: self.value(ref) for m, ref in self.masses.items()}

    def total_mass(self) -> float:
        """Sum of all masses and rigid-body masses in kg (the static apparent mass on the base)."""
        bodies = sum(self.value(b.mass) for b in self.bodies.values())
        return float(sum(self.mass_values().values()) + bodies)

    def with_parameters(self, **values: float) -> "Network":
        """Return a copy with some parameter values replaced.

        Raises
        ------
        BodyvibError
            If a name is not a parameter of this network.
        """
        unknown = sorted(set(values) - set(self.parameters))
        if unknown:
            raise BodyvibError(
                f"model '{self.name}' has no parameter(s) {', '.join(unknown)}; "
                f"its parameters are {', '.join(self.parameters)}"
            )
        params = dict(self.parameters)
        params.update({k: float(v) for k, v in values.items()})
        return replace(self, parameters=params)

    def point(self, role_or_name: str) -> str:
        """Resolve a role (``"head"``) or a point name to a point name."""
        return self.roles.get(role_or_name, role_or_name)

    def element_primitives(
        self, el: Element, mode: Optional[str] = None
    ) -> Tuple[List[Primitive], List[Primitive]]:
        """Expand one element into primitive springs and dampers.

        Parameters
        ----------
        el : Element
            One of the network's elements.
        mode : str, optional
            The regime of a nonlinear element (:data:`ELEMENT_MODES`); None linearizes
            it about static equilibrium (module docstring).

        Returns
        -------
        springs, dampers : list of (a, b, value)
            Point pairs with stiffness in N/m or damping in N s/m.
        """
        v = {p: self.value(r) for p, r in el.values.items()}
        if el.kind == "spring":
            return [(el.a, el.b, v["k"])], []
        if el.kind == "damper":
            return [], [(el.a, el.b, v["c"])]
        if el.kind == "kelvin":
            return [(el.a, el.b, v["k"])], [(el.a, el.b, v["c"])]
        if el.kind in ("contact", "stop"):
            engaged = mode in ("engaged", "compression", "rebound") or (
                mode is None and el.kind == "contact"
            )
            if not engaged:
                return [], []
            return [(el.a, el.b, v["k"])], ([(el.a, el.b, v["c"])] if "c" in v else [])
        if el.kind == "asymmetric_damper":
            c = {"compression": v["c_compression"], "rebound": v["c_rebound"]}.get(
                mode or "", 0.5 * (v["c_compression"] + v["c_rebound"])
            )
            return [], [(el.a, el.b, c)]
        n = el.internal_node
        if el.kind == "series_kelvin" and n is not None:  # the kind always has one
            return [(el.a, n, v["k_series"]), (n, el.b, v["k"])], [(n, el.b, v["c"])]
        if el.kind == "zener" and n is not None:
            return [(el.a, el.b, v["k"]), (el.a, n, v["k_series"])], [(n, el.b, v["c"])]
        if el.kind == "anti_roll_bar" and el.right is not None:
            # the Laplacian of (k/t^2) d^2 with d = (b - a) - (br - ar): -k/t^2 v_i v_j per pair
            k = v["k"] / v["track"] ** 2
            ar, br = el.right
            return [
                (el.a, el.b, k),
                (ar, br, k),
                (el.b, br, k),
                (el.a, ar, k),
                (el.b, ar, -k),
                (el.a, br, -k),
            ], []
        raise BodyvibError(f"element '{el.name}': unknown kind '{el.kind}'")

    def element_constant(self, el: Element, mode: Optional[str], preload: float = 0.0) -> float:
        """The constant part of a nonlinear element's force in a regime, N (+ in compression).

        A perturbation about static equilibrium: a free contact loses its static
        preload (``-preload``), an engaged stop side pushes from its gap on
        (``-k gap_compression``, ``+k gap_rebound``); every other case is 0.
        """
        if el.kind == "contact" and mode == "free":
            return -float(preload)
        if el.kind == "stop" and mode in ("compression", "rebound"):
            k = self.value(el.values["k"])
            if mode == "compression":
                return -k * self.value(el.values["gap_compression"])
            return k * self.value(el.values["gap_rebound"])
        return 0.0

    @property
    def nonlinear_elements(self) -> Tuple[Element, ...]:
        """The elements of :data:`NONLINEAR_KINDS`, in the network's order."""
        return tuple(el for el in self.elements if el.kind in NONLINEAR_KINDS)

    def primitives(self) -> Tuple[List[Primitive], List[Primitive]]:
        """All elements expanded into primitive springs and dampers.

        Returns
        -------
        springs, dampers : list of (a, b, value)
        """
        springs: List[Primitive] = []
        dampers: List[Primitive] = []
        for el in self.elements:
            s, d = self.element_primitives(el)
            springs += s
            dampers += d
        return springs, dampers


@dataclass(frozen=True, kw_only=True)
class SignalNames:
    """The named signals of a network's state space, and the network (both forms share them).

    Keyword-only fields, after the matrices of :class:`LinearModel` and
    :class:`DescriptorModel`.

    Attributes
    ----------
    states, inputs, outputs : tuple of str
        Names: states ``"<mass>.x"``, ``"<mass>.v"``, ``"<node>.y"``; inputs
        ``"<base>_displacement"``, ``"<base>_velocity"``, ``"<mass>.force"``;
        outputs ``"<mass>.x"``, ``"<mass>.v"``, ``"<mass>.a"``,
        ``"<node>.y"``, ``"<element>.deflection"``, ``"<element>.force"``,
        ``"<base>_force"``, ``"<name>_force"`` (the network's named forces).
    network : Network
        The network it was built from.
    """

    states: Tuple[str, ...]
    inputs: Tuple[str, ...]
    outputs: Tuple[str, ...]
    network: Network

    def output_index(self, name: str) -> int:
        """Index of an output by name; a role may stand for a mass (``"head.a"``)."""
        point, _, quantity = name.rpartition(".")
        if point:
            name = f"{self.network.point(point)}.{quantity}"
        try:
            return self.outputs.index(name)
        except ValueError:
            raise BodyvibError(
                f"no output '{name}'; outputs are {', '.join(self.outputs)}"
            ) from None

    def input_index(self, name: str) -> int:
        """Index of an input by name."""
        try:
            return self.inputs.index(name)
        except ValueError:
            raise BodyvibError(f"no input '{name}'; inputs are {', '.join(self.inputs)}") from None


@dataclass(frozen=True)
class LinearModel(SignalNames):
    """Continuous-time state space ``x' = A x + B u``, ``y = C x + D u``.

    Attributes
    ----------
    A, B, C, D : ndarray
        System matrices (SI units).
    states, inputs, outputs, network
        Its :class:`SignalNames`.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray


@dataclass(frozen=True)
class DescriptorModel(SignalNames):
    """Descriptor form ``E z' = A z + B u``, ``y = C z + Cd z' + D u`` of a network.

    Every matrix is linear (affine, with literal values) in the network's
    parameters: a mass contributes ``m`` to ``E``, a spring ``k`` and a damper
    ``c`` times fixed stencils, and nothing is divided or solved. This is the
    form the native FMUs assemble from per-parameter stencils
    (:mod:`bodyvib.fmu.native`); :func:`linear_model` solves it.

    Attributes
    ----------
    E, A : (ns, ns) ndarray
    B : (ns, ni) ndarray
    C, Cd : (no, ns) ndarray
        Output rows on the state and on its derivative (accelerations, node
        velocities).
    D : (no, ni) ndarray
    states, inputs, outputs, network
        Its :class:`SignalNames` (those of the :class:`LinearModel` it solves to).
    """

    E: np.ndarray
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    Cd: np.ndarray
    D: np.ndarray

    def solve(self) -> LinearModel:
        """The explicit state space ``x' = E^-1 (A x + B u)``, outputs with ``z'`` substituted.

        Raises
        ------
        BodyvibError
            If ``E`` is singular: a massless node without a damper path.
        """
        try:
            AB = np.linalg.solve(self.E, np.hstack([self.A, self.B]))
        except np.linalg.LinAlgError:
            raise BodyvibError(
                f"model '{self.network.name}': a massless node has no damper path to a "
                "mass or the base, so its motion is undetermined; give every node "
                "a damper (or merge springs in series)"
            ) from None
        ns = self.A.shape[0]
        A, B = AB[:, :ns], AB[:, ns:]
        return LinearModel(
            A=A,
            B=B,
            C=self.C + self.Cd @ A,
            D=self.D + self.Cd @ B,
            states=self.states,
            inputs=self.inputs,
            outputs=self.outputs,
            network=self.network,
        )


def _point_dofs(network: Network) -> dict:
    """Each mass-like point as a combination of degrees of freedom: {dof index: weight}."""
    masses = network.mass_names
    point_dofs = {m: {i: 1.0} for i, m in enumerate(masses)}
    i_body = len(masses)
    for b, body in network.bodies.items():
        rolls = body.roll_inertia is not None
        for p, (owner, x, y) in network.body_point_places.items():
            if owner == b:
                point_dofs[p] = {i_body: 1.0, i_body + 1: x}  # w = z + x theta
                if rolls:
                    point_dofs[p][i_body + 2] = y  # ... + y phi
        i_body += 3 if rolls else 2
    return point_dofs


def _element_forces(
    network: Network, motion: tuple, force_on: dict, const_on: dict, nw: int, regime: tuple
) -> Tuple[dict, dict]:
    """Each element's compression-positive force on its ``to`` point, as a row over ``w``,
    and its constant part (a nonlinear element's preload or gap in its regime); adds the
    forces of its springs and dampers to ``force_on`` and the constants to ``const_on``.
    ``regime`` is ``(modes, preloads)``."""
    pos, vel = motion
    modes, preloads = regime
    element_force, element_const = {}, {}
    for el in network.elements:
        mode = modes.get(el.name)
        el_springs, el_dampers = network.element_primitives(el, mode)
        c0 = network.element_constant(el, mode, preloads.get(el.name, 0.0))
        element_const[el.name] = c0
        const_on[el.b] += c0
        const_on[el.a] -= c0
        f_el = np.zeros(nw)
        for (a, b, k), is_spring in [(p, True) for p in el_springs] + [
            (p, False) for p in el_dampers
        ]:
            f = k * (pos[b] - pos[a]) if is_spring else k * (vel[b] - vel[a])  # force on a, up
            force_on[a] += f
            force_on[b] -= f
            if b == el.b:
                f_el -= f
            elif a == el.b:
                f_el += f
        element_force[el.name] = f_el
    return element_force, element_const


def _point_outputs(
    network: Network, motion: tuple, elements: tuple, forces: tuple, heights: dict
) -> Tuple[list, list, list]:
    """The output rows, names and constants after the degrees of freedom's: rigid-body
    points (and the horizontal accelerations ``heights`` gives of those above the centre
    of mass), nodes, elements, base forces and named forces. ``elements`` is
    ``(element_force, element_const)``, ``forces`` ``(force_on, const_on)``."""
    pos, vel, acc = motion
    element_force, element_const = elements
    force_on, const_on = forces
    out_rows, out_names = [], []
    for p in network.body_points:
        out_rows += [pos[p], vel[p], acc[p]]
        out_names += [f"{p}.x", f"{p}.v", f"{p}.a"]
    for p, rows in heights.items():  # a point above the centre of mass: -h theta'', -h phi''
        out_rows += list(rows)
        out_names += [f"{p}.ax", f"{p}.ay"]
    for n in network.node_names:
        out_rows.append(pos[n])
        out_names.append(f"{n}.y")
    out_const = [0.0] * len(out_rows)
    for el in network.elements:
        out_rows += [pos[el.b] - pos[el.a], element_force[el.name]]
        out_names += [f"{el.name}.deflection", f"{el.name}.force"]
        out_const += [0.0, element_const[el.name]]
    for b in network.bases:
        out_rows.append(-force_on[b])
        out_names.append(f"{b}_force")
        out_const.append(-const_on[b])
    for name, el_name in network.forces.items():
        out_rows.append(element_force[el_name])
        out_names.append(f"{name}_force")
        out_const.append(element_const[el_name])
    return out_rows, out_names, out_const


def descriptor_model(network: Network) -> DescriptorModel:
    """Assemble the descriptor form of a network (linear in its parameters).

    Parameters
    ----------
    network : Network
        A network; parameter values are used as they are (zero is allowed:
        nothing is divided).

    Returns
    -------
    DescriptorModel
        See the module docstring for the equations.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> dm = descriptor_model(load_model("reduced-paper"))
    >>> dm.E.shape, dm.B.shape
    ((5, 5), (5, 2))
    """
    return _descriptor(network)[0]


def _degrees_of_freedom(network: Network) -> Tuple[list, list]:
    """The degrees of freedom (names of position, rate, acceleration) and their inertia:
    a mass's displacement; a rigid body's bounce and pitch (and roll, if it rolls)."""
    mvals = network.mass_values()
    dofs = [(f"{m}.x", f"{m}.v", f"{m}.a") for m in network.mass_names]
    inertia = [mvals[m] for m in network.mass_names]
    for b, body in network.bodies.items():
        dofs += [(f"{b}.x", f"{b}.v", f"{b}.a"), (f"{b}.theta", f"{b}.omega", f"{b}.alpha")]
        inertia += [network.value(body.mass), network.value(body.inertia)]
        if body.roll_inertia is not None:
            dofs.append((f"{b}.phi", f"{b}.phi_rate", f"{b}.phi_acceleration"))
            inertia.append(network.value(body.roll_inertia))
    return dofs, inertia


def _constant_terms(point_dofs: dict, const_on: dict, nd: int, nodes: Sequence[str]) -> np.ndarray:
    """The equations' constant terms ``e``: none in ``x' = v``, the generalized constant
    forces in the momentum equations, the constant forces on the massless nodes."""
    gen_const = [0.0] * nd
    for p, weights in point_dofs.items():
        for i, c in weights.items():
            gen_const[i] += c * const_on[p]
    return np.array([0.0] * nd + gen_const + [const_on[n] for n in nodes])


def _horizontal_rows(network: Network, point_dofs: dict, dof_acc: list) -> dict:
    """A rigid-body point above the centre of mass: its fore-aft and lateral accelerations
    ``-h theta''`` and ``-h phi''`` (zero on a body that does not roll) as rows over ``w`` (point -> (x row,
    y row))."""
    rows = {}
    for p, (b, _, _, h) in network.body_point_heights.items():
        if h is not None:
            i = next(iter(point_dofs[p]))  # the body's bounce, then pitch, then roll
            rolls = network.bodies[b].roll_inertia is not None
            rows[p] = (-h * dof_acc[i + 1], -h * dof_acc[i + 2] if rolls else 0 * dof_acc[i + 1])
    return rows


def _equations(
    point_dofs: dict, force_on: dict, motion: tuple, inertia: list, nodes: Sequence[str]
) -> np.ndarray:
    """The equations, each ``0 = row @ w``: ``x' = v`` for a degree of freedom; inertia
    times ``v'`` = the generalized force (the forces on its points, weighted by the point
    map); 0 = the sum of forces on a massless node (first order in ``y'``).
    ``motion`` is the rows of each degree of freedom's ``v``, ``v'`` and ``x'``."""
    dof_vel, dof_acc, dof_rate = motion
    nd = len(inertia)
    generalized = [np.zeros_like(dof_vel[0]) for _ in range(nd)]
    for p, weights in point_dofs.items():
        for i, c in weights.items():
            generalized[i] = generalized[i] + c * force_on[p]
    rows = [dof_vel[i] - dof_rate[i] for i in range(nd)]
    rows += [generalized[i] - inertia[i] * dof_acc[i] for i in range(nd)]
    rows += [force_on[n] for n in nodes]
    return np.array(rows).reshape(len(rows), len(dof_vel[0]))


def _descriptor(
    network: Network,
    modes: Optional[Mapping[str, str]] = None,
    preloads: Optional[Mapping[str, float]] = None,
) -> Tuple[DescriptorModel, np.ndarray, np.ndarray]:
    """The descriptor form in a regime, and its constant terms.

    ``modes`` (element name -> mode) puts nonlinear elements in a regime (None: their
    linearization); ``preloads`` gives the contacts' static forces (N). Returns the
    model and the constants ``e`` (equations: ``E z' = A z + B u + e``) and ``d0``
    (outputs: ``y = C z + Cd z' + D u + d0``), both zero without ``modes``. With
    ``modes`` each contact adds the output ``"<contact>.contact"``, 1 engaged and 0
    free, after all others.
    """
    regime = modes is not None
    modes = modes or {}
    preloads = preloads or {}
    nodes = network.node_names
    dofs, inertia = _degrees_of_freedom(network)
    nd, nn = len(dofs), len(nodes)
    ns = 2 * nd + nn
    bases = network.bases
    inputs = tuple(n for b in bases for n in (f"{b}_displacement", f"{b}_velocity")) + tuple(
        f"{m}.force" for m in network.force_inputs
    )
    ni = len(inputs)
    # every signal is a linear map of w = [z (states), u (inputs), z' (state derivatives)]
    nw = 2 * ns + ni

    def unit(i: int) -> np.ndarray:
        e = np.zeros(nw)
        e[i] = 1.0
        return e

    point_dofs = _point_dofs(network)

    def combine(vectors: Sequence[np.ndarray], weights: Mapping[int, float]) -> np.ndarray:
        return sum((c * vectors[i] for i, c in weights.items()), np.zeros(nw))

    dof_pos = [unit(i) for i in range(nd)]
    dof_vel = [unit(nd + i) for i in range(nd)]
    dof_acc = [unit(ns + ni + nd + i) for i in range(nd)]  # v' of each degree of freedom
    pos = {p: combine(dof_pos, c) for p, c in point_dofs.items()}
    vel = {p: combine(dof_vel, c) for p, c in point_dofs.items()}
    acc = {p: combine(dof_acc, c) for p, c in point_dofs.items()}
    pos.update({n: unit(2 * nd + j) for j, n in enumerate(nodes)})
    vel.update({n: unit(ns + ni + 2 * nd + j) for j, n in enumerate(nodes)})  # y' of each node
    for j, b in enumerate(bases):
        pos[b], vel[b] = unit(ns + 2 * j), unit(ns + 2 * j + 1)

    force_on = {p: np.zeros(nw) for p in list(point_dofs) + list(nodes) + list(bases)}
    const_on = dict.fromkeys(force_on, 0.0)  # constant forces of nonlinear elements, up
    element_force, element_const = _element_forces(
        network, (pos, vel), force_on, const_on, nw, (modes, preloads)
    )
    for m in network.force_inputs:
        force_on[m] = force_on[m] + unit(ns + inputs.index(f"{m}.force"))

    dof_rate = [unit(ns + ni + i) for i in range(nd)]  # x' of each degree of freedom
    eq = _equations(point_dofs, force_on, (dof_vel, dof_acc, dof_rate), inertia, nodes)
    e = _constant_terms(point_dofs, const_on, nd, nodes)
    out_rows, out_names = [], []
    for i, names in enumerate(dofs):
        out_rows += [dof_pos[i], dof_vel[i], dof_acc[i]]
        out_names += list(names)
    point_rows, point_names, point_const = _point_outputs(
        network,
        (pos, vel, acc),
        (element_force, element_const),
        (force_on, const_on),
        _horizontal_rows(network, point_dofs, dof_acc),
    )
    out_const = [0.0] * len(out_rows) + point_const
    out_rows += point_rows
    out_names += point_names
    if regime:  # a regime's contact flags: 1 engaged, 0 free, constant in the regime
        flags = [el for el in network.elements if el.kind == "contact"]
        out_rows += [np.zeros(nw)] * len(flags)
        out_names += [f"{el.name}.contact" for el in flags]
        out_const += [0.0 if modes.get(el.name) == "free" else 1.0 for el in flags]
    out = np.array(out_rows).reshape(len(out_names), nw)
    states = tuple(d[0] for d in dofs) + tuple(d[1] for d in dofs) + tuple(f"{n}.y" for n in nodes)
    dm = DescriptorModel(
        E=-eq[:, ns + ni :] + 0.0,
        A=eq[:, :ns],
        B=eq[:, ns : ns + ni],
        C=out[:, :ns],
        Cd=out[:, ns + ni :],
        D=out[:, ns : ns + ni],
        states=states,
        inputs=inputs,
        outputs=tuple(out_names),
        network=network,
    )
    return dm, e, np.array(out_const)


def linear_model(network: Network) -> LinearModel:
    """Assemble the state-space matrices of a network.

    The descriptor form (:func:`descriptor_model`) solved for the state
    derivative.

    Parameters
    ----------
    network : Network
        A validated network (see :func:`bodyvib.runtime.modelfile.network_from_dict`).

    Returns
    -------
    LinearModel
        Matrices and signal names; see the module docstring for the equations.

    Raises
    ------
    BodyvibError
        If a massless node has no damper path (its equation would be algebraic).

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> lm = linear_model(load_model("reduced-paper"))
    >>> lm.A.shape
    (5, 5)
    """
    return descriptor_model(network).solve()


def regime_model(
    network: Network, modes: Mapping[str, str], preloads: Mapping[str, float]
) -> Tuple[LinearModel, np.ndarray, np.ndarray]:
    """The affine state space of one regime: ``x' = A x + B u + b``, ``y = C x + D u + d``.

    Parameters
    ----------
    network : Network
        A network with nonlinear elements.
    modes : dict of str to str
        Nonlinear element name -> its mode (:data:`ELEMENT_MODES`); one missing is
        linearized.
    preloads : dict of str to float
        Contact name -> static preload, N (:func:`static_preloads`).

    Returns
    -------
    model : LinearModel
        ``A, B, C, D`` of the regime.
    b : (ns,) ndarray
        Constant state-derivative term.
    d : (no,) ndarray
        Constant output term.

    Raises
    ------
    BodyvibError
        What :meth:`DescriptorModel.solve` refuses.
    """
    dm, e, d0 = _descriptor(network, modes, preloads)
    lm = dm.solve()
    b = np.linalg.solve(dm.E, e) if e.any() else np.zeros(e.shape)
    return lm, b, d0 + dm.Cd @ b


def static_preloads(network: Network) -> Dict[str, float]:
    """The static force of each contact under gravity, N (+ in compression).

    The static equilibrium of the whole network (linearized, :func:`linear_model`) under
    gravity on every mass and rigid body and on its :attr:`Network.static_loads`, the
    bases held at 0: each contact's force there.

    Parameters
    ----------
    network : Network
        Any network; one without contacts gives ``{}``.

    Returns
    -------
    dict of str to float
        Contact name -> preload, N.

    Raises
    ------
    BodyvibError
        A network without a static equilibrium (a mass held by dampers only), or a
        contact that carries no load (no mass rests on it under gravity).

    Examples
    --------
    >>> net = Network("drop", {"m": 10.0, "k": 1e4}, {"m": "m"},
    ...               (Element("floor", "contact", "ground", "m", {"k": "k"}),), base="ground")
    >>> round(static_preloads(net)["floor"], 4)
    98.0665
    """
    contacts = [el for el in network.elements if el.kind == "contact"]
    if not contacts:
        return {}
    lm = linear_model(network)
    g = np.zeros(lm.A.shape[0])
    for m in list(network.masses) + list(network.bodies):
        g[lm.states.index(f"{m}.v")] = -GRAVITY
    u = np.zeros(len(lm.inputs))
    carried = {}
    for p, ref in network.static_loads.items():  # a weight on a point, as a force input
        name = f"{p}.force"
        if name not in lm.inputs:
            raise BodyvibError(
                f"model '{network.name}': static load on '{p}', which takes no force input; "
                "list it in 'force_inputs'"
            )
        carried[name] = -GRAVITY * network.value(ref)
    for name, f in carried.items():
        u[lm.inputs.index(name)] = f
    try:
        x = np.linalg.solve(lm.A, -(g + lm.B @ u))
    except np.linalg.LinAlgError:
        raise BodyvibError(
            f"model '{network.name}': no static equilibrium under gravity (a mass or body "
            "held by dampers only); give every mass a spring path to a base"
        ) from None
    y = lm.C @ x + lm.D @ u
    out = {}
    for el in contacts:
        f = float(y[lm.output_index(f"{el.name}.force")])
        if not f > 1e-9 * GRAVITY * max(network.total_mass(), 1e-300):
            raise BodyvibError(
                f"model '{network.name}': contact '{el.name}' carries no static load "
                f"({f:.3g} N): no mass rests on it under gravity; a contact needs a load "
                "path to gravity (put masses above it, or use a spring)"
            )
        out[el.name] = f
    return out


def linearized(network: Network) -> Network:
    """The network with its nonlinear elements replaced by their linearizations.

    A contact becomes a spring (a kelvin element with its damping), a stop is dropped,
    an asymmetric damper becomes a damper of the mean coefficient; a network without
    nonlinear elements is returned as it is. Its state space equals
    :func:`linear_model` of ``network`` (but for the stops' outputs).

    Parameters
    ----------
    network : Network

    Returns
    -------
    Network
        Linear, without the parameters only the dropped elements and static loads used,
        and without the FMU outputs and named forces of what it dropped (the stops' and
        the contact flags).
    """
    if not network.nonlinear_elements:
        return network
    elements = []
    for el in network.elements:
        v = dict(el.values)
        if el.kind == "contact":
            kind = "kelvin" if "c" in v else "spring"
            elements.append(Element(el.name, kind, el.a, el.b, v))
        elif el.kind == "asymmetric_damper":
            c = 0.5 * (network.value(v["c_compression"]) + network.value(v["c_rebound"]))
            elements.append(Element(el.name, "damper", el.a, el.b, {"c": c}))
        elif el.kind != "stop":
            elements.append(el)
    refs = [r for el in elements for r in el.values.values()] + list(network.masses.values())
    for body in network.bodies.values():
        refs += [body.mass, body.inertia]
        if body.roll_inertia is not None:
            refs.append(body.roll_inertia)
        for place in body.points.values():  # a position, or (x, y[, h]) of a rolling body
            for x in place if isinstance(place, tuple) else (place,):
                refs.append(split_position(x)[2] if isinstance(x, str) else x)
    used = {r for r in refs if isinstance(r, str)}
    stops = {el.name for el in network.elements if el.kind == "stop"}
    kept = tuple(
        o
        for o in network.fmu_outputs
        if o["signal"].rpartition(".")[0] not in stops and not o["signal"].endswith(".contact")
    )
    return replace(
        network,
        elements=tuple(elements),
        fmu_outputs=kept,
        forces={n: e for n, e in network.forces.items() if e not in stops},
        static_loads={},
        parameters={k: v for k, v in network.parameters.items() if k in used},
        units={k: u for k, u in network.units.items() if k in used},
    )


def as_linear_model(model: Union[Network, LinearModel]) -> LinearModel:
    """A model as its state space: a :class:`Network` is assembled, a :class:`LinearModel` kept.

    Parameters
    ----------
    model : Network or LinearModel
        A network (assembled here) or its state space (returned as it is).

    Returns
    -------
    LinearModel
        The state space of ``model``.
    """
    return linear_model(model) if isinstance(model, Network) else model


def mount(carrier: Network, occupant: Network, at: str, prefix: str = "body.") -> Network:
    """Seat an occupant network on a point of a carrier network (two-way coupled).

    The occupant's base becomes the carrier's point ``at``; the occupant's
    points and parameters are renamed with ``prefix``. The result is one
    network driven by the carrier's base: the monolithic form of a coupled
    vehicle-occupant system.

    Parameters
    ----------
    carrier : Network
        The vehicle (its base is the road).
    occupant : Network
        The body model (its base is the seat).
    at : str
        Carrier mass, rigid-body point (or their role) the occupant sits on.
    prefix : str
        Prefix for the occupant's point, element and parameter names.

    Returns
    -------
    Network
    """
    at = carrier.point(at)
    if at not in carrier.masses and at not in carrier.node_names and at not in carrier.body_points:
        raise BodyvibError(f"carrier '{carrier.name}' has no point '{at}' to mount on")

    def rename(p: str) -> str:
        return at if p == occupant.base else prefix + p

    def ref(r: Value) -> Value:
        return prefix + r if isinstance(r, str) else r

    def position(r: Value) -> Value:
        if isinstance(r, str):
            sign, factor, name = split_position(r)
            scale = "" if factor == 1.0 else f"{factor!r}*"
            return ("-" if sign < 0 else "") + scale + prefix + name
        return ref(r)

    def place(r: Union[Value, Tuple[Value, ...]]) -> Union[Value, Tuple[Value, ...]]:
        return tuple(position(q) for q in r) if isinstance(r, tuple) else position(r)

    elements = tuple(
        Element(
            name=prefix + el.name,
            kind=el.kind,
            a=rename(el.a),
            b=rename(el.b),
            values={k: ref(v) for k, v in el.values.items()},
            node=prefix + el.internal_node if el.internal_node else None,
            right=None if el.right is None else (rename(el.right[0]), rename(el.right[1])),
        )
        for el in occupant.elements
    )
    actuated = {p for act in carrier.actuators for p in (act["from"], act["to"])}
    params = dict(carrier.parameters)
    params.update({prefix + k: v for k, v in occupant.parameters.items()})
    masses = dict(carrier.masses)
    masses.update({prefix + m: ref(r) for m, r in occupant.masses.items()})
    roles = dict(carrier.roles)
    roles.update({prefix + r: prefix + p for r, p in occupant.roles.items()})
    units = dict(carrier.units)
    units.update({prefix + k: u for k, u in occupant.units.items()})
    forces = dict(carrier.forces)
    forces.update({prefix + f: prefix + el for f, el in occupant.forces.items()})
    bodies = dict(carrier.bodies)
    bodies.update(
        {
            prefix + b: RigidBody(
                ref(body.mass),
                ref(body.inertia),
                {prefix + p: place(x) for p, x in body.points.items()},
                body.extent,
                None if body.roll_inertia is None else ref(body.roll_inertia),
            )
            for b, body in occupant.bodies.items()
        }
    )
    return Network(
        name=f"{carrier.name}+{occupant.name}",
        parameters=params,
        masses=masses,
        elements=carrier.elements + elements,
        nodes=carrier.nodes + tuple(prefix + n for n in occupant.nodes),
        base=carrier.base,
        # the seat force becomes internal; an actuator at the seat point still drives it
        force_inputs=tuple(m for m in carrier.force_inputs if m != at or m in actuated),
        roles=roles,
        description=f"{occupant.name} seated on {carrier.name} at '{at}'",
        units=units,
        forces=forces,
        bodies=bodies,
        extra_bases=carrier.extra_bases,
        actuators=carrier.actuators,
        static_loads={p: m for p, m in carrier.static_loads.items() if p != at},
    )
