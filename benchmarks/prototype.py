"""The thesis' prototype observations as the model computes them, shared by the studies that compare a model with
them (``benchmarks/studies/thesis_claims.py``, ``benchmarks/studies/boundaries.py``).

The observations (the thesis' prototype experiments, Table 3.1 prototype): the vent that restored a 5 mm trim
(0.048 MPa), the two-prototype converse (0.192 MPa), the reading's rise with Q at every contact ratio, the
softening law k(Q) = −1.337 Q + 0.9958, the extension Δl(Q) and the calibration factor ξ of the simulated strain to
the real gauge, 3.8 at a = 1 and 4.0 at a = 0.5 (the thesis' FE against the prototype); see those scripts'
docstrings.
"""

from __future__ import annotations

import numpy as np

from whisker_opt.calibration.forward import RestoreSearch, SceneSimulator, predict
from whisker_opt.calibration.measurements import Restore

#: name -> run-file settings of the mechanism (the defaults of each key are in docs/config.md)
MECHANISMS: dict[str, tuple[str, ...]] = {
    "clamped (as before)": (),
    "axial base": ("scene.base_support=axial",),
    "sliding base": ("scene.base_support=sliding",),
    "grip 2 mm": ("scene.base_support=grip", "scene.base_grip_depth=2"),
    "compliant base (h = 2 mm)": ("scene.base_support=compliant",),
    "compliant base (h = 10 mm)": ("scene.base_support=compliant", "scene.base_k_n=0.118", "scene.base_k_t=0.028"),
    "bonded gauge": ("scene.gauge_patch=bonded",),
    "bonded gauge (modulus / 10)": ("scene.gauge_patch=bonded", "scene.patch_modulus=210"),
    "cap of Dragon Skin 30": ("material.cap_rubber=yeoh_dragon_skin_30",),
    "compliant cap (k_j = 2)": ("material.cap_joint=compliant",),
    "compliant cap (k_j = 0.4)": ("material.cap_joint=compliant", "material.cap_joint_k=0.4"),
    "softened rubber (C10 = 0.10)": ("material.C10=0.10",),
    "grip 2 mm + bonded gauge": ("scene.base_support=grip", "scene.base_grip_depth=2", "scene.gauge_patch=bonded"),
    "compliant base (h = 10) + bonded gauge": ("scene.base_support=compliant", "scene.base_k_n=0.118",
                                               "scene.base_k_t=0.028", "scene.gauge_patch=bonded"),
    "compliant base (h = 10) + compliant cap (0.4)": ("scene.base_support=compliant", "scene.base_k_n=0.118",
                                                      "scene.base_k_t=0.028", "material.cap_joint=compliant",
                                                      "material.cap_joint_k=0.4"),
    "compliant base (h = 10) + softened rubber": ("scene.base_support=compliant", "scene.base_k_n=0.118",
                                                  "scene.base_k_t=0.028", "material.C10=0.10"),
    # the backing's modulus that configs/calibrate_base_gauge.yaml fits on the sensitivity ratios
    "compliant base (h = 10) + bonded gauge (calibrated)": ("scene.base_support=compliant", "scene.base_k_n=0.118",
                                                            "scene.base_k_t=0.028", "scene.gauge_patch=bonded",
                                                            "scene.patch_modulus=7157"),
}

A_VALUES = (0.45, 0.55, 0.7, 0.85, 1.0)
Q_VALUES = (0.0, 0.002, 0.05, 0.1, 0.15, 0.2)


#: The thesis' ξ, the real gauge's reading over its FE's strain, at a = 1 and a = 0.5.
XI = {1.0: 3.8, 0.5: 4.0}


def k_law(q: float) -> float:
    """The thesis' softening law k(Q) = −1.337 Q + 0.9958."""
    return -1.337 * q + 0.9958


def trim_effects_required() -> dict[str, float]:
    """The trim effect T(Q) = ε(65, Q)/ε(70, Q) each restore observation needs if the 70 mm whisker's pressure
    effect is the softening law's, ε(70, Q2)/ε(70, Q1) = k(Q1)/k(Q2):

    * the vent, ε(65, 0.048) = ε(70, 0.1): T(0.048) = k(0.048)/k(0.1);
    * the converse, ε(70, 0.192) = ε(65, 0.1): T(0.1) = k(0.1)/k(0.192).
    """
    return {"vent T(0.048)": k_law(0.048) / k_law(0.1), "converse T(0.1)": k_law(0.1) / k_law(0.192)}


def claims(cfg, search: RestoreSearch) -> dict:
    """Every model value the table needs, for one model."""
    sim = SceneSimulator(deflection=1.0)
    vent = Restore("vent", "-", trim_ref=0.0, Q_ref=0.1, trim=5.0, Q=0.048, a=1.0, delta=1.0, sigma=0.005)
    conv = Restore("conv", "-", trim_ref=5.0, Q_ref=0.1, trim=0.0, Q=0.192, a=1.0, delta=1.0, sigma=0.005)
    out = {"vent": predict(vent, cfg, sim, search), "conv": predict(conv, cfg, sim, search)}
    eps = np.array([[float(sim.reading(cfg, 0.0, q, a, [1.0])[0]) for q in Q_VALUES] for a in A_VALUES])  # (n_a, n_Q)
    out["eps"] = eps
    out["dl"] = {q: sim.extension(cfg, 0.0, q) for q in (0.05, 0.1, 0.2)}
    out["eps65"] = {q: float(sim.reading(cfg, 5.0, q, 1.0, [1.0])[0]) for q in (0.0, 0.048, 0.1)}
    out["eps70_vent"] = float(sim.reading(cfg, 0.0, 0.048, 1.0, [1.0])[0])  # for the trim effect at the vent's Q
    out["eps_a05"] = float(sim.reading(cfg, 0.0, 0.0, 0.5, [1.0])[0])  # for ξ's dependence on a (ξ at a = 0.5, 1)
    out["scenes"] = sim.solved
    return out
