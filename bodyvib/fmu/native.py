"""Build native (C) FMUs (``python build_fmu.py --native``, ``bodyvib build --native``).

The same models and the same FMU contract as the pythonfmu FMUs
(:func:`bodyvib.fmu.pythonfmu.build_fmu`), written as C that needs nothing on the host beyond
libc and libm. No C is written per model:

* the C sources in ``fmu_src/native/`` are model-independent: one core (linear
  algebra and the Pade(13) exponential in ``bodyvib_linalg.c``, assembly and
  discretization in ``bodyvib_assembly.c``, snapshots in ``bodyvib_state.c``, exact
  stepping and the calls the FMI functions make in ``bodyvib_core.c``) and thin FMI
  2.0 / 3.0 function files;
* this module emits the model as data (``bodyvib_model.c``): the descriptor form
  of :func:`bodyvib.runtime.network.descriptor_model`, whose matrices are affine in the
  parameters (quadratic in a rigid body's point positions), as sparse stencils of
  monomials (the builder evaluated with one
  parameter at 1 and the others at 0), plus the FMU contract of
  :class:`bodyvib.runtime.engine.FmuCore` (variable names, value references, units,
  input map, rate pairs, output rows).

Every FMU offers co-simulation and Model Exchange from the same binary: the continuous
states of ``x' = A x + B U s`` and their derivatives are generated as local variables after
the contract's (the contract itself is unchanged), with ``ModelStructure`` derivatives and
dependencies, and exact directional derivatives (rows of ``A``, ``B U`` and the outputs).

An output whose contract signal is ``RATE_PREFIX + signal`` is the exact time
derivative of that model output (``seat_force_rate``: ``C_sf (A x + B u) + D_sf du``);
the C core gives it the rows ``C A`` and ``C B U + D U R``.

Each FMU holds ``binaries/linux64`` (gcc) and ``binaries/win64`` (mingw-w64)
for FMI 2.0, ``binaries/x86_64-linux`` and ``binaries/x86_64-windows`` for FMI
3.0, ``sources/`` (with ``buildDescription.xml`` for FMI 3.0) so that ``fmpy
compile`` builds it elsewhere, and ``resources/bodyvib_model.json``. Every FMU
is checked with ``fmpy validate`` before it replaces the previous file.

Build-time needs: gcc, x86_64-w64-mingw32-gcc, fmpy (its FMI headers).
"""

import hashlib
import io
import json
import os
import shutil
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Dict, Iterable, List, Optional, Sequence, Tuple, Union
from xml.etree import ElementTree as ET

import numpy as np

from .. import __version__
from ..process import interrupts
from ..process.outputs import atomic_write_bytes
from ..runtime.contract import RATE_PREFIX, Variable
from ..runtime.engine import FmuCore
from ..runtime.errors import BodyvibError
from ..runtime.network import (
    LinearModel,
    Network,
    descriptor_model,
    linearized,
    split_position,
)
from .contents import model_resources, native_dir
from .description import (
    MODEL_STOP_TIME,
    InterfaceElement,
    ModelDescription,
    describe_fmu,
    validate_fmu_file,
    write_model_description,
)
from .native_regimes import RegimeData, c_regime_lines, constant_stencils, regime_data

__all__ = [
    "NATIVE_SOURCES",
    "PLATFORMS",
    "PlatformChoice",
    "choose_platforms",
    "NativeModel",
    "native_model",
    "c_variable_lines",
    "model_source",
    "native_description",
    "model_description",
    "build_description",
    "build_native_fmu",
    "package_native_fmu",
    "package_c_fmu",
    "fmi_headers",
]


#: The model-independent C sources and the FMI function file of each FMI version.
#: The FMI state machine both cores share (bodyvib_fsm.c) is compiled into every native FMU;
#: the linear core is split by subject: linear algebra and the matrix exponential
#: (bodyvib_linalg.c), model assembly (bodyvib_assembly.c), state serialization
#: (bodyvib_state.c) and the calls the FMI functions make (bodyvib_core.c).
NATIVE_SOURCES = (
    "bodyvib_core.h",
    "bodyvib_fsm.h",
    "bodyvib_fsm.c",
    "bodyvib_linalg.h",
    "bodyvib_linalg.c",
    "bodyvib_instance.h",
    "bodyvib_regimes.h",
    "bodyvib_regimes_hot.h",
    "bodyvib_regimes.c",
    "bodyvib_assembly.c",
    "bodyvib_state.c",
    "bodyvib_core.c",
    "bodyvib_calls.h",
    "bodyvib_calls.c",
)
#: The core of a source FMU (a table, bodyvib_table.c) in place of the linear one: the same API.
SOURCE_SOURCES = (
    "bodyvib_core.h",
    "bodyvib_fsm.h",
    "bodyvib_fsm.c",
    "bodyvib_table.h",
    "bodyvib_table.c",
    "bodyvib_calls.h",
    "bodyvib_calls.c",
)
FMI_FILES = {2: "fmi2Functions.c", 3: "fmi3Functions.c"}
FMI_HEADERS = {
    2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
    3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h"),
}
MODEL_C = "bodyvib_model.c"

