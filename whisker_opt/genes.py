"""The decision vector of the optimiser and how a genome becomes a whisker design.

A genome is x = [α, l, t, Q_i]: the cone half-angle α [deg] (the design's ``alpha``),
the x where the chamber ends l [mm], the wall thickness t [mm] and the initial chamber
pressure Q_i [MPa]. Every other geometric parameter comes from the run file's ``design``
section. This module is the one place that maps genes onto design fields.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Literal, Mapping

#: The decision vector, in this order.
GENE_NAMES: tuple[str, ...] = ("alpha", "l", "t", "Q_i")
GeneName = Literal["alpha", "l", "t", "Q_i"]

#: The genes that are fields of :class:`geometry.design.WhiskerDesign` (Q_i is a load, not geometry).
GEOMETRY_GENES: tuple[str, ...] = ("alpha", "l", "t")


def design_from_genes(base, genes: Mapping[str, float], trim: float = 0.0):
    """The design of a genome: ``base`` with α, l, t from ``genes`` and the given trim.

    Parameters
    ----------
    base : geometry.design.WhiskerDesign
        Supplies every parameter that is not a gene.
    genes : mapping
        At least ``alpha`` [deg], ``l`` and ``t`` [mm] (numbers or numeric strings).
    trim : float
        Length cut off the tip [mm].

    Returns
    -------
    geometry.design.WhiskerDesign
        Not validated (call ``validate()``).
    """
    return replace(base, trim=float(trim), **{g: float(genes[g]) for g in GEOMETRY_GENES})


def genes_dict(values) -> dict[str, float]:
    """``{name: float}`` of a genome given in :data:`GENE_NAMES` order."""
    return {n: float(x) for n, x in zip(GENE_NAMES, values)}
