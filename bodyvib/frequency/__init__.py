"""The frequency domain: model responses, their comparison, estimates from runs, measurements.

:mod:`~bodyvib.frequency.response` computes a network's exact frequency responses
(seat-to-head transmissibility, apparent mass, peaks); :mod:`~bodyvib.frequency.compare`
sets several models side by side (``bodyvib frf``); :mod:`~bodyvib.frequency.estimate`
estimates a transmissibility from a run's time records (Welch H1);
:mod:`~bodyvib.frequency.measured` reads a user's measured transmissibility.

Import from the package (``from bodyvib.frequency import transmissibility``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_MODULES = {
    "response": (
        "Peak",
        "apparent_mass",
        "control_labels",
        "displacement_input_matrices",
        "displacement_input_statespace",
        "find_peaks",
        "frequency_response",
        "to_statespace",
        "transmissibility",
    ),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