#: Platform -> (compiler, flags, binary suffix, FMI 2.0 folder, FMI 3.0 folder).
PLATFORMS = {
    "linux64": (
        "gcc",
        ["-fPIC", "-fvisibility=hidden", "-Wl,--no-undefined"],
        ".so",
        "linux64",
        "x86_64-linux",
    ),
    "win64": ("x86_64-w64-mingw32-gcc", ["-static-libgcc"], ".dll", "win64", "x86_64-windows"),
}
#: Flags of every platform. ``-flto``: the FMI wrappers, the shared calls and the core inline
#: into one function per FMI call, and the model's sizes are constants on the step's hot path
#: (bodyvib_core.c reads them from the binary's own model); ``-flto-partition=one`` keeps
#: the whole FMU one unit for that (and spares mingw's note on serial LTRANS jobs).
#: benchmarks/bench_native_step.py
#: compiles its plain loop with the same code-generation flags.
COMMON_FLAGS = [
    "-std=c99",
    "-O2",
    "-flto",
    "-flto-partition=one",
    "-shared",
    "-Wall",
    "-Wextra",
    "-Wno-unused-parameter",
]

#: Output derivative orders fmi2GetRealOutputDerivatives / fmi3GetOutputDerivatives give
#: (bodyvib_core.h, BV_MAX_OUTPUT_ORDER).
MAX_OUTPUT_DERIVATIVE_ORDER = 2

#: The log categories the native core logs under (fmi2SetDebugLogging / fmi3SetDebugLogging).
LOG_CATEGORIES = (
    ("logStatusWarning", "warnings (unconnected velocity input)"),
    ("logStatusError", "errors (refused steps, parameters, states)"),
)

#: Platform -> Debian package of its compiler (what the message on a missing one names).
COMPILER_PACKAGES = {"linux64": "gcc", "win64": "gcc-mingw-w64-x86-64"}

#: Matrix codes of the stencils (bodyvib_core.h: BV_E .. BV_D).
_MATRICES = ("E", "A", "B", "C", "Cd", "D")

#: A monomial in the parameters: the indices of its factors (``()``: the constant term).
Monomial = Tuple[int, ...]
#: One stencil entry: the monomial's parameter indices j1, j2, j3 (-1: none), the matrix
#: code, row, column and coefficient.
Stencil = Tuple[int, int, int, int, int, int, float]


@dataclass(frozen=True)
class NativeModel:
    """Everything the C core needs for one FMU, from the Python contract and the network.

    Attributes
    ----------
    name : str
        FMU model name (``modelName``, ``modelIdentifier``: the binaries' file name).
    kind : {"body", "car", "source"}
        The contract's FMU kind (:data:`bodyvib.runtime.contract.KINDS`).
    description : str
        One-line description of the FMU.
    network : Network or None
    variables : tuple of Variable
        By value reference.
    kinds : tuple of int
        Per value reference: 0 input, 1 output, 2 parameter.
    index : tuple of int
        Per value reference: index among the inputs, outputs or parameters.
    inputs, outputs, parameters : tuple of int
        Value references of each group, in order.
    input_map : (m, ni) ndarray
        Model inputs from FMU inputs.
    rate_matrix : (ni, ni) ndarray
        In-step rates of the FMU inputs, ``ds/dt = R s`` (the contract's rate pairs).
    pairs : tuple of (int, int, bool)
        The contract's unconnected-velocity pairs (displacement, velocity, True).
    out_row : tuple of int
        Per FMU output: the model output row (index into ``rows``).
    out_derivative : tuple of bool
        Per FMU output: it is the time derivative of that row.
    rows : tuple of int
        Model output indices (of the network's outputs) carried into C.
    stencils : list of (int, int, int, int, int, int, float)
        ``(parameter, parameter, parameter, matrix, row, col, coefficient)``: the entry
        adds the coefficient times the product of the parameters (-1: none).
    n, m : int
        States, model inputs.
    dependencies : tuple of tuple of int
        Per FMU output: the input value references it depends on directly.
    states : tuple of str
        Names of the continuous states x (model exchange), in the core's order.
    output_state_deps : tuple of tuple of int
        Per FMU output: the states (indices) it depends on.
    derivative_deps : tuple of (tuple of int, tuple of int)
        Per state: the states (indices) and the input value references its
        derivative ``(A x + B U s)_i`` depends on.
    stop_time : float
        The DefaultExperiment's stop time, s.
    regimes : RegimeData or None
        A nonlinear network's regimes (:mod:`bodyvib.fmu.native_regimes`); None: linear.
    out_flag : tuple of int
        Per FMU output: the nonlinear element whose contact flag it is, or -1.
    point_rows : tuple of tuple of int
        Per nonlinear element: its points' position and velocity rows (``from.x``,
        ``from.v``, ``to.x``, ``to.v``): an index into ``rows``, or ``-1 - i`` for
        model input ``i`` (a base).
    """

    name: str
    kind: str
    description: str
    network: Optional[Network]
    variables: Tuple[Variable, ...]
    kinds: Tuple[int, ...]
    index: Tuple[int, ...]
    inputs: Tuple[int, ...]
    outputs: Tuple[int, ...]
    parameters: Tuple[int, ...]
    input_map: np.ndarray
    rate_matrix: np.ndarray
    pairs: Tuple[Tuple[int, int, bool], ...]
    out_row: Tuple[int, ...]
    out_derivative: Tuple[bool, ...]
    rows: Tuple[int, ...]
    stencils: List[Tuple[int, int, int, int, int, int, float]]
    n: int
    m: int
    dependencies: Tuple[Tuple[int, ...], ...]
    states: Tuple[str, ...] = ()
    output_state_deps: Tuple[Tuple[int, ...], ...] = ()
    derivative_deps: Tuple[Tuple[Tuple[int, ...], Tuple[int, ...]], ...] = ()
    stop_time: float = MODEL_STOP_TIME
    regimes: Optional[RegimeData] = None
    out_flag: Tuple[int, ...] = ()
    point_rows: Tuple[Tuple[int, ...], ...] = ()


