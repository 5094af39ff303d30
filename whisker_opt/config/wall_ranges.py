"""The chamber wall's laws against a run file: a law that no evaluation can use is refused at validation.

A wall law (:mod:`whisker_opt.wall.law`) reads ``material.wall_slope`` (the 'calibrated' law alone, where
c(Q) = 1 + s·Q must stay a stiffness) and, for a law of the stored table ('sliding'), the wall's (r_i, t)
at mid-chamber and the pressure, inside what the table holds
(:meth:`whisker_opt.wall.table.WallTable.span`). A run file whose design, scene pressure or gene box
leaves what its laws accept would fail in every evaluation that reaches it, after a run had started;
:func:`check_wall_laws` asks the laws themselves (:class:`~whisker_opt.wall.law.WallLaw` and its
:meth:`~whisker_opt.wall.law.WallLaw.factor`, the one home of these rules) at the design and at every
corner of the gene box, so that every command refuses such a file in one line before it does anything.
"""

from __future__ import annotations

import itertools
from typing import Any, Iterator

from geometry.design import WhiskerDesign
from whisker_opt.genes import GEOMETRY_GENES, design_from_genes, gene_keys
from whisker_opt.wall.law import WallLaw


def _law(name: str, slope: float, where: str) -> WallLaw:
    """The law ``name`` with ``slope``; its refusal prefixed by ``where`` (empty: as the law says it)."""
    try:
        return WallLaw(name, slope)
    except ValueError as exc:
        raise ValueError(f"{where}{exc}") from None


def _factor(law: WallLaw, Q: float, design: WhiskerDesign, where: str, chosen_by: str) -> None:
    """Refuse, naming ``where`` and the key that chose the law, a pressure or a wall at which ``law`` has no
    factor c(Q)."""
    try:
        law.factor(Q, design)
    except ValueError as exc:
        raise ValueError(f"{where} under the wall law {law.name!r} ({chosen_by}): {exc}") from None


def _corners(genes: Any) -> Iterator[dict[str, float]]:
    """Every corner of the gene box that changes a wall law's factor: the design genes and Q_i."""
    keys = gene_keys()
    names = [g for g in genes.names() if g == "Q_i" or g in GEOMETRY_GENES or keys[g].section == "design"]
    for values in itertools.product(*((genes.of(g).lo, genes.of(g).hi) for g in names)):
        yield dict(zip(names, values))


def _check_genes(genes: Any, laws: tuple[str, ...], chosen_by: str, slope: float, base: WhiskerDesign) -> None:
    """Each law the GA evaluates under, at every corner of the gene box (see the module docstring)."""
    box = (genes.of("wall_slope").lo, genes.of("wall_slope").hi) if "wall_slope" in genes.names() else None
    for name in laws:
        slopes = box or (slope if name == "calibrated" else 0.0,)  # the slope each law is given (wiring)
        for s in slopes:
            where = (f"optimiser.genes.wall_slope=[{box[0]:g}, {box[1]:g}] with the wall law {name!r} "
                     f"({chosen_by}): " if box else "")
            law = _law(name, s, where)
            if law.identity:
                continue
            slope_text = f", wall_slope={s:g}" if box else ""
            if name == "calibrated":  # c(Q) = 1 + s·Q reads no wall: the ends of Q_i alone
                for Q in (genes.of("Q_i").lo, genes.of("Q_i").hi):
                    _factor(law, Q, base, f"optimiser.genes: Q_i={Q:g}{slope_text}", chosen_by)
                continue
            for corner in _corners(genes):
                text = ", ".join(f"{g}={x:g}" for g, x in corner.items())
                _factor(law, corner["Q_i"], design_from_genes(base, corner),
                        f"optimiser.genes: the corner ({text}{slope_text}) of the gene box", chosen_by)


def check_wall_laws(cfg: Any) -> None:
    """Refuse a run file whose wall laws cannot be evaluated (see the module docstring).

    Parameters
    ----------
    cfg : whisker_opt.config.model.WhiskerConfig
        The validated sections; the optimiser's defaults stand in for an absent ``optimiser`` section.

    Raises
    ------
    ValueError
        One line naming the key (``material.wall_slope``, ``design`` with ``scene.Q_i``, or a corner of
        ``optimiser.genes``), its value and what the law allows.
    """
    from whisker_opt.config.optimiser import OptimiserConfig

    m = cfg.material
    law = _law(m.wall_law, m.wall_slope, "")
    base = WhiskerDesign(**cfg.design.model_dump())
    if not law.identity:
        shown = ", ".join(f"design.{g}={getattr(base, g):g}" for g in GEOMETRY_GENES)
        _factor(law, cfg.scene.Q_i, base, f"{shown} at scene.Q_i={cfg.scene.Q_i:g}", "material.wall_law")
    opt = cfg.optimiser if cfg.optimiser is not None else OptimiserConfig()
    if opt.wall_laws is not None:
        _check_genes(opt.genes, opt.wall_laws.laws, "optimiser.wall_laws", m.wall_slope, base)
    else:
        _check_genes(opt.genes, (m.wall_law,), "material.wall_law", m.wall_slope, base)
