"""bodyvib: seated-occupant vertical vibration models for vehicle studies.

The physics library. The reduced 3-DOF human-body model of Balci & Gundogdu
(2025) and the ISO 7962 four-mass model, written as data (:func:`load_model`, the
parameter-file format of :mod:`bodyvib.runtime.modelfile`), turned into state space
(:func:`linear_model`), frequency responses (:mod:`bodyvib.frequency`, the closed forms
of :mod:`bodyvib.analytic`), exact discrete-time simulation
(:mod:`bodyvib.runtime.discretize`), ISO 2631-1 figures (:mod:`bodyvib.comfort`),
measured seat signals (:mod:`bodyvib.seat`), the refit of the reduced model
(:mod:`bodyvib.fit`) and FMUs (:mod:`bodyvib.fmu`).

Each subpackage declares its public interface in ``__all__``; import from the package
(``from bodyvib.comfort import comfort_figures``): the modules that hold the names are
internal and may move. :mod:`bodyvib.analytic` and :mod:`bodyvib.models` are public
modules of this package, and :mod:`bodyvib.runtime` is the numpy-only subpackage that
travels inside every pythonfmu FMU, used through its modules.

This package never imports :mod:`bodyvib.vehicle` (the application) or
:mod:`bodyvib.cli` (the command line): the layers run upward (docs/architecture.md).
"""

__version__ = "0.1.0"

from .models import available_models, load_model, load_network, save_model
from .runtime.errors import BodyvibError
from .runtime.network import linear_model

__all__ = [
    "BodyvibError",
    "available_models",
    "load_model",
    "load_network",
    "save_model",
    "linear_model",
    "__version__",
]
