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

_HOME = {
    # the car
    "CAR_DIR": "quarter_car",
    "load_car": "quarter_car",
    "seated_system": "quarter_car",
    # the seat as a part
    "load_seat": "seats",
    "mount_seat": "seats",
    "car_with_seat": "seats",
    "seat_transmissibility": "seat_response",
    "seat_value": "seat_response",
    # the FMUs of a run
    "FMUS": "fmus",
    "build_fmus": "fmus",
    "build_project_fmu": "fmus",
    "load_fmu_model": "fmus",
    "temporary_fmu_dir": "fmus",
    # active suspension control
    "SkyhookController": "control",
    "skyhook": "control",
    "closed_loop_model": "control",
    "compare_laws": "active",
    # the co-simulation
    "Master": "cosim",
    "Slave": "cosim",
    "open_fmu": "cosim",
    "check_fmu": "cosim",
    "model_from_fmu": "cosim",
    "cosimulate": "cosim",
    "write_csv": "cosim",
    "CsvStream": "cosim",
    "Record": "records",
    # the signals a run records
    "Signal": "signals",
    "SIGNALS": "signals",
    "UNITS": "signals",
    "header": "signals",
    "axis_label": "signals",
    # the exact reference and the check against it
    "reference_run": "reference",
    "ReferenceStream": "reference",
    "nrmse": "reference",
    "seat_force_weights": "reference",
    "TOLERANCES": "check",
    "Criterion": "check",
    "Comparison": "check",
    "compare": "check",
    # studies
    "BodyRun": "study",
    "Study": "study",
    "StudyCsv": "study",
    "StudyOptions": "study",
    "check_settings": "study",
    "run_study": "study",
    "coupling_error_sweep": "study",
    "format_report": "report",
    "study_json": "report",
    "plot_study": "study_plot",
    # the system structure (SSP) of the co-simulation
    "write_ssp": "ssp",
    "system_structure": "ssp",
}

#: Subpackages, imported on first use like the names.
_SUBPACKAGES = ("road", "sweep")

__all__, __getattr__, __dir__ = lazy_exports(__name__, _HOME, _SUBPACKAGES)
