"""The regimes of a nonlinear network as data for the native C core (``bodyvib_regimes.c``).

A network with contacts, stops or asymmetric dampers
(:data:`bodyvib.runtime.network.NONLINEAR_KINDS`) is linear within each regime
(:mod:`bodyvib.runtime.regimes`). The C core assembles every regime from the same
stencils as the linear model: each nonlinear element is written as a linear element
whose stiffness, damping and constant force are *pseudo-parameters* the core sets per
regime (the element's own values engaged, 0 free; a stop's ``-k gap`` or ``+k gap``
constant; a free contact's ``-F0``):

* ``<el>.k`` and ``<el>.c``: a kelvin element (a damper for an asymmetric damper)
  between the element's points, in the descriptor form's stencils;
* ``<el>.f``: the element's constant force (compression-positive), as stencils of the
  equations' constant term (matrix code 6) and of the outputs' constant (code 7).

The pseudo-parameters of each element are placed in the stencil order right after the
element's own stiffness (damping) parameter, where the linearized model has its
stencils: the regime in which the contacts are engaged and the stops free assembles to
the linearized model's matrices bit for bit (its pseudo values are the linearized
element's), so a run that never switches is the linear run bit for bit.

The switching functions are built by the core from the element's points' position and
velocity rows (the linear model's output rows, or a base's inputs), its parameters, and
the contacts' static preloads, which the core solves from gravity on every mass (and the
network's static loads) whenever the parameters change.
"""

from dataclasses import dataclass, replace
from typing import Dict, List, Sequence, Tuple

import numpy as np

from ..runtime.errors import BodyvibError
from ..runtime.network import GRAVITY, Element, Network, _descriptor, split_position

__all__ = ["RegimeData", "KIND_CODES", "regime_data", "constant_stencils", "c_regime_lines"]

#: Nonlinear kind -> its code in the C core (bodyvib_core.h, BV_NL_*).
KIND_CODES = {"contact": 0, "stop": 1, "asymmetric_damper": 2}

#: Matrix codes of the constant terms' stencils (bodyvib_core.h: BV_EC, BV_DC).
EC, DC = 6, 7


def _pseudo(el: Element, what: str) -> str:
    return f"{el.name}.{what}"


@dataclass(frozen=True)
class RegimeData:
    """What the C core needs to form a nonlinear network's regimes.

    Attributes
    ----------
    network : Network
        The network whose stencils the core assembles: each nonlinear element as a
        linear one of pseudo-parameters (module docstring).
    order : tuple of str
        The stencils' parameter order: the FMU parameters with the pseudo-parameters
        inserted after each element's own.
    pseudo : tuple of str
        The pseudo-parameters, three per element (``k``, ``c``, ``f``): the core's
        parameters ``np .. np + 3 ne - 1``.
    elements : tuple of tuple
        Per element: kind code, parameter indices of ``k``, ``c``, ``gap_compression``,
        ``gap_rebound``, ``c_compression``, ``c_rebound`` (-1: none).
    points : tuple of tuple of str
        Per element: the output signals (or base inputs) of ``from.x``, ``from.v``,
        ``to.x``, ``to.v``.
    grav : (n,) ndarray
        Gravity on the state derivative (-g on every mass's and body's velocity).
    loads : tuple of (str, int, float)
        Static loads: model input, parameter index (-1: none) and value (kg).
    """

    network: Network
    order: Tuple[str, ...]
    pseudo: Tuple[str, ...]
    elements: Tuple[Tuple[int, ...], ...]
    points: Tuple[Tuple[str, ...], ...]
    grav: np.ndarray
    loads: Tuple[Tuple[str, int, float], ...]


def _linear_values(network: Network, el: Element) -> Tuple[float, float]:
    """The pseudo ``k``, ``c`` of the linearized element (the regime the run starts in)."""
    v = {p: network.value(r) for p, r in el.values.items()}
    if el.kind == "contact":
        return v["k"], v.get("c", 0.0)
    if el.kind == "asymmetric_damper":
        return 0.0, 0.5 * (v["c_compression"] + v["c_rebound"])
    return 0.0, 0.0


