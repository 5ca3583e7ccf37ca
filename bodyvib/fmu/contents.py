"""What an FMU is made of, for both builders: the sources and the model's resources.

One place answers it for both builders: the pythonfmu builder copies
:mod:`bodyvib.runtime` and renders ``fmu_src/bodyvib_fmu_slave.py``; the native
builder compiles ``fmu_src/native/*.c``. ``fmu_src`` is found as an installed
package (it travels in the wheel), never by a path relative to this file. Both kinds
carry the same ``resources/``: a model's parameter file (:func:`model_resources`) or a
source's table (:func:`source_resources`).
"""

import importlib.util
import json
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Dict

from ..runtime.errors import BodyvibError

if TYPE_CHECKING:  # for annotations only
    from ..runtime.network import Network
    from ..runtime.tabulated import HermiteTable

__all__ = ["RUNTIME_DIR", "fmu_src_dir", "model_resources", "native_dir", "source_resources"]

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
    spec = importlib.util.find_spec("bodyvib.fmu_src")
    if spec is None or not spec.submodule_search_locations:
        raise BodyvibError(
            "the fmu_src package (the FMU sources) is not installed; "
            "reinstall bodyvib (pip install bodyvib)"
        )
    return Path(list(spec.submodule_search_locations)[0])


def native_dir() -> Path:
    """The folder of the native C sources, ``fmu_src/native``.

    Returns
    -------
    pathlib.Path
    """
    return fmu_src_dir() / "native"


def model_resources(network: "Network") -> Dict[str, bytes]:
    """The ``resources/`` of a model FMU: the parameter file of the model baked in.

    Parameters
    ----------
    network : bodyvib.runtime.network.Network
        The model.

    Returns
    -------
    dict of str to bytes
        :data:`bodyvib.runtime.contract.MODEL_FILE` -> its JSON text.
    """
    from ..runtime.contract import MODEL_FILE
    from ..runtime.modelfile import network_to_dict

    return {MODEL_FILE: (json.dumps(network_to_dict(network), indent=2) + "\n").encode()}


def source_resources(meta: dict, table: "HermiteTable") -> Dict[str, bytes]:
    """The ``resources/`` of a source FMU: its description and table files.

    Parameters
    ----------
    meta, table
        As :func:`bodyvib.fmu.pythonfmu.build_source_fmu`.

    Returns
    -------
    dict of str to bytes
        File name -> contents (:func:`bodyvib.runtime.tabulated.write_source`).
    """
    from ..runtime.tabulated import write_source

    with tempfile.TemporaryDirectory(prefix="bodyvib_source_") as tmp:
        return {Path(p).name: Path(p).read_bytes() for p in write_source(tmp, meta, table)}