@dataclass(frozen=True)
class PlatformChoice:
    """The platforms a native build compiles and the ones it leaves out.

    Attributes
    ----------
    platforms : tuple of str
        Keys of :data:`PLATFORMS` to build, in their order there.
    skipped : tuple of str
        One line per platform left out: which compiler is missing and how to get it.
    """

    platforms: Tuple[str, ...]
    skipped: Tuple[str, ...]


def _missing_compiler(platform: str) -> str:
    compiler = PLATFORMS[platform][0]
    return (
        f"{compiler} not found on PATH; install it (Debian: apt-get install "
        f"{COMPILER_PACKAGES[platform]})"
    )


def choose_platforms(requested: Optional[Iterable[str]] = None) -> PlatformChoice:
    """The platforms to compile: those asked for, or by default every one this machine can.

    Parameters
    ----------
    requested : str or iterable of str, optional
        Platform names (``"linux64,win64"`` or a list); None: every platform of
        :data:`PLATFORMS` whose compiler is on ``PATH``, the others reported as skipped.

    Returns
    -------
    PlatformChoice

    Raises
    ------
    BodyvibError
        An unknown platform, a requested platform whose compiler is missing, or (by
        default) no compiler at all.

    Examples
    --------
    >>> choose_platforms("linux64").platforms  # doctest: +SKIP
    ('linux64',)
    """
    if requested is not None:
        names = [
            p.strip()
            for p in (requested.split(",") if isinstance(requested, str) else requested)
            if p.strip()
        ]
        unknown = [p for p in names if p not in PLATFORMS]
        if unknown or not names:
            raise BodyvibError(
                f"'platforms': unknown platform {', '.join(unknown) or '(none)'};"
                f" choose among {', '.join(PLATFORMS)} (comma-separated)",
                parameters=("platforms",),
            )
        for p in names:
            if shutil.which(PLATFORMS[p][0]) is None:
                others = [q for q in names if q != p]
                raise BodyvibError(
                    f"{p}: {_missing_compiler(p)}, or leave it out (platforms="
                    f"{','.join(others) or 'another platform'})",
                    parameters=("platforms",),
                )
        return PlatformChoice(tuple(p for p in PLATFORMS if p in names), ())
    have = tuple(p for p in PLATFORMS if shutil.which(PLATFORMS[p][0]) is not None)
    if not have:
        raise BodyvibError(
            "no C compiler for any platform: "
            + "; ".join(f"{p}: {_missing_compiler(p)}" for p in PLATFORMS)
        )
    skipped = tuple(
        f"{p} skipped: {_missing_compiler(p)}, or pass platforms="
        f"{','.join(have)} to build without it"
        for p in PLATFORMS
        if p not in have
    )
    return PlatformChoice(have, skipped)


def _stencils(network: Network, params: Sequence[str], rows: Sequence[int]) -> List[Stencil]:
    """Stencils of the descriptor form, monomials in the parameters; checked to reproduce it.

    Every entry is ``c_0(G) + sum_a a c_a(G)``: affine in the masses, inertias,
    stiffnesses and dampings ``a``, and a polynomial of degree at most two in the
    rigid-body point positions ``G`` (a spring between two points pulls with ``k`` times
    their positions). Each ``c(G)`` is read off by evaluating the builder at ``G`` in
    ``{0, e_i, -e_i, e_i + e_j}`` (exact differences of numbers formed from 0 and 1).
    A network without rigid bodies has no ``G``: one evaluation per parameter, as an
    affine model needs.
    """
    positions = {
        split_position(ref)[2]
        for body in network.bodies.values()
        for place in body.points.values()
        for ref in (place if isinstance(place, tuple) else (place,))
        if isinstance(ref, str)
    }
    geometry = [j for j, p in enumerate(params) if p in positions]
    linear = [j for j, p in enumerate(params) if p not in positions]

    def mats(values: Sequence[float]) -> List[np.ndarray]:
        dm = descriptor_model(network.with_parameters(**dict(zip(params, values))))
        return [dm.E, dm.A, dm.B, dm.C[list(rows)], dm.Cd[list(rows)], dm.D[list(rows)]]

    def at(a: Optional[int], g: Dict[int, float]) -> List[np.ndarray]:
        # parameter a (or none) at 1, the geometry at g, every other parameter 0
        values = [0.0] * len(params)
        if a is not None:
            values[a] = 1.0
        for j, x in g.items():
            values[j] = x
        return mats(values)

    def diff(x: Sequence[np.ndarray], y: Sequence[np.ndarray]) -> List[np.ndarray]:
        return [p - q for p, q in zip(x, y)]

    def coefficients(a: Optional[int]) -> Dict[Monomial, List[np.ndarray]]:
        """Monomial (tuple of parameter indices) -> matrices, of c_a(G) (with c_0 removed)."""
        q: Dict[Monomial, List[np.ndarray]] = {(): at(a, {})}
        for i in geometry:
            q[(i,)], q[(-i - 1,)] = at(a, {i: 1.0}), at(a, {i: -1.0})
        for i, j in ((i, j) for i in geometry for j in geometry if i < j):
            q[(i, j, 0)] = at(a, {i: 1.0, j: 1.0})
        out: Dict[Monomial, List[np.ndarray]] = {(): q[()]}
        for i in geometry:
            out[(i,)] = [0.5 * (p - m) for p, m in zip(q[(i,)], q[(-i - 1,)])]
            out[(i, i)] = [0.5 * (p + m) - c for p, m, c in zip(q[(i,)], q[(-i - 1,)], q[()])]
        for i, j in ((i, j) for i in geometry for j in geometry if i < j):
            out[(i, j)] = [
                s - p - r + c for s, p, r, c in zip(q[(i, j, 0)], q[(i,)], q[(j,)], q[()])
            ]
        return out

    constant = coefficients(None)
    parts: List[Tuple[Monomial, Dict[Monomial, List[np.ndarray]]]] = [((), constant)]
    for a in linear:
        with_a = coefficients(a)
        parts.append(((a,), {mono: diff(with_a[mono], constant[mono]) for mono in with_a}))
    out: List[Stencil] = []
    for factor, monomials in parts:
        for mono, ms in monomials.items():
            powers = list(factor + mono) + [-1, -1, -1]
            j1, j2, j3 = powers[:3]
            for code, M in enumerate(ms):
                for r, c in zip(*np.nonzero(M)):
                    out.append((j1, j2, j3, code, int(r), int(c), float(M[r, c])))
    # the stencils must give back the descriptor form at the actual parameter values
    values = [float(network.parameters[p]) for p in params]
    actual = mats(values)
    for code, M in enumerate(actual):
        S = np.zeros_like(M)
        for j1, j2, j3, k, r, c, v in out:
            if k == code:
                S[r, c] += v * np.prod([values[j] for j in (j1, j2, j3) if j >= 0])
        scale = max(np.max(np.abs(M)), 1.0) if M.size else 1.0
        if M.size and np.max(np.abs(S - M)) > 1e-14 * scale:
            raise BodyvibError(
                f"model '{network.name}': its {_MATRICES[code]} matrix is not a polynomial "
                "of the form the native FMU assembles (affine in masses, stiffnesses and "
                "dampings, quadratic in point positions)"
            )
    return out


