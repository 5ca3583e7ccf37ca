"""The project's FMUs: HumanBody3DOF, HumanBodyISO7962 and QuarterCar.

``python build_fmu.py`` and ``bodyvib build`` build these three with
:func:`bodyvib.fmu_build.build_fmu`; the co-simulation commands build the ones
they are not given into a temporary folder (:func:`temporary_fmu_dir`).
"""

import tempfile
from pathlib import Path
from typing import Dict, Iterable, Optional

from bodyvib.fmu_build import build_fmu
from bodyvib.models import load_model
from bodyvib.runtime.errors import BodyvibError

from .quarter_car import load_car

__all__ = ["FMUS", "build_fmus", "build_project_fmu", "build_native_project_fmu", "load_fmu_model",
           "temporary_fmu_dir"]

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


def load_fmu_model(name: str, model: Optional[str] = None):
    """The model an FMU of :data:`FMUS` bakes in.

    Parameters
    ----------
    name : str
        A key of :data:`FMUS`.
    model : str, optional
        Shipped model name or parameter file (the FMU's default if None).

    Returns
    -------
    bodyvib.runtime.network.Network

    Raises
    ------
    BodyvibError
        Unknown FMU name, unknown model or invalid parameter file.
    """
    if name not in FMUS:
        raise BodyvibError(f"unknown FMU '{name}'; FMUs are {', '.join(FMUS)}")
    kind, default, _ = FMUS[name]
    return (load_car if kind == "car" else load_model)(model or default)


def build_project_fmu(name: str, dest="dist", model: Optional[str] = None) -> Path:
    """Build one FMU of :data:`FMUS`.

    Parameters
    ----------
    name : str
        A key of :data:`FMUS`.
    dest : str or path
        Output folder.
    model : str, optional
        Shipped model name or parameter file to bake in (the FMU's default if None).

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        See :func:`load_fmu_model` and :func:`bodyvib.fmu_build.build_fmu`.
    """
    network = load_fmu_model(name, model)
    kind, _, description = FMUS[name]
    return build_fmu(network, kind, name, description, dest)


def build_native_project_fmu(name: str, dest="dist/native", model: Optional[str] = None,
                             fmi: int = 2) -> Path:
    """Build one FMU of :data:`FMUS` as a native C FMU (:mod:`bodyvib.native_build`).

    Parameters
    ----------
    name : str
        A key of :data:`FMUS`.
    dest : str or path
        Output folder.
    model : str, optional
        Shipped model name or parameter file to bake in (the FMU's default if None).
    fmi : int
        FMI version, 2 or 3.

    Returns
    -------
    Path
        ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        See :func:`load_fmu_model` and :func:`bodyvib.native_build.build_native_fmu`.
    """
    from bodyvib.native_build import build_native_fmu

    network = load_fmu_model(name, model)
    kind, _, description = FMUS[name]
    return build_native_fmu(network, kind, name, description, dest, fmi=fmi)


def build_fmus(dest="dist", params: Optional[str] = None, car: str = "quarter-car",
               names: Optional[Iterable[str]] = None, echo=None, native: bool = False,
               fmi: Iterable[int] = (2, 3)) -> Dict[str, Path]:
    """Build the project's FMUs.

    Parameters
    ----------
    dest : str or path
        Output folder (``dist`` by default).
    params : str, optional
        Parameter file (or shipped model name) baked into ``HumanBody3DOF.fmu``;
        the paper's Table 2 (``reduced-paper``) by default.
    car : str
        Vehicle parameter file or shipped name for ``QuarterCar.fmu``.
    names : iterable of str, optional
        Which FMUs (all of :data:`FMUS` by default).
    echo : callable, optional
        Called with one line per FMU written.
    native : bool
        Build the native C FMUs instead of the pythonfmu ones: FMI 2.0 into
        ``dest``, FMI 3.0 into ``dest/fmi3`` (keys ``"fmi3/<name>"``).
    fmi : iterable of int
        With ``native``, the FMI versions to build.

    Returns
    -------
    dict of str to Path

    Raises
    ------
    BodyvibError
        See :func:`bodyvib.fmu_build.build_fmu`; every model is loaded (and a
        bad one refused) before the first FMU is built.

    Examples
    --------
    >>> paths = build_fmus("dist")  # doctest: +SKIP
    >>> sorted(paths)  # doctest: +SKIP
    ['HumanBody3DOF', 'HumanBodyISO7962', 'QuarterCar']
    """
    names = list(names or FMUS)
    chosen = {"HumanBody3DOF": params, "QuarterCar": car}
    for n in names:  # refuse a bad model before building anything
        load_fmu_model(n, chosen.get(n))
    out = {}
    if native:
        for version in fmi:
            folder = Path(dest) if version == 2 else Path(dest) / "fmi3"
            for n in names:
                key = n if version == 2 else f"fmi3/{n}"
                out[key] = build_native_project_fmu(n, folder, chosen.get(n), fmi=version)
                if echo:
                    echo(f"wrote {out[key]} (native C, FMI {version}.0, model "
                         f"{chosen.get(n) or FMUS[n][1]}; fmpy validate: no problems)")
        return out
    for n in names:
        out[n] = build_project_fmu(n, dest, chosen.get(n))
        if echo:
            echo(f"wrote {out[n]} (model {chosen.get(n) or FMUS[n][1]}; fmpy validate: no problems)")
    return out


def temporary_fmu_dir() -> str:
    """A fresh temporary folder for FMUs built for one run (the caller deletes it)."""
    return tempfile.mkdtemp(prefix="bodyvib-fmus-")
