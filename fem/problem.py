"""The boundary-value problem: mesh, material, constraints and load definitions.

Load *magnitudes* (pressures, prescribed displacement values) are not part of a
:class:`Problem`; they live in :class:`fem.loads.LoadState`, so one problem (and its
sparsity pattern and factorisation analysis) serves a whole load path.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from fem.material import IsochoricI1Material
from fem.mesh import TetMesh


class ProblemError(ValueError):
    """Inconsistent problem definition (names the field and the offending value)."""


def _tri6_faces(owner: str, faces) -> np.ndarray:
    """``faces`` as a contiguous int64 (n_faces, 6) array, or a ProblemError naming ``owner``."""
    f = np.ascontiguousarray(faces, dtype=np.int64)
    if f.ndim != 2 or f.shape[1] != 6:
        raise ProblemError(f"{owner}.faces: shape {f.shape}, expected (n_faces, 6)")
    return f


@dataclass(frozen=True)
class Dirichlet:
    """Prescribed displacement components on a node set.

    Parameters
    ----------
    nodes : ndarray (k,) int
        Node indices.
    components : tuple of int
        Which of x=0, y=1, z=2 are prescribed (the others stay free).
    name : str
        Label for reports.
    """

    nodes: np.ndarray
    components: tuple[int, ...] = (0, 1, 2)
    name: str = "dirichlet"

    def __post_init__(self) -> None:
        nodes = np.unique(np.asarray(self.nodes, dtype=np.int64).ravel())
        object.__setattr__(self, "nodes", nodes)
        comps = tuple(int(c) for c in self.components)
        if not comps or any(c not in (0, 1, 2) for c in comps) or len(set(comps)) != len(comps):
            raise ProblemError(f"Dirichlet({self.name}).components={self.components!r}: allowed distinct values in (0, 1, 2)")
        object.__setattr__(self, "components", comps)

    @property
    def shape(self) -> tuple[int, int]:
        """Shape of the value array a load state supplies: (n_nodes, n_components)."""
        return (len(self.nodes), len(self.components))

    def dofs(self) -> np.ndarray:
        """Global displacement DOF indices (3·node + component), shape (k, n_comp)."""
        return 3 * self.nodes[:, None] + np.asarray(self.components)[None, :]


@dataclass(frozen=True)
class FollowerPressure:
    """A pressure that follows the deforming surface (traction t = −p n da).

    Parameters
    ----------
    faces : ndarray (n_f, 6) int
        6-node triangles (corners a, b, c, then mid-edges ab, bc, ca) ordered so
        that (b − a) × (c − a) points out of the solid. A positive pressure pushes
        into the solid, like the gas in an inflated cavity.
    name : str
    """

    faces: np.ndarray
    name: str = "pressure"

    def __post_init__(self) -> None:
        object.__setattr__(self, "faces", _tri6_faces(f"FollowerPressure({self.name})", self.faces))


@dataclass(frozen=True)
class DeadTraction:
    """A dead (configuration-independent) traction on reference boundary faces.

    The load state supplies the traction vector t0 [MPa, force per reference area];
    consistent nodal forces f_a = ∫ N_a t0 dA (reference area).

    Parameters
    ----------
    faces : ndarray (n_f, 6) int
        6-node triangles (any orientation; only the area is used).
    name : str
    """

    faces: np.ndarray
    name: str = "traction"

    def __post_init__(self) -> None:
        object.__setattr__(self, "faces", _tri6_faces(f"DeadTraction({self.name})", self.faces))


@dataclass(frozen=True)
class ElasticSupport:
    """Distributed linear springs on reference boundary faces (:mod:`fem.support`).

    Energy Π_s = ½ ∫_Γ [k_n (u·n0)² + k_t |u − (u·n0) n0|²] dA over the reference faces, n0 their
    reference unit normal: a Winkler foundation with a tangential spring.

    Parameters
    ----------
    faces : ndarray (n_f, 6) int
        6-node triangles (either orientation).
    k_n, k_t : float
        Normal and tangential stiffness per reference area [N/mm³], finite and >= 0.
    name : str
    """

    faces: np.ndarray
    k_n: float
    k_t: float
    name: str = "support"

    def __post_init__(self) -> None:
        object.__setattr__(self, "faces", _tri6_faces(f"ElasticSupport({self.name})", self.faces))
        for key in ("k_n", "k_t"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v >= 0):
                raise ProblemError(f"ElasticSupport({self.name}).{key}={v!r}: must be finite and >= 0 N/mm^3")
            object.__setattr__(self, key, float(v))


@dataclass(frozen=True)
class Membrane:
    """A thin elastic sheet bonded to reference boundary faces (:mod:`fem.membrane`).

    Energy Π_m = ∫_Γ0 t W(E_s) dA0 of the surface Green–Lagrange strain E_s, W the plane-stress Saint
    Venant–Kirchhoff energy (Y/(2(1 − ν²))) [(1 − ν) tr(E_s²) + ν (tr E_s)²].

    Parameters
    ----------
    faces : ndarray (n_f, 6) int
        6-node triangles (either orientation).
    thickness : float or ndarray (n_f, n_qp)
        Sheet thickness t [mm], finite and >= 0: one value, or one per face and point of the problem's
        triangle rule (:attr:`fem.membrane.MembraneKernel.points`), e.g. 0 outside a footprint.
    youngs_modulus : float
        Y [MPa], finite and > 0.
    poisson : float
        ν, in [0, 0.5).
    name : str
    """

    faces: np.ndarray
    thickness: object
    youngs_modulus: float
    poisson: float
    name: str = "membrane"

    def __post_init__(self) -> None:
        f = _tri6_faces(f"Membrane({self.name})", self.faces)
        object.__setattr__(self, "faces", f)
        t = np.asarray(self.thickness, dtype=np.float64)
        t = np.full((len(f), 1), float(t)) if t.ndim == 0 else np.ascontiguousarray(t)
        if t.ndim != 2 or t.shape[0] != len(f):
            raise ProblemError(f"Membrane({self.name}).thickness: shape {t.shape}, expected a number or "
                               f"(n_faces, n_qp) with n_faces = {len(f)}")
        if not np.all(np.isfinite(t)) or np.any(t < 0):
            raise ProblemError(f"Membrane({self.name}).thickness: must be finite and >= 0 mm")
        object.__setattr__(self, "thickness", t)
        if not (np.isfinite(self.youngs_modulus) and self.youngs_modulus > 0):
            raise ProblemError(f"Membrane({self.name}).youngs_modulus={self.youngs_modulus!r}: must be finite "
                               "and > 0 MPa")
        if not (0.0 <= self.poisson < 0.5):
            raise ProblemError(f"Membrane({self.name}).poisson={self.poisson!r}: must be in [0, 0.5)")
        object.__setattr__(self, "youngs_modulus", float(self.youngs_modulus))
        object.__setattr__(self, "poisson", float(self.poisson))


@dataclass(frozen=True)
class EmbeddedTrusses:
    """Truss fibres embedded in the host tets (no nodes of their own).

    Each fibre point is interpolated from its host element, x = Σ N_a(ξ) x_a. The
    segments are linear elastic in Green–Lagrange/2nd Piola–Kirchhoff form,
    S = E·E_GL, stored energy ½ E A L0 E_GL² per segment.

    Parameters
    ----------
    host_elements : ndarray (n_pts,) int
    local_coords : ndarray (n_pts, 3)
        ξ of each point in its host element.
    segments : ndarray (n_seg, 2) int
        Pairs of point indices.
    youngs_modulus : float
        MPa, > 0.
    area : float
        mm², > 0.
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    segments: np.ndarray
    youngs_modulus: float
    area: float
    name: str = "fibres"

    def __post_init__(self) -> None:
        he = np.ascontiguousarray(self.host_elements, dtype=np.int64).ravel()
        xi = np.ascontiguousarray(self.local_coords, dtype=np.float64).reshape(-1, 3)
        seg = np.ascontiguousarray(self.segments, dtype=np.int64).reshape(-1, 2)
        if len(he) != len(xi):
            raise ProblemError(
                f"EmbeddedTrusses({self.name}): {len(he)} host_elements but {len(xi)} local_coords"
            )
        if seg.size and (seg.min() < 0 or seg.max() >= len(he)):
            raise ProblemError(f"EmbeddedTrusses({self.name}).segments: index outside [0, {len(he) - 1}]")
        if not (self.youngs_modulus > 0):
            raise ProblemError(f"EmbeddedTrusses({self.name}).youngs_modulus={self.youngs_modulus!r} must be > 0 MPa")
        if not (self.area > 0):
            raise ProblemError(f"EmbeddedTrusses({self.name}).area={self.area!r} must be > 0 mm^2")
        object.__setattr__(self, "host_elements", he)
        object.__setattr__(self, "local_coords", xi)
        object.__setattr__(self, "segments", seg)


