"""Where the sources an FMU is made of live: the run-time package and ``fmu_src``.

One place answers it for both builders: the pythonfmu builder copies
:mod:`bodyvib.runtime` and renders ``fmu_src/bodyvib_fmu_slave.py``; the native
builder compiles ``fmu_src/native/*.c``. ``fmu_src`` is found as an installed
package (it travels in the wheel), never by a path relative to this file.
"""

import importlib.util
from pathlib import Path

from ..runtime.errors import BodyvibError

__all__ = ["RUNTIME_DIR", "fmu_src_dir", "native_dir"]

#: The run-time package copied into every pythonfmu FMU.
RUNTIME_DIR = Path(__file__).resolve().parent.parent / "runtime"


def fmu_src_dir() -> Path:
    """The folder of the installed ``fmu_src`` package.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    BodyvibError
        ``fmu_src`` is not importable (a broken installation).
    """
    spec = importlib.util.find_spec("fmu_src")
    if spec is None or not spec.submodule_search_locations:
        raise BodyvibError("the fmu_src package (the FMU sources) is not installed; "
                           "reinstall bodyvib (pip install bodyvib)")
    return Path(list(spec.submodule_search_locations)[0])


def native_dir() -> Path:
    """The folder of the native C sources, ``fmu_src/native``.

    Returns
    -------
    pathlib.Path
    """
    return fmu_src_dir() / "native"
