"""The run's own rubber law, for a stress that an older result file does not store.

The viewer shows the arrays the solver stored (:mod:`whisker_opt.output.scenes`); only when a
file lacks one does it compute it, and then with the law the run was solved with: the
``material`` section of the run's ``config.yaml`` (``rubber``, ``cap_rubber``, ``C10``, ``D1``, ``cap_joint``)
made into a law by the one registry of rubbers,
:func:`whisker_opt.experiment.rubber_laws.rubber_material`. A cap of another rubber needs the cap's
end c [mm]: the file's own ``design_c`` field data, else the scene's design, else the
config's ``design.c``. Under a wall law other than ``embedded`` that is the rubber alone: the law's
scaling and frozen stress are in the stored stress only (:func:`fem.post.problem_strain_stress`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any, Mapping

import numpy as np

from fem.material import IsochoricI1Material
from whisker_opt.experiment.caps.compliant import K_DEFAULT as CAP_JOINT_K_DEFAULT
from whisker_opt.viewer.sceneinfo import finite_float

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class RunRubber:
    """The rubber of a run, as its config names it (:class:`whisker_opt.config.model.MaterialConfig`).

    Attributes
    ----------
    rubber, cap_rubber : str
        :attr:`whisker_opt.experiment.spec.SceneSpec.rubber`, ``cap_rubber``.
    c10 : float
        [MPa].
    d1 : float
        [1/MPa].
    c : float or None
        The config's cap end ``design.c`` [mm] (None when unknown).
    cap_joint : str
        :attr:`whisker_opt.experiment.spec.SceneSpec.cap_joint`.
    cap_joint_k : float
        [N/mm³], the 'compliant' joint's stiffness.
    """

    rubber: str
    cap_rubber: str
    c10: float
    d1: float
    c: float | None = None
    cap_joint: str = "tied"
    cap_joint_k: float = CAP_JOINT_K_DEFAULT

    @property
    def has_cap_law(self) -> bool:
        """The cap is of another law than the body, or scaled by a joint that is not tied."""
        return self.cap_rubber not in ("same", self.rubber) or self.cap_joint != "tied"

    def law(self, points: np.ndarray, cells: np.ndarray, c: float | None = None) -> IsochoricI1Material | None:
        """The law on a TET10 mesh (one row per cell when the cap is of another rubber).

        Parameters
        ----------
        points : ndarray, shape (n_nodes, 3)
            Reference coordinates [mm].
        cells : ndarray, shape (n_el, 10)
        c : float, optional
            The cap's end [mm] (default :attr:`c`); the cap's elements are
            :func:`whisker_opt.experiment.spec.cap_elements`.

        Returns
        -------
        fem.material.IsochoricI1Material or None
            None (logged) for a cap of another rubber whose end c is unknown.
        """
        from whisker_opt.experiment.rubber_laws import rubber_material
        from whisker_opt.experiment.spec import cap_elements

        c = self.c if c is None else c
        if self.has_cap_law and c is None:
            logger.warning("the cap's end c is unknown: no law for a cap of %s on a body of %s", self.cap_rubber,
                           self.rubber)
            return None
        cap = (cap_elements(SimpleNamespace(points=np.asarray(points, dtype=float), cells=np.asarray(cells)), c)
               if self.has_cap_law else np.zeros(len(cells), dtype=bool))
        factor = 1.0
        if self.cap_joint != "tied":
            from whisker_opt.experiment.cap_joints import cap_factor
            from whisker_opt.experiment.rubber_laws import cap_law

            factor = cap_factor(self.cap_joint, self, c, cap_law(self.rubber, self.cap_rubber, self.c10,
                                                                   self.d1).shear_modulus)
        return rubber_material(self.rubber, self.cap_rubber, self.c10, self.d1, cap, factor)


def run_rubber(config: Mapping[str, Any]) -> RunRubber | None:
    """The rubber of a run's ``config.yaml`` (a plain mapping); None without a config or when its
    ``material`` section does not validate (logged).

    A config without a ``material`` section stands for the defaults, which the run was solved with.
    """
    if not config:
        return None
    from pydantic import ValidationError

    from whisker_opt.config.model import MaterialConfig, format_validation_error

    try:
        m = MaterialConfig.model_validate(config.get("material") or {})
    except ValidationError as exc:
        logger.warning("the run's config.yaml has no usable material section; stresses are shown only as "
                       "stored:\n%s", format_validation_error(exc, "config.yaml"))
        return None
    design = config.get("design")
    c = finite_float(design.get("c")) if isinstance(design, dict) else None
    if c is None:
        from geometry.design import WhiskerDesign

        c = float(WhiskerDesign().c)
    return RunRubber(m.rubber, m.cap_rubber, float(m.C10), float(m.D1), c, m.cap_joint, float(m.cap_joint_k))


def cap_end(grid, design: Mapping[str, Any] | None = None) -> float | None:
    """The cap's end c [mm] of a state file: its ``design_c`` field data (written with every solved
    scene, :func:`whisker_opt.output.scenes.scene_metadata`), else ``design['c']``, else None."""
    arr = grid.field_data.get("design_c") if hasattr(grid, "field_data") else None
    if arr is not None and np.size(arr) == 1:
        c = finite_float(np.ravel(arr)[0])
        if c is not None:
            return c
    return finite_float(design.get("c")) if design else None