@dataclass(frozen=True)
class SmearedFibres:
    """Fibres smeared over elements as an anisotropic energy term (:mod:`fem.fibre_field`).

    Parameters
    ----------
    elements : ndarray (n_sel,) int
        Reinforced elements (each at most once).
    stiffness : ndarray (n_sel, n_qp)
        Fibre stiffness per volume k = E_f A_f ρ_L at each quadrature point [MPa], ≥ 0.
    directions : ndarray (n_sel, n_qp, 3)
        Unit reference fibre direction at each quadrature point.
    """

    elements: np.ndarray
    stiffness: np.ndarray
    directions: np.ndarray
    name: str = "smeared fibres"

    def __post_init__(self) -> None:
        el = np.ascontiguousarray(self.elements, dtype=np.int64).ravel()
        k = np.ascontiguousarray(self.stiffness, dtype=np.float64)
        a = np.ascontiguousarray(self.directions, dtype=np.float64)
        if k.ndim != 2 or k.shape[0] != len(el) or a.shape != k.shape + (3,):
            raise ProblemError(f"SmearedFibres({self.name}): stiffness {k.shape} and directions {a.shape} "
                               f"must be (n_sel, n_qp) and (n_sel, n_qp, 3) with n_sel = {len(el)}")
        if len(np.unique(el)) != len(el):
            raise ProblemError(f"SmearedFibres({self.name}).elements: an element is listed twice")
        if not np.all(np.isfinite(k)) or np.any(k < 0):
            raise ProblemError(f"SmearedFibres({self.name}).stiffness must be finite and >= 0 MPa")
        if a.size and not np.allclose(np.linalg.norm(a, axis=-1), 1.0, atol=1e-9):
            raise ProblemError(f"SmearedFibres({self.name}).directions must be unit vectors")
        object.__setattr__(self, "elements", el)
        object.__setattr__(self, "stiffness", k)
        object.__setattr__(self, "directions", a)


