"""The shipped models: body parameter files loadable by name.

Shipped models: ``reduced-paper`` (Balci & Gundogdu 2025, Table 2) and
``iso7962`` (the ISO 7962 four-mass model; see its ``provenance``). Any
parameter file (:mod:`bodyvib.runtime.modelfile`) loads the same way by path.
"""

import os
from typing import List, Union

from .process.outputs import write_json
from .runtime.errors import BodyvibError
from .runtime.modelfile import network_from_file, network_to_dict
from .runtime.network import Network

__all__ = [
    "DEFAULT_MODELS",
    "MODEL_DIR",
    "available_models",
    "load_model",
    "load_network",
    "save_model",
    "shipped_names",
]

#: The body models run and compared by default (shipped names): the reduced model with
#: the paper's parameters and the ISO 7962 model it reduces.
DEFAULT_MODELS = ("reduced-paper", "iso7962")

#: Folder of the shipped parameter files.
MODEL_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")


def shipped_names(folder: str) -> List[str]:
    """Names of the parameter files in a folder (sorted ``*.json`` stems)."""
    return sorted(f[:-5] for f in os.listdir(folder) if f.endswith(".json"))


def available_models() -> List[str]:
    """Names of the shipped models.

    Returns
    -------
    list of str
        Sorted names (file stems in :data:`MODEL_DIR`).
    """
    return shipped_names(MODEL_DIR)


def load_network(
    name_or_path: Union[str, os.PathLike], folder: str, what: str = "model"
) -> Network:
    """Load a parameter file by path, or by its name among the files of ``folder``.

    Parameters
    ----------
    name_or_path : str or path
        A parameter file, or the stem of a ``.json`` file in ``folder``.
    folder : str
        Folder of the shipped parameter files.
    what : str
        What is loaded, for messages (``"model"``, ``"vehicle model"``).

    Returns
    -------
    Network
        The file's network, validated by :func:`~bodyvib.runtime.modelfile.network_from_file`.

    Raises
    ------
    BodyvibError
        A missing file (a name ending in ``.json`` or with a path separator),
        an unknown name (the message lists the shipped ones), or what
        :func:`~bodyvib.runtime.modelfile.network_from_file` refuses.
    """
    s = os.fspath(name_or_path)
    if os.path.isfile(s):
        return network_from_file(s)
    names = shipped_names(folder)
    if s in names:
        return network_from_file(os.path.join(folder, s + ".json"))
    if s.endswith(".json") or os.sep in s:
        raise BodyvibError(f"{what} file '{s}' does not exist")
    raise BodyvibError(
        f"unknown {what} '{s}'; give a parameter file path or one of: " + ", ".join(names)
    )


def load_model(name_or_path: Union[str, os.PathLike]) -> Network:
    """Load a model by shipped name or from a JSON file.

    Parameters
    ----------
    name_or_path : str or path
        ``"reduced-paper"``, ``"iso7962"``, or the path of a parameter file.

    Returns
    -------
    Network
        The body model, as :func:`load_network` loads it from :data:`MODEL_DIR`.

    Raises
    ------
    BodyvibError
        What :func:`load_network` refuses (the message names the file and field).

    Examples
    --------
    >>> net = load_model("reduced-paper")
    >>> net.parameters["m1"]
    4.88
    """
    return load_network(name_or_path, MODEL_DIR, "model")


def save_model(net: Network, path: Union[str, os.PathLike]) -> None:
    """Write a network as a parameter file, atomically.

    Parameters
    ----------
    net : Network
        The model to keep, e.g. a refit one.
    path : str or os.PathLike
        Destination (its folder is created if missing).

    Examples
    --------
    >>> import tempfile, os
    >>> from bodyvib.models import load_model, save_model
    >>> d = tempfile.mkdtemp()
    >>> save_model(load_model("reduced-paper"), os.path.join(d, "m.json"))
    >>> load_model(os.path.join(d, "m.json")).parameters["m1"]
    4.88
    >>> import shutil; shutil.rmtree(d)
    """
    write_json(path, network_to_dict(net))