def native_model(kind: str, network: Network, name: str, description: str = "") -> NativeModel:
    """The C core's view of one FMU, read off the Python FMU contract.

    Parameters
    ----------
    kind : str
        ``"body"`` or ``"car"`` (:data:`bodyvib.runtime.contract.KINDS`).
    network : Network
        The model baked in.
    name : str
        FMU model name.
    description : str
        One-line description of the FMU.

    Returns
    -------
    NativeModel

    Raises
    ------
    BodyvibError
        A model the FMU contract refuses (missing roles, invalid parameters).
    """
    core = FmuCore(kind, network, name)
    core.check_parameters()
    iface = core.interface
    variables = list(core.variables)
    ni, no = len(iface.inputs), len(iface.outputs)
    par_vrs = tuple(vr for vr, v in enumerate(variables) if v.causality == "parameter")
    params = [variables[vr].name for vr in par_vrs]
    rd = None
    if network.nonlinear_elements:
        rd = regime_data(network, params, descriptor_model(linearized(network)).states)
    lm = descriptor_model(rd.network if rd else network).solve()
    derivative = [sig.startswith(RATE_PREFIX) for sig in iface.output_signals]
    names = [el.name for el in network.nonlinear_elements]
    # a contact's flag (<contact>.contact) is the regime's constant, on no row
    flags = [
        names.index(sig[: -len(".contact")]) if sig.endswith(".contact") else -1
        for sig in iface.output_signals
    ]
    signals = [
        0 if f >= 0 else lm.output_index(sig[len(RATE_PREFIX) :] if d else sig)
        for sig, d, f in zip(iface.output_signals, derivative, flags)
    ]
    out_vrs = list(range(ni, ni + no))
    probes = [p for pts in (rd.points if rd else ()) for p in pts if p not in lm.inputs]
    rows = tuple(dict.fromkeys(signals + [lm.output_index(p) for p in probes]))
    kinds, index = [0] * len(variables), [0] * len(variables)
    in_vrs = tuple(range(ni))
    for i, vr in enumerate(in_vrs):
        kinds[vr], index[vr] = 0, i
    for i, vr in enumerate(out_vrs):
        kinds[vr], index[vr] = 1, i
    for i, vr in enumerate(par_vrs):
        kinds[vr], index[vr] = 2, i
    pairs = [(i, j, True) for i, j in iface.slope_fallback]
    stencils = (
        _stencils(network, params, rows) if rd is None else _regime_stencils(rd, params, rows)
    )
    # direct dependencies (feedthrough): the core's, as the pythonfmu FMU declares them
    U = iface.input_map
    R = iface.rate_matrix()
    deps = [tuple(in_vrs[i] for i in d) for d in core.output_dependencies()]
    out_state, der_deps = _state_dependencies(
        lm if rd is None else rd, (signals, derivative, flags), U
    )
    return NativeModel(
        name=name,
        kind=kind,
        description=description,
        network=network,
        variables=tuple(variables),
        kinds=tuple(kinds),
        index=tuple(index),
        inputs=in_vrs,
        outputs=tuple(out_vrs),
        parameters=par_vrs,
        input_map=U,
        rate_matrix=R,
        pairs=tuple(pairs),
        out_row=tuple(rows.index(s) for s in signals),
        out_derivative=tuple(derivative),
        rows=rows,
        stencils=stencils,
        n=lm.A.shape[0],
        m=lm.B.shape[1],
        dependencies=tuple(deps),
        states=tuple(lm.states),
        output_state_deps=out_state,
        derivative_deps=der_deps,
        regimes=rd,
        out_flag=tuple(flags),
        point_rows=_point_rows(rd, lm, rows),
    )