@dataclass(frozen=True)
class FrozenStress:
    """A prescribed second Piola–Kirchhoff stress on a set of elements (:mod:`fem.frozen_stress`).

    Parameters
    ----------
    elements : ndarray (n_sel,) int
        Elements that carry it (each at most once).
    stress : ndarray (n_sel, n_qp, 3, 3)
        Symmetric stress T at each quadrature point of the problem's tet rule [MPa].
    name : str
    nodal : ndarray (n_nodes, 3, 3), optional
        The same field at every node of the mesh [MPa] (0 away from ``elements``), for the stress of
        a solved state (:func:`fem.post.problem_strain_stress`), e.g. the law that gave ``stress``
        evaluated at the nodal deformation; default: ``stress`` extrapolated to the nodes
        (:func:`fem.post.frozen_stress_at_nodes`). The solve does not read it.
    """

    elements: np.ndarray
    stress: np.ndarray
    name: str = "frozen stress"
    nodal: np.ndarray | None = None

    def __post_init__(self) -> None:
        el = np.ascontiguousarray(self.elements, dtype=np.int64).ravel()
        T = np.ascontiguousarray(self.stress, dtype=np.float64)
        if T.ndim != 4 or T.shape[0] != len(el) or T.shape[2:] != (3, 3):
            raise ProblemError(f"FrozenStress({self.name}).stress: shape {T.shape}, expected (n_sel, n_qp, 3, 3) "
                               f"with n_sel = {len(el)}")
        if len(np.unique(el)) != len(el):
            raise ProblemError(f"FrozenStress({self.name}).elements: an element is listed twice")
        if not np.all(np.isfinite(T)) or not np.allclose(T, np.swapaxes(T, -1, -2), rtol=0, atol=1e-12 * max(1.0, np.abs(T).max(initial=0))):
            raise ProblemError(f"FrozenStress({self.name}).stress must be finite and symmetric")
        object.__setattr__(self, "elements", el)
        object.__setattr__(self, "stress", T)
        if self.nodal is not None:
            Tn = np.ascontiguousarray(self.nodal, dtype=np.float64)
            if Tn.ndim != 3 or Tn.shape[1:] != (3, 3) or not np.all(np.isfinite(Tn)):
                raise ProblemError(f"FrozenStress({self.name}).nodal: shape {Tn.shape}, expected finite (n_nodes, 3, 3)")
            object.__setattr__(self, "nodal", Tn)


