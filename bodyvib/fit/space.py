"""The search space of the refit: genes and the reduced model's parameters.

The fit cannot find the absolute scale of the reduced model (scaling every m,
k and c by one factor leaves every transmissibility unchanged), so it
searches six ratios per kg of total mass, ``m1/M, k1/M, k2/M, ks/M, c1/M,
c2/M``, as base-10 logarithms (the genes), with ``M = m1 + m2`` pinned.
"""

from dataclasses import replace
from typing import Mapping, Optional

import numpy as np

from ..models import load_model
from ..runtime.network import Network

__all__ = [
    "REDUCED_PARAMETERS",
    "PAIR_ROLES",
    "GENES",
    "genes_to_parameters",
    "parameters_to_genes",
    "reduced_network",
]

#: Parameters of the reduced model, in the order of :mod:`bodyvib.analytic`.
REDUCED_PARAMETERS = ("m1", "m2", "k1", "k2", "c1", "c2", "ks")

#: Roles of the reduced model whose position responses the objective can pair.
PAIR_ROLES = ("head", "torso")

#: The searched quantities, each per kg of total mass M = m1 + m2 (log10 in the GA).
GENES = ("m1", "k1", "k2", "ks", "c1", "c2")


def genes_to_parameters(genes, total_mass: float) -> np.ndarray:
    """Search coordinates to reduced-model parameters.

    Parameters
    ----------
    genes : array_like, shape (..., 6)
        ``log10`` of ``m1/M, k1/M, k2/M, ks/M, c1/M, c2/M`` (:data:`GENES`).
    total_mass : float
        ``M = m1 + m2`` in kg.

    Returns
    -------
    ndarray, shape (..., 7)
        In :data:`REDUCED_PARAMETERS` order, SI.
    """
    v = 10.0 ** np.asarray(genes, dtype=float) * total_mass
    m1, k1, k2, ks, c1, c2 = (v[..., i] for i in range(6))
    return np.stack([m1, total_mass - m1, k1, k2, c1, c2, ks], axis=-1)


def parameters_to_genes(params) -> np.ndarray:
    """Inverse of :func:`genes_to_parameters` (the total mass is ``m1 + m2``)."""
    p = np.asarray(params, dtype=float)
    m1, m2, k1, k2, c1, c2, ks = (p[..., i] for i in range(7))
    M = m1 + m2
    return np.log10(np.stack([m1, k1, k2, ks, c1, c2], axis=-1) / M[..., None])


def reduced_network(
    params, name: str = "reduced-refit", description: str = "", provenance: Optional[dict] = None
) -> Network:
    """The reduced model (paper's topology) with the given parameters.

    Parameters
    ----------
    params : array_like (7,) or dict
        In :data:`REDUCED_PARAMETERS` order, or by name.
    name, description : str
    provenance : dict, optional

    Returns
    -------
    Network
    """
    template = load_model("reduced-paper")
    if not isinstance(params, Mapping):
        params = dict(zip(REDUCED_PARAMETERS, (float(v) for v in params)))
    net = template.with_parameters(**params)
    return replace(
        net,
        name=name,
        description=description or template.description,
        provenance=dict(provenance or {}),
    )
