"""``compliant``: the base face on elastic supports, normal and tangential springs per area (a Winkler layer).

The base face x = 0 rests on distributed springs (:class:`fem.problem.ElasticSupport`, energy
Π_s = ½ ∫ [k_n (u·n0)² + k_t |u − (u·n0) n0|²] dA, :mod:`fem.support`) of stiffness k_n = ``scene.base_k_n``
and k_t = ``scene.base_k_t`` [N/mm³]: the compliance of what holds the whisker beyond the meshed body, modelled
as a layer of the rubber itself of thickness h between the base face and a rigid holder floor (the rubber
pressed into the socket). No node is prescribed: the springs hold all six rigid motions.

Stiffness of such a layer (the numbers below are for the default rubber, C10 = 0.14 MPa: μ = 0.28 MPa,
E = 3μ = 0.84 MPa, and the default base diameter D = 18 mm):

- shear: k_t = μ/h, exact for a thin layer whose faces are held (simple shear; Gent 2001, *Engineering with
  Rubber*, 2nd ed., ch. 3).
- compression: k_n = E'/h with E' between E (a layer free to bulge at its rim, no friction on the floor) and
  the bonded-block compression modulus E_c = E (1 + 2 S²) of a disc of shape factor S = D/(4h) (loaded area
  over free rim area; Gent & Lindley 1959, Proc. IMechE 173, 111; Gent 2001 ch. 3); a layer also confined at
  its rim by the socket's wall has E' = K + 4μ/3 ≈ K ≈ 1-2 GPa for rubbers (Gent 2001), i.e. k_n of 10² to 10³
  N/mm³ and more, which is the ``clamped`` base for this rubber.
- h, the rubber between the meshed base face and the holder's rigid floor: 1 to 10 mm, an **estimate** (no
  measurement of the prototype's holder exists): at least the fitting clearance and one printed layer of a
  3-D-printed socket, at most a socket as deep as the base's radius D/2 = 9 mm.

So k_t ≈ 0.028 to 0.28 N/mm³ and k_n ≈ 0.084 (E/h, h = 10 mm) to 35 N/mm³ (E_c/h, h = 1 mm, S = 4.5) for a
layer that can bulge; the defaults are the bonded disc of h = 2 mm: k_n = E (1 + 2 S²)/h = 4.67 N/mm³
(S = 2.25) and k_t = μ/h = 0.14 N/mm³. The run file allows 0 < k ≤ 10⁴ N/mm³ for both, enough to reach the
clamp (a test checks that k = 10⁴ reproduces it).

In bending the supports turn the base face by θ = M/(k_n I_face) under a moment M (a rigid face on a Winkler
foundation, I_face its second moment of area about the bending axis), so a cantilever of length L under a tip
force F deflects by F L²/(k_n I_face) more than on a clamp, plus F/(k_t A) from the face's shear slip.
"""

from __future__ import annotations

from geometry.design import WhiskerDesign
from geometry.materials import RUBBER_C10

NAME = "compliant"
ORDER = 4
DESCRIPTION = "the base face on elastic supports of normal and tangential stiffness base_k_n, base_k_t per area"
PARAMETERS: tuple[str, ...] = ("base_k_n", "base_k_t")

#: Estimated thickness range of the rubber layer in the holder [mm] and the defaults' thickness (docstring).
LAYER_THICKNESS: tuple[float, float] = (1.0, 10.0)
LAYER_DEFAULT = 2.0
_MU = 2.0 * RUBBER_C10  # shear modulus of the default rubber [MPa]
_SHAPE = WhiskerDesign().D / (4.0 * LAYER_DEFAULT)  # shape factor S = D/(4h) of the default design's base disc
#: Default normal stiffness per area [N/mm³]: E (1 + 2 S²)/h of a bonded disc of the default thickness.
K_N_DEFAULT = 3.0 * _MU * (1.0 + 2.0 * _SHAPE**2) / LAYER_DEFAULT
#: Default tangential stiffness per area [N/mm³]: μ/h.
K_T_DEFAULT = _MU / LAYER_DEFAULT
#: What the run file allows for either stiffness [N/mm³]: (lower bound, excluded; upper bound).
K_RANGE: tuple[float, float] = (0.0, 1e4)


def hold(wm, spec):
    """No displacement set; one elastic support on the base face's faces."""
    import numpy as np

    from fem.problem import ElasticSupport
    from whisker_opt.experiment.bases import BaseHold

    base = np.asarray(wm.node_sets["base"], dtype=np.int64)
    return BaseHold((), (ElasticSupport(wm.face_sets["base"], spec.base_k_n, spec.base_k_t, "base springs"),), base)
