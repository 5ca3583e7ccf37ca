"""vehicle: the quarter-car model, road profiles and the co-simulation with a body FMU.

The vehicle models are parameter files like the body models (see
:mod:`bodyvib.models`); :func:`load_car` loads them. A run co-simulates the body FMU on
the car FMU driven by a road (:func:`cosimulate`), is checked against the exact
reference of the same coupled system (:func:`reference_run`, :func:`compare`), and a
study runs every body on one road (:func:`run_study`, :func:`plot_study`). Roads are in
:mod:`bodyvib.vehicle.road`, sweeps of many cases in :mod:`bodyvib.vehicle.sweep`.

Import from the package (``from bodyvib.vehicle import cosimulate``): the names below
are its public interface, and the modules that hold them are internal and may move.
Names are imported from their module on first use, so ``import bodyvib.vehicle`` costs
nothing until a name is used (the command line imports only what a command needs).
"""

# One module identity: this folder installs as bodyvib.vehicle (pyproject.toml's package-dir).
# Imported as `vehicle` from a checkout it would be a second copy of every module, with
# its own classes and registries, so it refuses.
if __name__ != "bodyvib.vehicle":
    raise ImportError(
        f"import bodyvib.vehicle, not {__name__}: the repository's vehicle/ folder is the "
        "package bodyvib.vehicle (pip install -e . installs it so)"
    )


from bodyvib._lazy import lazy_exports

_MODULES = {
    # the car
    "quarter_car": ("CAR_DIR", "load_car", "seated_system"),
    # the seat as a part
    "seats": ("car_with_seat", "load_seat", "mount_seat"),
    "seat_response": ("seat_transmissibility", "seat_value"),
    "seat_motion": ("seat_axes", "seat_height", "seat_point"),
    # the FMUs of a run
    "fmus": ("FMUS", "build_fmus", "build_project_fmu", "load_fmu_model", "temporary_fmu_dir"),
    # active suspension control
    "control": ("SkyhookController", "closed_loop_model", "skyhook"),
    "active": ("compare_laws",),
    # the co-simulation
    "cosim": (
        "CsvStream",
        "Master",
        "Slave",
        "check_fmu",
        "cosimulate",
        "model_from_fmu",
        "open_fmu",
        "write_csv",
    ),
    "records": ("Record",),
    # the signals a run records
    "signals": ("SIGNALS", "UNITS", "Signal", "axis_label", "header"),
    # the exact reference and the check against it
    "reference": ("ReferenceStream", "nrmse", "reference_run", "seat_force_weights"),
    "check": ("TOLERANCES", "Comparison", "Criterion", "compare"),
    # studies
    "study": (
        "BodyRun",
        "Study",
        "StudyCsv",
        "StudyOptions",
        "check_settings",
        "coupling_error_sweep",
        "run_study",
    ),
    "report": ("format_report", "study_json"),
    "study_plot": ("plot_study",),
    # the system structure (SSP) of the co-simulation
    "ssp": ("system_structure", "write_ssp"),
}

#: Subpackages, imported on first use like the names.
_SUBPACKAGES = ("road", "sweep")

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES, _SUBPACKAGES)
