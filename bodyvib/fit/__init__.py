"""The refit of the reduced model: objective, search space, search methods, results.

:mod:`~bodyvib.fit.config` reads the settings, :mod:`~bodyvib.fit.space` maps genes to
the reduced model's parameters, :mod:`~bodyvib.fit.objective` defines the objective
(the impulse-response error and its Parseval form), :mod:`~bodyvib.fit.methods` holds
the searches (genetic algorithm, CMA-ES, differential evolution),
:mod:`~bodyvib.fit.search` runs seeded searches and polishes them,
:mod:`~bodyvib.fit.result` writes the parameter file with its provenance,
:mod:`~bodyvib.fit.report` and :mod:`~bodyvib.fit.pareto` compare and trade off.
Names are imported from their module on first use (the searches pull in DEAP,
CMA-ES and pymoo, which a plain ``import bodyvib`` should not pay for).

Import from the package (``from bodyvib.fit import fit``): the names in ``__all__``
are its public interface, and the modules that hold them are internal and may move.
"""

from bodyvib._lazy import lazy_exports

_MODULES = {
    "config": ("FitConfig", "load_config", "parse_pairs"),
    "objective": (
        "FitTarget",
        "measured_target",
        "model_target",
        "objective_frequency_domain",
        "objective_time_domain",
    ),
    "space": ("GENES", "genes_to_parameters", "parameters_to_genes"),
    "methods": ("METHODS", "SearchResult"),
    "search": ("fit", "polish"),
    "result": ("FitResult", "write_parameter_file"),
    "report": ("compare_fit", "write_report"),
    "pareto": ("ParetoFront", "pareto_front"),
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _MODULES)