def _point_rows(rd: Optional[RegimeData], lm: LinearModel, rows: Sequence[int]) -> tuple:
    """Per nonlinear element, its points' rows: an index into ``rows``, or ``-1 - i`` for
    model input ``i`` (a base)."""
    return tuple(
        tuple(
            -1 - lm.inputs.index(p) if p in lm.inputs else list(rows).index(lm.output_index(p))
            for p in pts
        )
        for pts in (rd.points if rd else ())
    )


def _state_dependencies(
    model: Union[LinearModel, RegimeData], outputs: tuple, U: np.ndarray
) -> Tuple[tuple, tuple]:
    """Model exchange: the states each output depends on, and the states and input value
    references each derivative ``A x + B U s`` depends on. Of a nonlinear model
    (``RegimeData``), what any regime's depend on (every element engaged); a contact flag
    depends on nothing. ``outputs`` is ``(rows, is_derivative, flag)`` per output."""
    if isinstance(model, RegimeData):
        engaged = {p: 1.0 for p in model.pseudo}
        dm = descriptor_model(model.network.with_parameters(**engaged)).solve()
    else:
        dm = model
    rows = [
        0 * dm.C[0] if f >= 0 else dm.C[r] @ dm.A if d else dm.C[r] for r, d, f in zip(*outputs)
    ]
    BU = dm.B @ U
    der_deps = tuple(
        (
            tuple(int(j) for j in np.nonzero(dm.A[i])[0]),
            tuple(j for j in range(U.shape[1]) if BU[i, j] != 0.0),
        )
        for i in range(dm.A.shape[0])
    )
    return tuple(tuple(int(j) for j in np.nonzero(row)[0]) for row in rows), der_deps


def _regime_stencils(rd: RegimeData, params: Sequence[str], rows: Sequence[int]) -> List[Stencil]:
    """The stencils of a nonlinear network's regimes (:mod:`bodyvib.fmu.native_regimes`): in
    the order the pseudo-parameters take, indexed as the core holds them (the FMU's
    parameters, then three pseudo-parameters per nonlinear element)."""
    col = {p: j for j, p in enumerate(params)}
    col.update({p: len(params) + j for j, p in enumerate(rd.pseudo)})
    raw = _stencils(rd.network, rd.order, rows)

    def at(j: int) -> int:
        return -1 if j < 0 else col[rd.order[j]]

    out = [(at(a), at(b), at(c), k, r, q, v) for a, b, c, k, r, q, v in raw]
    return out + constant_stencils(rd, rows, col)


def _c_string(text: str) -> str:
    return json.dumps(text, ensure_ascii=True)  # a valid C string literal for ASCII text


def _parameter_start(variable: Variable) -> float:
    """The start value of a parameter (the contract gives every parameter one)."""
    if variable.start is None:
        raise BodyvibError(f"parameter {variable.name!r} has no start value to bake into the FMU")
    return variable.start


def _c_doubles(values: Iterable[float]) -> str:
    return ", ".join(repr(float(v)) for v in values) or "0.0"


def _c_ints(values: Iterable[int]) -> str:
    return ", ".join(str(int(v)) for v in values) or "0"


def c_variable_lines(nm: NativeModel) -> List[str]:
    """The C arrays every native kind's model data starts with (after its ``#include``).

    Parameters
    ----------
    nm : NativeModel

    Returns
    -------
    list of str
        ``vr_kind``, ``vr_index`` and ``vr_name`` by value reference, then
        ``param_unit`` and ``param_start`` by parameter: the names the ``bv_model``
        struct of ``bodyvib_core.h`` and ``bodyvib_table.h`` points at.
    """
    pars = [nm.variables[vr] for vr in nm.parameters]
    return [
        f"static const int vr_kind[] = {{{_c_ints(nm.kinds)}}};",
        f"static const int vr_index[] = {{{_c_ints(nm.index)}}};",
        "static const char *const vr_name[] = {"
        + ", ".join(_c_string(v.name) for v in nm.variables)
        + "};",
        "static const char *const param_unit[] = {"
        + ", ".join(_c_string(p.unit) for p in pars)
        + "};",
        f"static const double param_start[] = {{{_c_doubles(map(_parameter_start, pars))}}};",
    ]


