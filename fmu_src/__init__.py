"""FMU sources that travel with the bodyvib package: the one pythonfmu slave script.

Not imported at run time: :mod:`bodyvib.fmu.pythonfmu` reads ``bodyvib_fmu_slave.py``
from here and renders it per FMU.
"""

# One module identity: this folder installs as bodyvib.fmu_src (pyproject.toml's package-dir).
# Imported as `fmu_src` from a checkout it would be a second copy of every module, with
# its own classes and registries, so it refuses.
if __name__ != "bodyvib.fmu_src":
    raise ImportError(
        f"import bodyvib.fmu_src, not {__name__}: the repository's fmu_src/ folder is the "
        "package bodyvib.fmu_src (pip install -e . installs it so)"
    )


__all__ = []  # type: list[str]