@dataclass(frozen=True)
class Problem:
    """Mesh + material + constraints + load definitions (magnitudes excluded).

    Parameters
    ----------
    mesh : TetMesh
    material : IsochoricI1Material
    dirichlet : tuple of Dirichlet
        Their DOFs must not overlap.
    pressures : tuple of FollowerPressure
    trusses : tuple of EmbeddedTrusses
    tractions : tuple of DeadTraction
    fibre_fields : tuple of SmearedFibres
        Their arrays have one column per point of the tet rule of ``quadrature_degree``.
    supports : tuple of ElasticSupport
        Elastic surface supports (springs on faces); their faces are part of the topology, their
        stiffnesses are not.
    membranes : tuple of Membrane
        Thin sheets bonded to faces; their faces are part of the topology, their thickness and
        moduli are not.
    frozen_stresses : tuple of FrozenStress
        Prescribed stresses (one per quadrature point of the same rule); not part of the
        topology, so a problem that adds them shares its sparsity pattern and factorisation analysis.
    quadrature_degree : int
        Degree of the tet rule (2 → 4 points, as C3D10 in Abaqus/CalculiX).
    face_quadrature_degree : int
        Degree of the triangle rule for loaded faces.
    formulation : {'mixed', 'displacement'}
        'mixed' (default): P2/P0 u–p, locking-free, D1 ≥ 0. 'displacement': the
        volumetric energy (1/D1)(J − 1)² at every quadrature point (standard C3D10, as
        CalculiX; locks as D1 → 0; needs D1 > 0); element pressures are then inert.
    """

    mesh: TetMesh
    material: IsochoricI1Material
    dirichlet: tuple[Dirichlet, ...] = ()
    pressures: tuple[FollowerPressure, ...] = ()
    trusses: tuple[EmbeddedTrusses, ...] = ()
    tractions: tuple[DeadTraction, ...] = ()
    fibre_fields: tuple[SmearedFibres, ...] = ()
    frozen_stresses: tuple[FrozenStress, ...] = ()
    supports: tuple[ElasticSupport, ...] = ()
    membranes: tuple[Membrane, ...] = ()
    quadrature_degree: int = 2
    face_quadrature_degree: int = 4
    formulation: str = "mixed"
    _cache: dict = field(default_factory=dict, repr=False, compare=False, hash=False)

    def __post_init__(self) -> None:
        n = self.mesh.n_nodes
        for d in self.dirichlet:
            if d.nodes.size and (d.nodes.min() < 0 or d.nodes.max() >= n):
                raise ProblemError(f"Dirichlet({d.name}).nodes outside [0, {n - 1}]")
        for pr in self.pressures:
            if pr.faces.size and (pr.faces.min() < 0 or pr.faces.max() >= n):
                raise ProblemError(f"FollowerPressure({pr.name}).faces: node index outside [0, {n - 1}]")
        for dt in self.tractions:
            if dt.faces.size and (dt.faces.min() < 0 or dt.faces.max() >= n):
                raise ProblemError(f"DeadTraction({dt.name}).faces: node index outside [0, {n - 1}]")
        for sp in self.supports:
            if sp.faces.size and (sp.faces.min() < 0 or sp.faces.max() >= n):
                raise ProblemError(f"ElasticSupport({sp.name}).faces: node index outside [0, {n - 1}]")
        for mb in self.membranes:
            if mb.faces.size and (mb.faces.min() < 0 or mb.faces.max() >= n):
                raise ProblemError(f"Membrane({mb.name}).faces: node index outside [0, {n - 1}]")
        for tr in self.trusses:
            if tr.host_elements.size and (tr.host_elements.min() < 0 or tr.host_elements.max() >= self.mesh.n_elements):
                raise ProblemError(f"EmbeddedTrusses({tr.name}).host_elements outside [0, {self.mesh.n_elements - 1}]")
        for ff in self.fibre_fields:
            if ff.elements.size and (ff.elements.min() < 0 or ff.elements.max() >= self.mesh.n_elements):
                raise ProblemError(f"SmearedFibres({ff.name}).elements outside [0, {self.mesh.n_elements - 1}]")
        for fs in self.frozen_stresses:
            if fs.elements.size and (fs.elements.min() < 0 or fs.elements.max() >= self.mesh.n_elements):
                raise ProblemError(f"FrozenStress({fs.name}).elements outside [0, {self.mesh.n_elements - 1}]")
            if fs.nodal is not None and len(fs.nodal) != n:
                raise ProblemError(f"FrozenStress({fs.name}).nodal: {len(fs.nodal)} nodes, the mesh has {n}")
        if self.dirichlet:
            all_dofs = np.concatenate([d.dofs().ravel() for d in self.dirichlet])
            if len(np.unique(all_dofs)) != len(all_dofs):
                raise ProblemError("Problem.dirichlet: two Dirichlet sets prescribe the same DOF")
        if self.formulation not in ("mixed", "displacement"):
            raise ProblemError(f"Problem.formulation={self.formulation!r}: allowed 'mixed', 'displacement'")
        if self.formulation == "displacement" and not self.material.d1 > 0:
            raise ProblemError(f"Problem.formulation='displacement' needs material.d1 > 0 (got {self.material.d1})")
        if self.quadrature_degree < 2:
            raise ProblemError(f"Problem.quadrature_degree={self.quadrature_degree} must be >= 2")

    @property
    def n_u(self) -> int:
        """Number of displacement DOFs (3 per node)."""
        return 3 * self.mesh.n_nodes

    @property
    def n_dofs(self) -> int:
        """Displacement DOFs plus one pressure per element."""
        return self.n_u + self.mesh.n_elements

    def constrained_dofs(self) -> np.ndarray:
        """Sorted prescribed displacement DOFs."""
        if not self.dirichlet:
            return np.zeros(0, dtype=np.int64)
        return np.sort(np.concatenate([d.dofs().ravel() for d in self.dirichlet]))
