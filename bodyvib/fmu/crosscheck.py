"""A native body FMU in the FMI cross-check layout, with its exact reference result.

The FMI cross-check (the modelica-tools ``fmi-cross-check`` repository) publishes every
exported FMU in ``fmus/<FMI version>/<cs|me>/<platform>/<tool>/<tool version>/<model>/``
beside the files an importing tool needs to run it and judge its result. The native FMI
2.0 body FMU is both a co-simulation and a model-exchange FMU, so it is published twice,
under ``cs`` and under ``me``, with the same files (the cross-check covers FMI 1.0 and
2.0 only):

* ``<model>.fmu`` -- the FMU (here the native FMI 2.0 body FMU, linux64 binary and sources);
* ``<model>_in.csv`` -- the inputs over time (a seat sine: displacement, velocity and
  acceleration, one row per communication step);
* ``<model>_ref.csv`` -- the reference outputs: here the *exact* response of the model's
  state space to that sine from rest (harmonic part plus the matrix-exponential free
  response), not a run of the FMU;
* ``<model>_ref.opt`` -- start time, stop time, step size and relative tolerance;
* ``<model>_cc.sh`` / ``<model>_cc.bat`` -- the command that made the tree, which run from
  anywhere rebuilds it in place (the tree's root is seven folders above the script);
* ``ReadMe.md`` -- what the FMU is and how the reference was computed.

``fmpy.cross_check.validate_vendor_repo.validate_repo`` checks such a tree.
"""

import math
import os
import shlex
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Dict, Mapping, Sequence, Tuple, Union

import numpy as np
import scipy.linalg

from .. import __version__
from ..process.outputs import atomic_write_bytes, atomic_write_text, staged_source
from ..runtime.contract import KINDS
from ..runtime.errors import BodyvibError
from ..runtime.network import Network, linear_model
from ..runtime.renames import renamed_fields

if TYPE_CHECKING:  # for annotations only
    from numpy.typing import ArrayLike

__all__ = ["CrossCheckSettings", "CrossCheck", "exact_sine_outputs", "write_cross_check"]

#: The exporting tool's name in the layout.
TOOL = "bodyvib"

#: The cross-check's interface folders the FMU is published in: co-simulation, model exchange.
INTERFACES = ("cs", "me")


@renamed_fields(stop_time="duration")
@dataclass(frozen=True)
class CrossCheckSettings:
    """What the cross-check folder runs: a seat sine from rest.

    Parameters
    ----------
    name : str
        The FMU's model name.
    duration : float
        Run length, s (``stop_time`` still works for one release, with a
        ``DeprecationWarning``).
    step : float
        Communication step (and the input table's row spacing), s.
    output_step : float
        Row spacing of the reference, s.
    amplitude : float
        Seat displacement amplitude, m (chosen: 5 mm, a rough road's seat motion).
    frequency : float
        Seat sine frequency, Hz (chosen: 4 Hz, near the body's main resonance).
    rel_tol : float
        Relative tolerance written to the options file.
    """

    name: str = "HumanBody3DOF"
    duration: float = 4.0
    step: float = 1e-3
    output_step: float = 1e-2
    amplitude: float = 5e-3
    frequency: float = 4.0
    rel_tol: float = 1e-6


@dataclass(frozen=True)
class CrossCheck:
    """The files of one cross-check folder.

    Attributes
    ----------
    folder : Path
        ``<dest>/fmus/2.0/cs/linux64/bodyvib/<version>/<name>``.
    fmu, inputs, reference, options, readme : Path
        Its FMU, ``_in.csv``, ``_ref.csv``, ``_ref.opt`` and ``ReadMe.md``.
    outputs : tuple of str
        The output variables of the reference.
    entries : tuple of Path
        Every folder that publishes the FMU: ``folder`` and its ``me`` twin.
    """

    folder: Path
    fmu: Path
    inputs: Path
    reference: Path
    options: Path
    readme: Path
    outputs: Tuple[str, ...]
    entries: Tuple[Path, ...] = ()


def _seat(settings: CrossCheckSettings, t: np.ndarray) -> np.ndarray:
    """Seat displacement, velocity and acceleration of the sine at times t: (n, 3)."""
    a, w = settings.amplitude, 2 * math.pi * settings.frequency
    return np.column_stack([a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t)])


def exact_sine_outputs(
    network: Network, settings: CrossCheckSettings, t: "ArrayLike"
) -> Dict[str, np.ndarray]:
    """The body interface's outputs under the settings' seat sine from rest, exactly.

    The state space ``x' = A x + B u`` is driven by ``u = U s`` with ``s`` the seat sine:
    ``x(t) = Re(X e^{iwt}) + e^{At} (x(0) - Re X)`` with ``X = (iw I - A)^-1 B U S`` and
    ``x(0) = 0``; each output is ``C x + D u`` of its row.

    Parameters
    ----------
    network : Network
        A body model.
    settings : CrossCheckSettings
    t : (n,) array_like
        Times, s.

    Returns
    -------
    dict of str to ndarray
        Output name -> values at t, for every output that is not a rate (``*_rate``).

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> y = exact_sine_outputs(load_model("reduced-paper"), CrossCheckSettings(), [0.0])
    >>> float(y["head_displacement"][0])
    0.0
    """
    t = np.asarray(t, dtype=float)
    lm = linear_model(network)
    iface = KINDS["body"](network)
    a, w = settings.amplitude, 2 * math.pi * settings.frequency
    S = np.array([-1j * a, a * w, 1j * a * w * w])  # s(t) = Re(S e^{iwt})
    X = np.linalg.solve(1j * w * np.eye(len(lm.A)) - lm.A, lm.B @ iface.input_map @ S)
    x = np.array(
        [(X * np.exp(1j * w * tk)).real - scipy.linalg.expm(lm.A * tk) @ X.real for tk in t]
    )
    u = _seat(settings, t) @ iface.input_map.T
    out: Dict[str, np.ndarray] = {}
    for var, signal in zip(iface.outputs, iface.output_signals, strict=True):
        if not var.name.endswith("_rate"):
            r = lm.output_index(signal)
            out[var.name] = x @ lm.C[r] + u @ lm.D[r]
    return out