def regime_data(network: Network, params: Sequence[str], states: Sequence[str]) -> RegimeData:
    """The regimes of ``network`` as the C core assembles them.

    Parameters
    ----------
    network : Network
        A network with nonlinear elements.
    params : sequence of str
        The FMU's parameters, in their order.
    states : sequence of str
        The state names of its linear model (gravity acts on the ``.v`` of masses and bodies).

    Returns
    -------
    RegimeData

    Raises
    ------
    BodyvibError
        A nonlinear element whose values are not the FMU's parameters.
    """
    order = list(params)
    values = dict(network.parameters)
    elements, new_elements, table, points, pseudo = [], [], [], [], []

    def index(ref: object) -> int:
        return params.index(ref) if isinstance(ref, str) and ref in params else -1

    for el in network.elements:
        if el.kind not in KIND_CODES:
            new_elements.append(el)
            continue
        names = [_pseudo(el, w) for w in ("k", "c", "f")]
        pseudo += names
        k0, c0 = _linear_values(network, el)
        values.update({names[0]: k0, names[1]: c0, names[2]: 0.0})
        # the pseudo stiffness after the element's own (damping after its damping)
        anchor_k = el.values.get("k", el.values.get("c_compression"))
        anchor_c = el.values.get("c", el.values.get("c_rebound", anchor_k))
        for name, anchor in ((names[0], anchor_k), (names[1], anchor_c)):
            at = (
                order.index(anchor) + 1
                if isinstance(anchor, str) and anchor in order
                else len(order)
            )
            order.insert(at, name)
        order.append(names[2])
        if el.kind == "asymmetric_damper":
            new_elements.append(Element(el.name, "damper", el.a, el.b, {"c": names[1]}))
        else:
            new_elements.append(
                Element(el.name, "kelvin", el.a, el.b, {"k": names[0], "c": names[1]})
            )
        v = el.values
        table.append(
            (KIND_CODES[el.kind],)
            + tuple(index(v.get(p)) for p in ("k", "c", "gap_compression", "gap_rebound"))
            + tuple(index(v.get(p)) for p in ("c_compression", "c_rebound"))
        )
        points.append(tuple(_point(network, p, q) for p in (el.a, el.b) for q in ("x", "v")))
        elements.append(el)
    rn = replace(network, elements=tuple(new_elements), parameters=values)
    grav = np.zeros(len(states))
    for m in list(network.masses) + list(network.bodies):
        grav[list(states).index(f"{m}.v")] = -GRAVITY
    loads = tuple(
        (f"{p}.force", index(ref), float(network.value(ref)))
        for p, ref in network.static_loads.items()
    )
    return RegimeData(rn, tuple(order), tuple(pseudo), tuple(table), tuple(points), grav, loads)


def _point(network: Network, point: str, q: str) -> str:
    if point in network.bases:
        return f"{point}_{'displacement' if q == 'x' else 'velocity'}"
    return f"{point}.{q}"


def constant_stencils(
    rd: RegimeData, rows: Sequence[int], col: Dict[str, int]
) -> List[Tuple[int, int, int, int, int, int, float]]:
    """Stencils of each element's constant force per newton: the equations' constant term
    (code 6, row = equation) and the carried outputs' constants (code 7, row = carried row).

    They are linear in the rigid bodies' point positions (a force at ``x`` has the pitch
    moment ``x F``): read off at every position 0, then each at 1, and checked to give back
    the constants at the actual values. ``col`` maps parameter names to the core's indices.
    """
    net = rd.network
    positions = sorted(
        {
            split_position(ref)[2]
            for body in net.bodies.values()
            for place in body.points.values()
            for ref in (place if isinstance(place, tuple) else (place,))
            if isinstance(ref, str)
        }
    )
    out = []
    for el in net.elements:
        f_name = _pseudo(el, "f")
        if f_name not in col:
            continue

        def consts(geom: Dict[str, float], el: Element = el) -> Tuple[np.ndarray, np.ndarray]:
            free = Element(el.name, "contact", el.a, el.b, {"k": _pseudo(el, "k")})
            elements = tuple(free if e.name == el.name else e for e in net.elements)
            n2 = replace(net, elements=elements).with_parameters(**geom)
            _, e, d0 = _descriptor(n2, {el.name: "free"}, {el.name: -1.0})  # c0 = +1
            return e, d0[list(rows)]

        zero = {p: 0.0 for p in positions}
        base = consts(zero)
        terms = [(-1, base)] + [
            (col[p], tuple(a - b for a, b in zip(consts({**zero, p: 1.0}), base)))
            for p in positions
        ]
        actual = consts({})
        for code, k in ((EC, 0), (DC, 1)):
            total = np.zeros_like(actual[k])
            for j, parts in terms:
                vec = parts[k]
                scale = (
                    1.0
                    if j < 0
                    else float(net.parameters[positions[[col[p] for p in positions].index(j)]])
                )
                total = total + scale * vec
                for r in np.flatnonzero(vec):
                    out.append((j, col[f_name], -1, code, int(r), 0, float(vec[r])))
            if np.max(np.abs(total - actual[k]), initial=0.0) > 1e-12 * max(
                1.0, np.max(np.abs(actual[k]), initial=0.0)
            ):
                raise BodyvibError(
                    f"model '{net.name}': element '{el.name}''s constant force is not "
                    "linear in the point positions as the native FMU assembles it"
                )
    return out


def c_regime_lines(
    rd: RegimeData,
    out_flags: Sequence[int],
    point_rows: Sequence[Sequence[int]],
    inputs: Sequence[str],
) -> List[str]:
    """The C definitions of the regime data (``nl``, ``grav``, ``loads``, ``out_flag``)."""

    def ints(v: Sequence[int]) -> str:
        return ", ".join(str(int(x)) for x in v) or "0"

    lines = ["static const bv_nl_element nl[] = {"]
    for t, pr in zip(rd.elements, point_rows):
        lines.append(f"    {{{ints(t)}, {{{ints(pr)}}}}},")
    lines.append("};")
    lines.append(
        "static const double grav[] = {"
        + (", ".join(repr(float(g)) for g in rd.grav) or "0.0")
        + "};"
    )
    loads = [f"{{{inputs.index(i)}, {j}, {v!r}}}" for i, j, v in rd.loads]
    lines.append("static const bv_load loads[] = {" + (", ".join(loads) or "{0, -1, 0.0}") + "};")
    lines.append(f"static const int out_flag[] = {{{ints(out_flags)}}};")
    return lines
