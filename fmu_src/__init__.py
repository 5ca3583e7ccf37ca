"""FMU sources that travel with the bodyvib package: the one pythonfmu slave script.

Not imported at run time: :mod:`bodyvib.fmu.pythonfmu` reads ``bodyvib_fmu_slave.py``
from here and renders it per FMU.
"""

__all__ = []  # type: list[str]
