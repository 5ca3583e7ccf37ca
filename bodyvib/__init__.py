"""bodyvib: seated-occupant vertical vibration models for vehicle studies.

The reduced 3-DOF human-body model of Balci & Gundogdu (2025) and the ISO 7962
four-mass model, written as data (:mod:`bodyvib.models`), turned into state
space (:mod:`bodyvib.network`), frequency responses (:mod:`bodyvib.frequency`,
:mod:`bodyvib.analytic`) and exact discrete-time simulation
(:mod:`bodyvib.discretize`).

The modules ``errors``, ``fileio``, ``network``, ``models`` and ``discretize``
need numpy only and import each other relatively: the FMUs ship them under a
private package name.
"""

__version__ = "0.1.0"

from .errors import BodyvibError  # noqa: F401
from .models import available_models, load_model  # noqa: F401
from .network import linear_model  # noqa: F401

__all__ = ["BodyvibError", "available_models", "load_model", "linear_model", "__version__"]
