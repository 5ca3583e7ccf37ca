"""bodyvib: seated-occupant vertical vibration models for vehicle studies.

The physics library. The reduced 3-DOF human-body model of Balci & Gundogdu
(2025) and the ISO 7962 four-mass model, written as data (:mod:`bodyvib.models`,
:mod:`bodyvib.runtime.modelfile`), turned into state space
(:mod:`bodyvib.runtime.network`), frequency responses (:mod:`bodyvib.frequency.response`,
:mod:`bodyvib.analytic`), exact discrete-time simulation
(:mod:`bodyvib.runtime.discretize`), ISO 2631-1 figures (:mod:`bodyvib.comfort.figures`),
the GA refit (``bodyvib.fit_*``) and FMUs (:mod:`bodyvib.fmu.pythonfmu`).

:mod:`bodyvib.runtime` is the numpy-only sub-package that travels inside every
pythonfmu FMU. This package never imports :mod:`bodyvib.vehicle` (the application) or
:mod:`bodyvib.cli` (the command line): the layers run upward
(docs/architecture.md).
"""

__version__ = "0.1.0"

from .models import available_models, load_model  # noqa: F401
from .runtime.errors import BodyvibError  # noqa: F401
from .runtime.network import linear_model  # noqa: F401

__all__ = ["BodyvibError", "available_models", "load_model", "linear_model", "__version__"]
