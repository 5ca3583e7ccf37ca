"""Building FMUs from models: pythonfmu (Python) and native (C), FMI 2.0 and 3.0.

:func:`~bodyvib.fmu.builder.build` is the one entry: any kind, either backend.
:mod:`~bodyvib.fmu.pythonfmu` builds a pythonfmu FMU whose slave runs the copied
run-time package :mod:`bodyvib.runtime`; :mod:`~bodyvib.fmu.native` compiles the
one C code base in ``fmu_src/native`` for the model baked in as data;
:mod:`~bodyvib.fmu.contents` locates the sources both start from;
:mod:`~bodyvib.fmu.controller` builds the skyhook controller, a small C model of its own;
:mod:`~bodyvib.fmu.inspect` checks an extracted FMU before a host loads it. Names are
imported from their module on first use (pythonfmu and the compilers are only
needed when building).

Import from the package (``from bodyvib.fmu import build``): the names below are its
public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_MODULES = {
    "builder": ("BACKENDS", "build"),
    "pythonfmu": ("build_fmu", "build_source_fmu"),
    "native": ("PLATFORMS", "NativeModel", "build_native_fmu", "native_model"),
    "native_table": ("build_native_source_fmu",),
    "controller": ("build_controller_fmu",),
    "description": ("ModelDescription", "validate_fmu_file"),
    "inspect": ("check_elf", "check_extracted_fmu"),
    "contents": ("RUNTIME_DIR", "fmu_src_dir", "native_dir"),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