def model_source(nm: NativeModel, token: str) -> str:
    """The generated C file of one FMU (``bodyvib_model.c``): the model as constant data.

    Parameters
    ----------
    nm : NativeModel
    token : str
        GUID / instantiation token.

    Returns
    -------
    str
        C99 source defining ``bv_model_data``.
    """
    lines = [
        f"/* Generated by bodyvib.fmu.native (bodyvib {__version__}) from model "
        f"'{nm.network.name if nm.network is not None else nm.name}': do not edit. */",
        '#include "bodyvib_core.h"',
        "",
        *c_variable_lines(nm),
        f"static const double U[] = {{{_c_doubles(nm.input_map.ravel())}}};",
        f"static const double R[] = {{{_c_doubles(nm.rate_matrix.ravel())}}};",
        "static const bv_pair pairs[] = {"
        + ", ".join(f"{{{i}, {j}, {int(f)}}}" for i, j, f in nm.pairs)
        + "};",
        f"static const int out_row[] = {{{_c_ints(nm.out_row)}}};",
        f"static const int out_derivative[] = {{{_c_ints(nm.out_derivative)}}};",
        "static const bv_stencil stencils[] = {",
    ]
    lines += [
        f"    {{{j1}, {j2}, {j3}, {k}, {r}, {c}, {v!r}}}," for j1, j2, j3, k, r, c, v in nm.stencils
    ]
    lines += ["};"]
    if nm.regimes is not None:
        inputs = descriptor_model(nm.regimes.network).inputs
        lines += c_regime_lines(nm.regimes, nm.out_flag, nm.point_rows, inputs)
    lines += [
        "",
        "const bv_model bv_model_data = {",
        f"    {_c_string(nm.name)}, {_c_string(token)},",
        f"    {nm.n}, {nm.m}, {len(nm.rows)},",
        f"    {len(nm.inputs)}, {len(nm.outputs)}, {len(nm.parameters)}, {len(nm.variables)},",
        "    vr_kind, vr_index, vr_name, param_unit, param_start, U, R,",
        f"    {len(nm.pairs)}, pairs, out_row, out_derivative,",
        f"    {len(nm.stencils)}, stencils,",
    ]
    if nm.regimes is not None:
        lines += [
            f"    {len(nm.regimes.elements)}, nl, grav, {len(nm.regimes.loads)}, loads, out_flag,"
        ]
    else:
        lines += ["    0, 0, 0, 0, 0, 0,"]
    lines += [
        "};",
        "",
    ]
    return "\n".join(lines)


def core_sources(kind: str) -> Tuple[str, ...]:
    """The model-independent C sources an FMU of ``kind`` compiles (its core)."""
    return SOURCE_SOURCES if kind == "source" else NATIVE_SOURCES


def _c_files(nm: NativeModel, fmi: int) -> List[str]:
    return [s for s in core_sources(nm.kind) if s.endswith(".c")] + [MODEL_C, FMI_FILES[fmi]]


# The continuous state x of x' = A x + B U s is exposed for model exchange as local variables
# after the contract's (bodyvib.fmu.description.ModelDescription.state_vr, BV_STATE_VR /
# BV_DER_VR of bodyvib_core.h). In model exchange the host sets the inputs at each time, the
# velocity inputs included: the FMU does not differentiate the displacement;
# seat_acceleration and seat_force_rate enter only the outputs that are exact time
# derivatives (seat_force_rate).


def _interfaces(nm: NativeModel, fmi: int) -> Tuple[InterfaceElement, ...]:
    """Model Exchange and co-simulation from one binary: what the native core offers.

    A source has no states and no inputs (no knowns): no directional derivatives; in model
    exchange its outputs are the table at the time the host sets (``SetTime``).
    """
    directional = "false" if nm.kind == "source" else "true"
    order = str(MAX_OUTPUT_DERIVATIVE_ORDER)
    if fmi == 2:
        common = (
            ("canBeInstantiatedOnlyOncePerProcess", "false"),
            ("canNotUseMemoryManagementFunctions", "true"),
            ("canGetAndSetFMUstate", "true"),
            ("canSerializeFMUstate", "true"),
            ("providesDirectionalDerivative", directional),
        )
        files = tuple(_c_files(nm, fmi))
        return (
            InterfaceElement(
                "ModelExchange",
                (("needsExecutionTool", "false"), ("completedIntegratorStepNotNeeded", "true"))
                + common,
                files,
            ),
            InterfaceElement(
                "CoSimulation",
                (
                    ("needsExecutionTool", "false"),
                    ("canHandleVariableCommunicationStepSize", "true"),
                    ("canInterpolateInputs", "true"),
                    ("maxOutputDerivativeOrder", order),
                    ("canRunAsynchronuously", "false"),
                )
                + common,
                files,
            ),
        )
    common = (
        ("needsExecutionTool", "false"),
        ("canBeInstantiatedOnlyOncePerProcess", "false"),
        ("canGetAndSetFMUState", "true"),
        ("canSerializeFMUState", "true"),
        ("providesDirectionalDerivatives", directional),
    )
    return (
        InterfaceElement(
            "ModelExchange",
            common
            + (
                ("needsCompletedIntegratorStep", "false"),
                ("providesEvaluateDiscreteStates", "false"),
            ),
        ),
        InterfaceElement(
            "CoSimulation",
            common
            + (
                ("canHandleVariableCommunicationStepSize", "true"),
                ("maxOutputDerivativeOrder", order),
                ("hasEventMode", "false"),
                ("providesIntermediateUpdate", "false"),
                ("canReturnEarlyAfterIntermediateUpdate", "false"),
            ),
        ),
    )


def native_description(nm: NativeModel, token: str, fmi: int) -> ModelDescription:
    """What a native FMU's modelDescription.xml declares, read off its :class:`NativeModel`.

    Parameters
    ----------
    nm : NativeModel
        The FMU's interface.
    token : str
        GUID (FMI 2.0) or instantiation token (FMI 3.0): the hash ``_token`` computes.
    fmi : {2, 3}
        FMI version.

    Returns
    -------
    bodyvib.fmu.description.ModelDescription
        Co-simulation and Model Exchange, with the continuous states.
    """
    return ModelDescription(
        fmi=fmi,
        model_name=nm.name,
        model_identifier=nm.name,
        token=token,
        description=describe_fmu(nm.description or nm.name, nm.network),
        generation_tool=f"bodyvib {__version__} native_build",
        variables=nm.variables,
        output_dependencies=nm.dependencies,
        interfaces=_interfaces(nm, fmi),
        log_categories=LOG_CATEGORIES,
        stop_time=nm.stop_time,
        source=nm.kind == "source",
        states=nm.states,
        output_state_dependencies=nm.output_state_deps,
        derivative_dependencies=nm.derivative_deps,
        event_indicators=_switches(nm),
    )


