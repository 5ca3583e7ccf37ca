"""The command line's words for the library's parameters: one table, parameter -> flag.

The library names its own parameters in its messages (``retry_failed=True needs
resume=True``) and lists them with the message (``BodyvibError.parameters``,
``RoadWarning.parameters``); the command line shows each as the flag that sets it
(``--retry-failed needs --resume``). Standard library only: every command imports it.
"""

import re
from typing import Iterable, Mapping, Optional

__all__ = ["FLAGS", "in_flags"]

#: The library's parameter (or settings field, or spec key) -> the flag that sets it.
FLAGS = {
    # a run
    "speed": "--speed",
    "duration": "--duration",
    "step": "--step",
    "road_length": "--road-length",
    # how a road is driven (RoadOptions)
    "taper_m": "--road-taper",
    "track_m": "--road-track",
    "units": "--road-units",
    "envelope": "--road-envelope",
    "repeat": "--road-repeat",
    "contact": "--road-contact",
    # the FMUs of a co-simulation, their build
    "body_fmus": "--body",
    "car": "--car",
    "car_fmu": "--car-fmu",
    "controller": "--control-fmu",
    "platforms": "--platforms",
    "linear": "--linear",
    # a sweep (SweepSettings)
    "grid_spec": "--grid",
    "out": "--out",
    "csv": "--csv",
    "resume": "--resume",
    "retry_failed": "--retry-failed",
    "overwrite": "--overwrite",
    "scheduler": "--scheduler",
    "scheduler_file": "--scheduler-file",
    "connect_timeout": "--connect-timeout",
    "worker_timeout": "--worker-timeout",
    "workers": "--workers",
    # the refit, a response, a comparison
    "total_mass": "--total-mass",
    "pairs": "--pairs",
    "channel": "--channel",
    "channels": "--channels",
    "points": "--points",
    # the library's functions, where a message names the one that does the fix
    "build_active_ssp": "bodyvib build --control",
    "build_fmus": "bodyvib build --fmus",
    "run_study": "bodyvib cosim --control",
    "pareto_front": "bodyvib fit --pareto",
}


def in_flags(
    message: str, parameters: Iterable[str] = (), flags: Optional[Mapping[str, str]] = None
) -> str:
    """A library message as the command line says it: each named parameter as its flag.

    Parameters
    ----------
    message : str
        The library's message (a :class:`~bodyvib.runtime.errors.BodyvibError`, a warning,
        a status line).
    parameters : iterable of str
        The parameters it names (keys of :data:`FLAGS`; others are left as they are), each
        written ``name=True`` (the flag alone), ``name=value`` (the flag and the value),
        ``'name'`` or, for a name with an underscore, ``name``: a plain word such as
        ``units`` is translated only in those marked forms, never in the prose around it.
    flags : mapping of str to str, optional
        A command's own flags where they differ from :data:`FLAGS` (``bodyvib road``'s
        ``--track``).

    Returns
    -------
    str

    Examples
    --------
    >>> in_flags("retry_failed=True needs resume=True", ("retry_failed", "resume"))
    '--retry-failed needs --resume'
    >>> in_flags("shorten the run ('duration') or lower 'speed'", ("duration", "speed"))
    'shorten the run (--duration) or lower --speed'
    >>> in_flags("or pass platforms=linux64", ("platforms",))
    'or pass --platforms linux64'
    >>> in_flags("the file names no units; give 'units' or units=m,mm", ("units",))
    'the file names no units; give --road-units or --road-units m,mm'
    """
    table = {**FLAGS, **(flags or {})}
    for name in parameters:
        flag = table.get(name)
        if flag is None:
            continue
        word = rf"(?<![\w.'-]){re.escape(name)}"
        message = re.sub(rf"{word}=True\b", flag, message)
        message = re.sub(rf"{word}=", f"{flag} ", message)
        message = re.sub(rf"'{re.escape(name)}'", flag, message)
        if "_" in name:
            message = re.sub(rf"{word}(?![\w'=-])", flag, message)
    return message
