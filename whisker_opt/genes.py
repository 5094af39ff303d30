"""The decision vector of the optimiser and how a genome becomes a whisker design and its scene.

The default genome is x = [α, l, t, Q_i]: the cone half-angle α [deg] (the design's ``alpha``),
the x where the chamber ends l [mm], the wall thickness t [mm] and the initial chamber
pressure Q_i [MPa]. A run file may add genes (``optimiser.genes.<name>: [lo, hi]``): any real
number of the ``design`` section (e.g. ``L``, ``D``, ``fibre_pitch``, ``fibre_radius_frac``) or of
the ``material`` section (``C10``, ``D1``, ``wall_slope``), named by its run-file key; they follow
the four in the order written. Every parameter that is not a gene comes from the run file. This
module is the one place that maps genes onto design and material fields.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cache
from types import MappingProxyType
from typing import Literal, Mapping

#: The default decision vector, in this order (every genome starts with it).
GENE_NAMES: tuple[str, ...] = ("alpha", "l", "t", "Q_i")
GeneName = Literal["alpha", "l", "t", "Q_i"]

#: The genes that are fields of :class:`geometry.design.WhiskerDesign` (Q_i is a load, not geometry).
GEOMETRY_GENES: tuple[str, ...] = ("alpha", "l", "t")

#: The run-file sections whose real numbers may be genes.
GENE_SECTIONS: tuple[str, ...] = ("design", "material")
#: The ``material`` keys (fields of :class:`whisker_opt.experiment.spec.SceneSpec`) that may be genes.
MATERIAL_GENE_FIELDS: tuple[str, ...] = ("c10", "d1", "wall_slope")


@dataclass(frozen=True)
class GeneKey:
    """A run-file key a gene may take, and where its value goes.

    Parameters
    ----------
    name : str
        The gene: its run-file key (``alpha``, ``fibre_pitch``, ``C10``, ...), or ``Q_i``.
    section : {'design', 'material', 'load'}
        ``design``: a field of :class:`geometry.design.WhiskerDesign`; ``material``: a field of
        :class:`whisker_opt.experiment.spec.SceneSpec`; ``load``: the intact scene's pressure Q.
    field : str
        The dataclass field the value is written to.
    unit : str
    bounds : tuple of (str, float)
        The key's allowed range as ``gt``/``ge``/``lt``/``le`` limits.
    """

    name: str
    section: str
    field: str
    unit: str
    bounds: tuple[tuple[str, float], ...]

    def range_text(self) -> str:
        """The allowed range, e.g. ``(0, 100]``."""
        b = dict(self.bounds)
        lo = f"[{b['ge']:g}" if "ge" in b else f"({b['gt']:g}" if "gt" in b else "(-inf"
        hi = f"{b['le']:g}]" if "le" in b else f"{b['lt']:g})" if "lt" in b else "inf)"
        return f"{lo}, {hi}"

    def admits(self, x: float) -> bool:
        """True when ``x`` lies in the key's allowed range."""
        checks = {"gt": float.__gt__, "ge": float.__ge__, "lt": float.__lt__, "le": float.__le__}
        return all(checks[k](float(x), float(v)) for k, v in self.bounds)


def _real_keys(cls, section: str, names: tuple[str, ...] | None = None) -> dict[str, GeneKey]:
    """The real-number user parameters of dataclass ``cls`` as gene keys (ints and words left out)."""
    from geometry.design import user_parameters

    out = {}
    for f in user_parameters(cls):
        if (names is not None and f.name not in names) or f.type not in ("float", float):
            continue
        m = f.metadata
        key = m["key"] or f.name
        out[key] = GeneKey(key, section, f.name, m["unit"], tuple(sorted(m["bounds"].items())))
    return out


@cache
def gene_keys() -> Mapping[str, GeneKey]:
    """Every key a gene may take, by name: the four default genes, then the design's and the material's
    real numbers (read-only; built once per process from the declared fields)."""
    from geometry.design import WhiskerDesign
    from whisker_opt.experiment.spec import Q_RANGE, SceneSpec

    design = _real_keys(WhiskerDesign, "design")
    material = _real_keys(SceneSpec, "material", MATERIAL_GENE_FIELDS)
    q = GeneKey("Q_i", "load", "Q", "MPa", (("ge", Q_RANGE[0]), ("le", Q_RANGE[1])))
    head = {g: design[g] for g in GEOMETRY_GENES}
    return MappingProxyType({**head, "Q_i": q, **design, **material})