def _switches(nm: NativeModel) -> Tuple[str, ...]:
    """The switching functions' names (``<element>.<side>``), in the core's order."""
    if nm.network is None or nm.regimes is None:
        return ()
    sides = {"contact": ("contact",), "stop": ("compression", "rebound")}
    return tuple(
        f"{el.name}.{side}"
        for el in nm.network.nonlinear_elements
        for side in sides.get(el.kind, ("rate",))
    )


def model_description(nm: NativeModel, token: str, fmi: int) -> bytes:
    """``modelDescription.xml`` of a native FMU.

    Parameters
    ----------
    nm, token, fmi
        As :func:`native_description`.

    Returns
    -------
    bytes
        UTF-8 XML (:func:`bodyvib.fmu.description.write_model_description`).
    """
    return write_model_description(native_description(nm, token, fmi))


def build_description(nm: NativeModel) -> bytes:
    """``sources/buildDescription.xml`` (FMI 3.0): what ``fmpy compile`` compiles."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    bc = ET.SubElement(root, "BuildConfiguration", modelIdentifier=nm.name)
    fs = ET.SubElement(bc, "SourceFileSet", language="C99")
    for s in _c_files(nm, 3):
        ET.SubElement(fs, "SourceFile", name=s)
    ET.indent(root)
    return ET.tostring(root, encoding="UTF-8", xml_declaration=True)


def fmi_headers() -> Path:
    """The folder of the FMI 2.0 / 3.0 C headers (shipped with fmpy)."""
    import fmpy

    folder = Path(fmpy.__file__).resolve().parent / "c-code"
    if not (folder / "fmi3Functions.h").is_file():
        raise BodyvibError(f"the FMI headers are not in {folder}; reinstall fmpy")
    return folder


def _token(model_text: str, core: Sequence[str]) -> str:
    """The instantiation token: a hash of the generated text and every C source it builds with
    (``core`` and the FMI function files, each once)."""
    h = hashlib.sha256(model_text.encode())
    for s in dict.fromkeys(tuple(core) + tuple(FMI_FILES.values())):
        h.update((native_dir() / s).read_bytes())
    d = h.hexdigest()
    return "{" + f"{d[:8]}-{d[8:12]}-{d[12:16]}-{d[16:20]}-{d[20:32]}" + "}"


def _compile(platform: str, src: Path, fmi: int, out: Path, files: Sequence[str]) -> None:
    """Compile the C ``files`` in ``src`` into the binary ``out`` for ``platform``."""
    compiler, flags, _, _, _ = PLATFORMS[platform]
    if shutil.which(compiler) is None:
        raise BodyvibError(
            f"{platform}: {_missing_compiler(platform)}, or build the other "
            "platforms only (platforms=...)",
            parameters=("platforms",),
        )
    cmd = (
        [compiler]
        + COMMON_FLAGS
        + flags
        + [f"-I{src}", "-o", str(out)]
        + [str(src / f) for f in files]
        + ["-lm"]
    )
    # its own process group, killed on a signal; its temporary files in the build's folder
    proc = interrupts.run_process(cmd, scratch=src.parent.parent / "compiler-tmp")
    if proc.returncode != 0 or not out.is_file():
        raise BodyvibError(
            f"{compiler} failed for {out.name} ({platform}, FMI {fmi}.0): "
            + " | ".join((proc.stderr or proc.stdout).strip().splitlines()[-4:])
        )
    if proc.stderr.strip():
        raise BodyvibError(
            f"{compiler} warned for {out.name} ({platform}, FMI {fmi}.0): "
            + " | ".join(proc.stderr.strip().splitlines()[-4:])
        )


def _zip(folder: Path) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                zf.write(path, path.relative_to(folder).as_posix())
    return buf.getvalue()


def build_native_fmu(
    network: Network,
    kind: str,
    name: str,
    description: str,
    dest: Union[str, os.PathLike] = "dist/native",
    fmi: int = 2,
    platforms: Iterable[str] = ("linux64", "win64"),
) -> Path:
    """Build one native FMU of a model (the counterpart of :func:`bodyvib.fmu.pythonfmu.build_fmu`).

    The model goes into the binaries as C data (:func:`model_source`), compiled with
    the model-independent core (:data:`NATIVE_SOURCES`) by :func:`package_native_fmu`.

    Parameters
    ----------
    network, kind, name, description, dest
        As :func:`bodyvib.fmu.pythonfmu.build_fmu`.
    fmi : {2, 3}
        FMI version.
    platforms : iterable of str
        Binaries to compile (:data:`PLATFORMS`).

    Returns
    -------
    Path
        The FMU written, ``dest/<name>.fmu``: FMI ``fmi``.0, co-simulation and Model
        Exchange, binaries for ``platforms`` and its C sources. A model with contacts,
        stops or asymmetric dampers steps its regimes with located events in
        co-simulation (:mod:`bodyvib.fmu.native_regimes`).

    Raises
    ------
    BodyvibError
        A model the FMU kind cannot run, invalid parameters, a compiler missing or
        failing, or an FMU that ``fmpy validate`` finds problems in; the previous
        file at ``dest/<name>.fmu`` is then left as it was.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> build_native_fmu(load_model("reduced-paper"), "body", "HumanBody3DOF", "reduced body",
    ...                  "dist/native/fmi3", fmi=3, platforms=["linux64"])  # doctest: +SKIP
    PosixPath('dist/native/fmi3/HumanBody3DOF.fmu')
    """
    nm = native_model(kind, network, name, description)
    return package_native_fmu(
        nm, lambda token: model_source(nm, token), model_resources(network), dest, fmi, platforms
    )


def package_native_fmu(
    nm: NativeModel,
    model_c: Callable[[str], str],
    resources: Dict[str, bytes],
    dest: Union[str, os.PathLike],
    fmi: int,
    platforms: Iterable[str],
) -> Path:
    """Compile, package, validate and place one native FMU: what every native kind shares.

    Parameters
    ----------
    nm : NativeModel
        The FMU's interface (its model description is written from it).
    model_c : callable
        ``model_c(token)`` -> the text of ``bodyvib_model.c`` (the model as C data),
        given the instantiation token; it is compiled with the core of ``nm.kind``
        (:func:`core_sources`) and the FMI version's wrapper.
    resources : dict of str to bytes
        Files for the FMU's ``resources/`` folder.
    dest, fmi, platforms
        As :func:`build_native_fmu`.

    Returns
    -------
    Path
        As :func:`package_c_fmu`.

    Raises
    ------
    BodyvibError
        An FMI version that does not exist, or what :func:`package_c_fmu` refuses.
    """
    if fmi not in FMI_FILES:
        raise BodyvibError(f"FMI version must be 2 or 3, got {fmi!r}")
    core = core_sources(nm.kind)
    return package_c_fmu(
        nm.name,
        fmi,
        tuple(core) + (FMI_FILES[fmi],),
        lambda token: {MODEL_C: model_c(token)},
        _c_files(nm, fmi),
        lambda token: model_description(nm, token, fmi),
        resources,
        dest,
        platforms,
        f"{nm.name}.fmu (native, FMI {fmi}.0)",
        build_description(nm) if fmi == 3 else None,
    )


def package_c_fmu(
    name: str,
    fmi: int,
    sources: Sequence[str],
    generated: Callable[[str], Dict[str, str]],
    c_files: Sequence[str],
    description: Callable[[str], bytes],
    resources: Dict[str, bytes],
    dest: Union[str, os.PathLike],
    platforms: Iterable[str],
    label: str,
    build_xml: Optional[bytes] = None,
) -> Path:
    """Compile, package, validate and place an FMU from C: the one native build path.

    Parameters
    ----------
    name : str
        Model identifier (the binaries' and the FMU's file name).
    fmi : {2, 3}
        FMI version (the headers copied into ``sources/``, the binaries' folders).
    sources : sequence of str
        Files of ``fmu_src/native`` the FMU ships in ``sources/``.
    generated : callable
        ``generated(token)`` -> generated files (name -> text) for ``sources/``; the
        token is the hash of ``generated("")`` and ``sources``.
    c_files : sequence of str
        The C files (of ``sources/``) compiled into the binary.
    description : callable
        ``description(token)`` -> ``modelDescription.xml``.
    resources : dict of str to bytes
        Files for ``resources/`` (none: no folder).
    dest : str or path
        Output folder.
    platforms : iterable of str
        Binaries to compile (:data:`PLATFORMS`).
    label : str
        How errors name the FMU.
    build_xml : bytes, optional
        ``sources/buildDescription.xml`` (FMI 3.0).

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        A platform that does not exist, a compiler missing, failing or warning, or an
        FMU that ``fmpy validate`` finds problems in (the previous file is kept).
    """
    platforms = list(platforms)
    unknown = [p for p in platforms if p not in PLATFORMS]
    if unknown or not platforms:
        raise BodyvibError(f"platforms must be among {', '.join(PLATFORMS)}, got {platforms}")
    token = _token("".join(generated("").values()), sources)
    headers = fmi_headers()
    with tempfile.TemporaryDirectory(prefix="bodyvib_native_") as tmp:
        stage = Path(tmp) / "fmu"
        src = stage / "sources"
        src.mkdir(parents=True)
        for s in sources:
            shutil.copyfile(native_dir() / s, src / s)
        for h in FMI_HEADERS[fmi]:
            shutil.copyfile(headers / h, src / h)
        for file, text in generated(token).items():
            (src / file).write_text(text, encoding="utf-8")
        if build_xml is not None:
            (src / "buildDescription.xml").write_bytes(build_xml)
        (stage / "modelDescription.xml").write_bytes(description(token))
        if resources:
            (stage / "resources").mkdir()
        for file, data in resources.items():
            (stage / "resources" / file).write_bytes(data)
        for p in platforms:
            _, _, suffix, folder2, folder3 = PLATFORMS[p]
            out = stage / "binaries" / (folder2 if fmi == 2 else folder3) / (name + suffix)
            out.parent.mkdir(parents=True, exist_ok=True)
            _compile(p, src, fmi, out, c_files)
        staged = Path(tmp) / f"{name}.fmu"
        staged.write_bytes(_zip(stage))
        validate_fmu_file(staged, label)
        target = Path(dest) / f"{name}.fmu"
        atomic_write_bytes(target, staged.read_bytes())
    return target