def _csv(t: np.ndarray, columns: Mapping[str, np.ndarray]) -> str:
    names = ["time", *columns]
    rows = [",".join(names)]
    values = np.column_stack([t, *columns.values()])
    rows += [",".join(repr(float(v)) for v in row) for row in values]
    return "\n".join(rows) + "\n"


def _readme(settings: CrossCheckSettings, model: str, outputs: Sequence[str]) -> str:
    return f"""# {settings.name} (bodyvib {__version__})

The native C FMI 2.0 co-simulation FMU of the seated human body model `{model}` (bodyvib),
linux64 binary and C sources. Inputs: seat displacement [m], velocity [m/s] and
acceleration [m/s2]; outputs: {", ".join(outputs)} and the seat force's rate.

Inputs (`{settings.name}_in.csv`): the seat sine d = {settings.amplitude:g} sin(2 pi
{settings.frequency:g} t) m with its exact velocity and acceleration, one row per
communication step ({settings.step:g} s), from rest at t = 0 to {settings.duration:g} s.

Reference (`{settings.name}_ref.csv`): the exact response of the model's linear state space to
that sine from rest (the harmonic solution plus the matrix-exponential free response that
cancels it at t = 0), every {settings.output_step:g} s; not a run of the FMU.
"""


def write_cross_check(
    dest: Union[str, os.PathLike],
    network: Network,
    model: str,
    settings: CrossCheckSettings = CrossCheckSettings(),
) -> CrossCheck:
    """Build the native body FMU and write its cross-check folder under ``dest``.

    Parameters
    ----------
    dest : str or os.PathLike
        The root of the cross-check tree (``fmus/...`` is made in it).
    network : Network
        The body model baked into the FMU.
    model : str
        Its name for the ReadMe (a model name or parameter file).
    settings : CrossCheckSettings

    Returns
    -------
    CrossCheck

    Raises
    ------
    BodyvibError
        A step that does not divide the run or the output step; and everything
        :func:`bodyvib.fmu.native.build_native_fmu` refuses (a missing compiler).
    """
    from .native import build_native_fmu

    s = settings
    n_steps, n_out = s.duration / s.step, s.output_step / s.step
    if not (abs(n_steps - round(n_steps)) < 1e-9 * n_steps and abs(n_out - round(n_out)) < 1e-9):
        raise BodyvibError(
            f"cross-check: the step {s.step:g} s must divide the run ({s.duration:g} s) and "
            f"the output step ({s.output_step:g} s)"
        )
    entries = tuple(
        Path(dest) / "fmus" / "2.0" / kind / "linux64" / TOOL / __version__ / s.name
        for kind in INTERFACES
    )
    folder = entries[0]
    fmu = build_native_fmu(
        network, "body", s.name, f"{model} (cross-check)", folder, fmi=2, platforms=("linux64",)
    )
    t_in = np.arange(round(n_steps) + 1) * s.step
    seat = _seat(s, t_in)
    inputs = folder / f"{s.name}_in.csv"
    names = [v.name for v in KINDS["body"](network).inputs]
    atomic_write_text(inputs, _csv(t_in, dict(zip(names, seat.T, strict=True))))
    t_ref = np.arange(round(s.duration / s.output_step) + 1) * s.output_step
    ref = exact_sine_outputs(network, s, t_ref)
    reference = folder / f"{s.name}_ref.csv"
    atomic_write_text(reference, _csv(t_ref, ref))
    options = folder / f"{s.name}_ref.opt"
    atomic_write_text(
        options,
        f"StartTime, 0.0\nStopTime, {s.duration!r}\nStepSize, {s.step!r}\nRelTol, {s.rel_tol!r}\n",
    )
    sh, bat = _commands(model)
    atomic_write_text(folder / f"{s.name}_cc.sh", sh)
    atomic_write_text(folder / f"{s.name}_cc.bat", bat)
    readme = folder / "ReadMe.md"
    atomic_write_text(readme, _readme(s, model, list(ref)))
    scripts = [folder / f"{s.name}_cc.{ext}" for ext in ("sh", "bat")]
    files = [fmu, inputs, reference, options, *scripts, readme]
    for twin in entries[1:]:  # the same FMU and files, published for the other interface
        for f in files:  # (inside staged_writes, what was written is still staged)
            with open(staged_source(f), "rb") as src:
                atomic_write_bytes(twin / f.name, src.read())
    return CrossCheck(folder, fmu, inputs, reference, options, readme, tuple(ref), entries)


def _commands(model: str) -> Tuple[str, str]:
    """``_cc.sh`` and ``_cc.bat``: the command that rebuilds the tree the script is in (its
    root seven folders up: model, version, tool, platform, interface, FMI version, fmus)."""
    if os.path.isfile(model):  # a parameter file: found wherever the script runs from
        model = os.path.abspath(model)
    up = "/".join([".."] * 7)
    sh = (
        "#!/bin/sh\n"
        f'root="$(cd "$(dirname "$0")/{up}" && pwd)"\n'
        f'exec bodyvib build --cross-check "$root" --params {shlex.quote(model)}\n'
    )
    bat = f'bodyvib build --cross-check "%~dp0{up.replace("/", chr(92))}" --params "{model}"\r\n'
    return sh, bat
