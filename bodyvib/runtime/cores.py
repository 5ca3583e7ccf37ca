"""Every FMU kind in one table, behind one core protocol.

An FMU of this project is a thin wrapper (the pythonfmu slave, or the native C
wrappers for the C cores) around a *core*: the object that owns one instance's
variables, parameters and state and answers the FMI calls. Two implementations
exist: :class:`~bodyvib.runtime.engine.FmuCore` runs a network (the ``body`` and
``car`` kinds, whose interfaces :data:`bodyvib.runtime.contract.KINDS` defines),
:class:`~bodyvib.runtime.tabulated.SourceCore` a tabulated signal (the ``source``
kind, Road.fmu). :data:`CORES` says, per kind, how a core is made from the FMU's
``resources`` folder; :class:`Core` is what the wrappers may call.
"""

import os
from typing import Callable, Dict, List, Optional, Protocol, Sequence

import numpy as np

from .contract import MODEL_FILE
from .engine import FmuCore
from .modelfile import network_from_file
from .tabulated import SOURCE_FILE, SourceCore, read_source

__all__ = ["Core", "CORES", "load_core"]

#: ``log(message, level)``, level ``"warning"`` or ``"error"`` (the FMU's logger).
_Log = Callable[[str, str], None]


class Core(Protocol):
    """What an FMU wrapper calls on its core (both core classes provide it).

    ``variables`` lists the FMU's variables in value-reference order; the methods
    follow the FMI calls of the same names and raise
    :class:`~bodyvib.runtime.errors.BodyvibError` to refuse one (the instance's
    state unchanged).
    """

    kind: str
    variables: tuple

    def setup_experiment(self, start_time: float) -> None: ...
    def check_parameters(self, params: Optional[np.ndarray] = None) -> None: ...
    def initialize(self) -> None: ...
    def get_real(self, vrs: Sequence[int]) -> List[float]: ...
    def set_real(self, vrs: Sequence[int], values: Sequence[float]) -> None: ...
    def do_step(self, current_time: float, step_size: float) -> None: ...
    def get_state(self) -> dict: ...
    def set_state(self, state: dict) -> None: ...
    def output_dependencies(self) -> List[List[int]]: ...


def _network_core(kind: str) -> Callable[..., Core]:
    def make(resources: str, name: str, log: Optional[_Log] = None) -> Core:
        return FmuCore(kind, network_from_file(os.path.join(resources, MODEL_FILE)), name, log=log)

    return make


def _source_core(resources: str, name: str, log: Optional[_Log] = None) -> Core:
    meta, table = read_source(os.path.join(resources, SOURCE_FILE))
    return SourceCore(meta, table, name, log=log)


#: FMU kind -> ``make(resources, name, log)``: the core of an FMU of that kind, from the
#: files its builder put into ``resources/`` (the parameter file, or the source table).
CORES: Dict[str, Callable[..., Core]] = {
    "body": _network_core("body"),
    "car": _network_core("car"),
    "source": _source_core,
}


def load_core(kind: str, resources: str, name: str, log: Optional[Callable] = None) -> Core:
    """The core of an FMU of ``kind`` from its ``resources`` folder.

    Parameters
    ----------
    kind : str
        A key of :data:`CORES`.
    resources : str
        The FMU's extracted ``resources`` folder.
    name : str
        The instance name, for messages.
    log : callable, optional
        ``log(message, level)`` for the FMU's logger.

    Returns
    -------
    Core

    Raises
    ------
    KeyError
        An unknown kind (a build error: the builder writes the kind it registered).
    """
    return CORES[kind](resources, name, log)
