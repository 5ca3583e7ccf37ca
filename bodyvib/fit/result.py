"""The result of a refit and its parameter file, with provenance.

:func:`write_parameter_file` writes a :class:`FitResult` as a parameter file of
the reduced model, with its provenance (objective values, seed, algorithm,
reference, date, package version), that ``load_model``, ``bodyvib frf
--models`` and ``build_fmu.py --params`` read.
"""

import datetime
from dataclasses import dataclass, field
from typing import Dict, List

from .. import __version__
from ..models import save_model
from ..runtime.network import Network
from .config import FitConfig
from .objective import FitTarget, objective_time_domain
from .space import reduced_network

__all__ = [
    "FitResult",
    "write_parameter_file",
]


@dataclass
class FitResult:
    """Outcome of :func:`~bodyvib.fit.search.fit`.

    Attributes
    ----------
    parameters : dict of str to float
        Fitted reduced-model parameters (SI).
    objective : float
        Final objective (frequency-domain form), 1/s.
    objective_table2 : float
        The paper's Table 2 parameters on the same objective, 1/s.
    ga_objective : float
        Best run's objective from the search (the GA by default), before the
        polish.
    relative_error : float
        ``objective / target.energy()``.
    target : FitTarget
    seed : int
    config : FitConfig
        The configuration the search ran with.
    polished : bool
    evaluations : int
        Objective evaluations (individual parameter sets) in the GA and polish.
    elapsed_s : float
        Wall time of the search.
    history : list of float
        Best objective after each generation.
    at_bounds : list of str
        Searched ratios that ended within 0.1 % (in log) of a bound.
    runs : list of dict
        Per search (``restarts`` of them): its seed, its best objective, the
        objective after the polish, its evaluations, generations and why it
        stopped; the best run is the result.
    method : str
        The search method (:data:`bodyvib.fit.methods.METHODS`).
    """

    parameters: Dict[str, float]
    objective: float
    objective_table2: float
    ga_objective: float
    relative_error: float
    target: FitTarget
    seed: int
    config: FitConfig
    polished: bool
    evaluations: int
    elapsed_s: float
    history: List[float] = field(default_factory=list)
    at_bounds: List[str] = field(default_factory=list)
    runs: List[dict] = field(default_factory=list)
    method: str = "ga"

    def to_dict(self) -> dict:
        """The result as a JSON-ready dict.

        The target is summarized (``name``, ``kind``, ``description``,
        ``pairs``, ``total_mass``, ``modulus_only``, ``reference_model``,
        ``measured_data``) rather than copied with its quadrature arrays.
        """
        t = self.target
        return {
            "parameters": dict(self.parameters),
            "objective": self.objective,
            "objective_table2": self.objective_table2,
            "ga_objective": self.ga_objective,
            "relative_error": self.relative_error,
            "target": {
                "name": t.name,
                "kind": t.kind,
                "description": t.description,
                "pairs": dict(t.pairs),
                "total_mass": t.total_mass,
                "modulus_only": t.modulus_only,
                "reference_model": t.reference.name if t.reference is not None else None,
                "measured_data": t.measured.source if t.measured is not None else None,
            },
            "seed": self.seed,
            "config": self.config.to_dict(),
            "polished": self.polished,
            "evaluations": self.evaluations,
            "elapsed_s": self.elapsed_s,
            "history": [float(x) for x in self.history],
            "at_bounds": list(self.at_bounds),
            "runs": [dict(r) for r in self.runs],
            "method": self.method,
        }


def write_parameter_file(result: FitResult, path, command: str = "") -> Network:
    """Write the fitted model as a reduced-model parameter file with its provenance.

    The file is a normal bodyvib model (same topology as ``reduced-paper``),
    so :func:`bodyvib.models.load_model`, ``bodyvib frf --models FILE`` and
    ``python build_fmu.py --params FILE`` read it. Written atomically.

    Parameters
    ----------
    result : FitResult
    path : str or os.PathLike
    command : str
        The command line that made it (recorded in the provenance).

    Returns
    -------
    Network
        The model as written.
    """
    from .methods import describe

    t = result.target
    name = f"reduced-refit-{t.name}"
    prov = {
        "source": f"{'GA' if result.method == 'ga' else result.method} refit of the reduced "
        "3-DOF model of Balci & Gundogdu (2025), Fig. 2, by "
        "'bodyvib fit' (bodyvib.fit.search)",
        "command": command,
        "date": datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat(),
        "bodyvib_version": __version__,
        "target": t.description,
        "reference_model": t.reference.name if t.reference is not None else None,
        "measured_data": t.measured.source if t.measured is not None else None,
        "objective": {
            "definition": "paper Eq. 3: J = sum_p w_p int_0^inf (h_ref,p(t) - h_red,p(t))^2 dt, "
            "h = position response to a unit impulse of seat displacement [1/s]; "
            "evaluated by Parseval, 2 int_0^inf |H_ref - H_red|^2 df"
            + (" (measured band only, trapezoid on the data)" if t.kind == "measured" else "")
            + (" on moduli only (no phase)" if t.modulus_only else ""),
            "pairs": dict(t.pairs),
            "value_per_s": result.objective,
            "relative_to_target_energy": result.relative_error,
            "table2_value_per_s": result.objective_table2,
            "search_value_before_polish_per_s": result.ga_objective,
        },
        "scale_pinning": {
            "total_mass_kg": t.total_mass,
            "how": (
                "m1 + m2 pinned to the reference model's static apparent mass"
                if t.kind == "model"
                else "m1 + m2 pinned to total_mass (75 kg by default)"
            )
            + "; every transmissibility is invariant to scaling all m, k, c by one "
            "factor, so the fit searched only the six ratios m1/M, k1/M, k2/M, ks/M, "
            "c1/M, c2/M",
        },
        "algorithm": {
            "method": result.method,
            "library": describe(result.method),
            "seed": result.seed,
            "restarts": getattr(result.config.restarts, t.kind),
            "settings": result.config.settings(result.method).to_dict(),
            "bounds_per_kg_total_mass": result.config.to_dict()["bounds_per_kg_total_mass"],
            "search_space": (
                "log10 of the six ratios within the bounds, searched as "
                + (
                    "log(m1/M), log(k1/m1), log(k2/M), log(ks/M), log(c1/m1), log(c2/M)"
                    if result.config.settings(result.method).coordinates == "aligned"
                    else "themselves"
                )
            ),
            "polish": (
                dict(result.config.polish.to_dict(), enabled=True)
                if result.polished
                else {"enabled": False}
            ),
            "quadrature": result.config.quadrature.to_dict(),
            "runs": [dict(r) for r in result.runs],
            "evaluations": result.evaluations,
            "wall_time_s": round(result.elapsed_s, 3),
        },
        "at_bounds": list(result.at_bounds),
    }
    if t.kind == "model":
        net = reduced_network(result.parameters)
        prov["objective"]["time_domain_value_per_s"] = objective_time_domain(
            t.reference, net, t.pairs, config=result.config
        )
    description = (
        f"Reduced 3-DOF seated human-body model (topology of Balci & Gundogdu 2025, Fig. 2: "
        f"seat --ks-- platform --(k2 || c2)-- torso m2 --(k1 || c1)-- head m1), parameters "
        f"refitted by {'a genetic algorithm' if result.method == 'ga' else result.method} "
        f"to {t.description}; total mass pinned to "
        f"{t.total_mass:g} kg."
    )
    net = reduced_network(result.parameters, name=name, description=description, provenance=prov)
    save_model(net, path)
    return net
