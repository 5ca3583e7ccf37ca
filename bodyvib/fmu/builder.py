"""One entry for building an FMU: any kind (body, car, source), either backend, FMI 2.0 or 3.0.

:func:`build` chooses among the four builders by the FMU's kind and the backend, and
refuses a combination that does not exist (pythonfmu FMUs are FMI 2.0 only) before any
work:

=========  ================================================  ==========================================================
kind       backend ``"pythonfmu"`` (FMI 2.0)                 backend ``"native"`` (FMI 2.0 or 3.0)
=========  ================================================  ==========================================================
body, car  :func:`~bodyvib.fmu.pythonfmu.build_fmu`          :func:`~bodyvib.fmu.native.build_native_fmu`
source     :func:`~bodyvib.fmu.pythonfmu.build_source_fmu`   :func:`~bodyvib.fmu.native_table.build_native_source_fmu`
=========  ================================================  ==========================================================

Every builder writes its model description through :mod:`bodyvib.fmu.description`.
"""

import os
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Tuple, Union

from ..runtime.cores import CORES
from ..runtime.errors import BodyvibError
from ..runtime.network import Network

if TYPE_CHECKING:  # for annotations only
    from ..runtime.tabulated import HermiteTable

__all__ = ["BACKENDS", "build"]

#: The FMU backends: a pythonfmu slave over the copied run-time, or the compiled C code base.
BACKENDS = ("pythonfmu", "native")


def build(
    model: Union[Network, Tuple[dict, "HermiteTable"]],
    kind: str,
    name: str,
    description: str = "",
    dest: Union[str, os.PathLike] = "dist",
    *,
    backend: str = "pythonfmu",
    fmi: int = 2,
    platforms: Iterable[str] = ("linux64", "win64"),
) -> Path:
    """Build one FMU of ``kind`` with ``backend``: the library's one build entry.

    Parameters
    ----------
    model : Network or (dict, HermiteTable)
        For ``kind`` ``"body"`` or ``"car"``: the model
        (:func:`bodyvib.models.load_model`; a car: :func:`bodyvib.models.load_network`). For
        ``"source"``: the source description and its table
        (:mod:`bodyvib.runtime.tabulated`).
    kind : {"body", "car", "source"}
        The FMU's role (:data:`bodyvib.runtime.cores.CORES`).
    name : str
        Model name and identifier of the FMU; the file is ``dest/<name>.fmu``.
    description : str
        One sentence on the FMU, written into its model description.
    dest : str or path
        Output folder, created if missing.
    backend : {"pythonfmu", "native"}
        A pythonfmu FMU (FMI 2.0, needs Python in the host's process) or a native C
        FMU (co-simulation and Model Exchange, no Python).
    fmi : {2, 3}
        FMI version; 3 needs ``backend="native"``.
    platforms : iterable of str
        Native only: binaries to compile (:data:`bodyvib.fmu.native.PLATFORMS`).

    Returns
    -------
    Path
        The FMU written, ``dest/<name>.fmu``.

    Raises
    ------
    BodyvibError
        An unknown kind or backend, FMI 3.0 asked of pythonfmu, a source not given as
        ``(meta, table)``; then whatever the chosen builder refuses (invalid model, a
        compiler missing, problems ``fmpy validate`` finds), the previous file at
        ``dest/<name>.fmu`` left as it was.

    Examples
    --------
    >>> from bodyvib.models import load_model
    >>> build(load_model("reduced-paper"), "body", "HumanBody3DOF", "reduced body",
    ...       "dist/native/fmi3", backend="native", fmi=3)  # doctest: +SKIP
    PosixPath('dist/native/fmi3/HumanBody3DOF.fmu')
    >>> build(load_model("reduced-paper"), "body", "HumanBody3DOF", fmi=3)
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: pythonfmu FMUs are FMI 2.0 only; build FMI 3.0 with backend='native'
    """
    if kind not in CORES:
        raise BodyvibError(f"unknown FMU kind {kind!r}; kinds are {', '.join(CORES)}")
    if backend not in BACKENDS:
        raise BodyvibError(f"unknown FMU backend {backend!r}; backends are {', '.join(BACKENDS)}")
    if fmi not in (2, 3):
        raise BodyvibError(f"FMI version must be 2 or 3, got {fmi!r}")
    if backend == "pythonfmu" and fmi != 2:
        raise BodyvibError("pythonfmu FMUs are FMI 2.0 only; build FMI 3.0 with backend='native'")
    if kind == "source":
        if not (isinstance(model, tuple) and len(model) == 2 and isinstance(model[0], dict)):
            raise BodyvibError(
                "a source FMU is built from (meta, table), the source description "
                "and its table (bodyvib.runtime.tabulated)"
            )
        meta, table = model
        if backend == "native":
            from .native_table import build_native_source_fmu

            return build_native_source_fmu(
                meta, table, name, description, dest, fmi=fmi, platforms=platforms
            )
        from .pythonfmu import build_source_fmu

        return build_source_fmu(meta, table, name, description, dest)
    if not isinstance(model, Network):
        raise BodyvibError(
            f"a {kind} FMU is built from a Network (bodyvib.models.load_model "
            f"or a car file), got {type(model).__name__}"
        )
    if backend == "native":
        from .native import build_native_fmu

        return build_native_fmu(model, kind, name, description, dest, fmi=fmi, platforms=platforms)
    from .pythonfmu import build_fmu

    return build_fmu(model, kind, name, description, dest)