def gene_key(name: str) -> GeneKey:
    """The key of gene ``name``.

    Raises
    ------
    ValueError
        One line naming the gene and the allowed names.
    """
    import difflib

    keys = gene_keys()
    if name not in keys:
        close = difflib.get_close_matches(str(name).lower(), [k.lower() for k in keys], n=1, cutoff=0.6)
        hint = f"did you mean {next(k for k in keys if k.lower() == close[0])!r}? " if close else ""
        raise ValueError(f"unknown key {name!r}: a gene is a real number of the design or material section; "
                         f"{hint}allowed: {', '.join(keys)}")
    return keys[name]


def check_gene_bounds(name: str, lo: float, hi: float) -> None:
    """Refuse bounds [lo, hi] of gene ``name`` that leave its key's allowed range.

    Raises
    ------
    ValueError
        One line naming the gene, the bounds and the allowed range.
    """
    key = gene_key(name)
    if not (key.admits(lo) and key.admits(hi)):
        raise ValueError(f"gene {name}: bounds [{lo:g}, {hi:g}] leave the allowed range {key.range_text()} "
                         f"of {key.section}.{name} [{key.unit}]")


def design_from_genes(base, genes: Mapping[str, float], trim: float = 0.0):
    """The design of a genome: ``base`` with its design genes from ``genes`` and the given trim.

    Parameters
    ----------
    base : geometry.design.WhiskerDesign
        Supplies every parameter that is not a gene.
    genes : mapping
        At least ``alpha`` [deg], ``l`` and ``t`` [mm] (numbers or numeric strings); any other
        design gene (:func:`gene_keys`) present is applied too, other names are ignored.
    trim : float
        Length cut off the tip [mm].

    Returns
    -------
    geometry.design.WhiskerDesign
        Not validated (call ``validate()``).
    """
    keys = gene_keys()
    fields = {g: float(genes[g]) for g in GEOMETRY_GENES}
    fields.update({keys[g].field: float(x) for g, x in genes.items()
                   if g in keys and keys[g].section == "design" and g not in GEOMETRY_GENES})
    return replace(base, trim=float(trim), **fields)


def spec_from_genes(base_spec, genes: Mapping[str, float], trim: float, Q: float):
    """The scene of a genome: ``base_spec`` with the genome's design (:func:`design_from_genes`), its
    material genes and the pressure ``Q``.

    Parameters
    ----------
    base_spec : whisker_opt.experiment.spec.SceneSpec
    genes : mapping
        Gene values by name.
    trim : float
        Length cut off the tip [mm].
    Q : float
        Chamber pressure of the scene [MPa].
    """
    keys = gene_keys()
    material = {keys[g].field: float(x) for g, x in genes.items() if g in keys and keys[g].section == "material"}
    return replace(base_spec, design=design_from_genes(base_spec.design, genes, trim), Q=float(Q), **material)


def genes_dict(values, names: tuple[str, ...] = GENE_NAMES) -> dict[str, float]:
    """``{name: float}`` of a genome given in ``names`` order (default :data:`GENE_NAMES`)."""
    return {n: float(x) for n, x in zip(names, values)}


def run_genome(cfg) -> tuple[str, ...]:
    """The genome a run declares: :data:`GENE_NAMES`, then the added genes of ``optimiser.genes`` in the
    order written.

    Parameters
    ----------
    cfg : whisker_opt.config.model.WhiskerConfig or whisker_opt.config.optimiser.OptimiserConfig
        A run file (:data:`GENE_NAMES` when it has no ``optimiser`` section) or its ``optimiser`` section.
    """
    opt = getattr(cfg, "optimiser", cfg)
    genes = getattr(opt, "genes", None)
    return tuple(genes.names()) if genes is not None else GENE_NAMES


def genome_of(genes: Mapping[str, float], names: tuple[str, ...], what: str = "genes") -> dict[str, float]:
    """``{name: float}`` of the genes ``names`` of a design, in that order (other entries dropped).

    Raises
    ------
    ValueError
        One line naming ``what``, the missing genes and the genome.
    """
    missing = [n for n in names if n not in genes]
    if missing:
        raise ValueError(f"{what}: missing gene(s) {', '.join(missing)} of the genome ({', '.join(names)})")
    return {n: float(genes[n]) for n in names}


def config_genome(cfg) -> dict[str, float]:
    """The values a run file gives its own genome (:func:`run_genome`): each gene's key of the ``design`` or
    ``material`` section, and Q_i from ``scene.Q_i``.

    Parameters
    ----------
    cfg : whisker_opt.config.model.WhiskerConfig
    """
    keys = gene_keys()
    out = {}
    for name in run_genome(cfg):
        key = keys[name]
        out[name] = float(cfg.scene.Q_i if key.section == "load" else getattr(getattr(cfg, key.section), name))
    return out
