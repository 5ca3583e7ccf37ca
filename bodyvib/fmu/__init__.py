"""Building FMUs from models: pythonfmu (Python) and native (C), FMI 2.0 and 3.0.

:func:`~bodyvib.fmu.build.build` is the one entry: any kind, either backend.
:mod:`~bodyvib.fmu.pythonfmu` builds a pythonfmu FMU whose slave runs the copied
run-time package :mod:`bodyvib.runtime`; :mod:`~bodyvib.fmu.native` compiles the
one C code base in ``fmu_src/native`` for the model baked in as data;
:mod:`~bodyvib.fmu.contents` locates the sources both start from. Names are
imported from their module on first use (pythonfmu and the compilers are only
needed when building).
"""

import importlib

_HOME = {
    "build": "build",
    "BACKENDS": "build",
    "build_fmu": "pythonfmu",
    "build_source_fmu": "pythonfmu",
    "build_native_fmu": "native",
    "native_model": "native",
    "PLATFORMS": "native",
    "fmu_src_dir": "contents",
    "native_dir": "contents",
    "RUNTIME_DIR": "contents",
}

__all__ = sorted(_HOME)


def __getattr__(name):
    if name in _HOME:
        return getattr(importlib.import_module(f"{__name__}.{_HOME[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
