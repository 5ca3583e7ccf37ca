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

_HOME = {
    "load_config": "config",
    "parse_pairs": "config",
    "FitConfig": "config",
    "FitTarget": "objective",
    "model_target": "objective",
    "measured_target": "objective",
    "objective_time_domain": "objective",
    "objective_frequency_domain": "objective",
    "GENES": "space",
    "genes_to_parameters": "space",
    "parameters_to_genes": "space",
    "METHODS": "methods",
    "SearchResult": "methods",
    "fit": "search",
    "polish": "search",
    "FitResult": "result",
    "write_parameter_file": "result",
    "compare_fit": "report",
    "write_report": "report",
    "ParetoFront": "pareto",
    "pareto_front": "pareto",
}

__all__, __getattr__, __dir__ = lazy_exports(__name__, _HOME)
