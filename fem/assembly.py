"""Vectorised residual/tangent assembly of the mixed u–p total-Lagrangian problem.

Discrete potential (P2 displacement, P0 element pressure p_e)::

    Π(u, p) = Σ_e [ ∫_e W_iso(F) dV + p_e ∫_e (J − 1) dV − (D1/4) p_e² V_e ]
              + Ψ_fibres(u) + Σ_e ½ C_e Ē_e² + Π_s(u) − W_ext(u)

(Ψ_fibres: embedded trusses, fem.truss; Σ_e ½ C_e Ē_e²: smeared fibres, fem.fibre_field; Π_s: elastic
surface supports, fem.support; Π_m, bonded membranes, fem.membrane, enters like Π_s.)

Stationarity gives (G = F⁻¹, ∂J/∂F = J Gᵀ)::

    R_u = ∫ (P_iso + p J G^T) : ∇_X δu dV + R_fibres + R_smeared + R_pressure
    R_p = ∫_e (J − 1) dV − (D1/2) p_e V_e

For D1 > 0 eliminating p_e gives p_e = 2(J̄_e − 1)/D1 with J̄_e the element mean of
J, i.e. the energy (1/D1)(J̄ − 1)² of a mean-dilatation element; D1 = 0 enforces
∫_e (J − 1) = 0. The P2/P0 pair does not lock (tests/test_fem_cook.py).
Simo, Taylor & Pister (1985); Bonet & Wood (2008) §8.6.

Tangent of the volumetric term: ∂(p J G_Ji)/∂F_kL = p J (G_Ji G_Lk − G_Jk G_Li).
"""

from __future__ import annotations


import numpy as np

from fem import element, jit
from fem.fibre_field import FibreFieldKernel
from fem.frozen_stress import FrozenStressKernel
from fem.membrane import MembraneKernel
from fem.pressure import PressureKernel
from fem.problem import Problem, ProblemError
from fem.quadrature import tet_rule, tri_rule
from fem.sparsity import Pattern, build_pattern
from fem.support import SupportKernel
from fem.tensor3 import det3, det_inv3
from fem.truss import TrussKernel


class InvertedElements(ArithmeticError):
    """Some quadrature point has det F ≤ 0 (or the state is not finite)."""

    def __init__(self, n_bad: int, min_j: float):
        super().__init__(f"{n_bad} quadrature points with det F <= 0 (min J = {min_j:.3g})")
        self.n_bad = n_bad
        self.min_j = min_j


class Topology:
    """Everything about a problem that does not depend on the material or the loads.

    Shared between problems that differ only in Dirichlet sets or material (see
    :func:`topology_for`): reference gradients, quadrature weights, the sparsity
    pattern and the scatter maps of pressures and fibres.
    """

    def __init__(self, problem: Problem) -> None:
        mesh = problem.mesh
        rule = tet_rule(problem.quadrature_degree)
        dN = element.shape_gradients(rule.points)  # (n_qp, 10, 3)
        Xe = mesh.points[mesh.cells]  # (n_el, 10, 3)
        J0 = np.einsum("eai,qaj->eqij", Xe, dN)  # (n_el, n_qp, 3, 3)  dX_i/dxi_j
        det0 = np.linalg.det(J0)  # (n_el, n_qp)
        if np.any(det0 <= 0):
            bad = int(np.sum(np.any(det0 <= 0, axis=1)))
            raise ValueError(f"mesh: {bad} elements with non-positive Jacobian at a quadrature point")
        inv0 = np.linalg.inv(J0)  # (n_el, n_qp, 3, 3)
        self.dNdX = np.einsum("qaj,eqji->eqai", dN, inv0)  # (n_el, n_qp, 10, 3)
        self.wdet = rule.weights[None, :] * det0  # (n_el, n_qp)
        self.vol = self.wdet.sum(axis=1)  # (n_el,)
        self.cells = mesh.cells
        self.n_nodes = mesh.n_nodes
        self.n_el = mesh.n_elements
        self.pressure_kernels = [PressureKernel(pr.faces, problem.face_quadrature_degree) for pr in problem.pressures]
        self.truss_kernels = [
            TrussKernel(mesh.points, mesh.cells, t.host_elements, t.local_coords, t.segments, t.youngs_modulus, t.area)
            for t in problem.trusses
        ]
        self.traction_forces = []  # per DeadTraction: (dofs (n_f*18,), weights (n_f, 6)) with f = weights ⊗ t0
        for dt in problem.tractions:
            rule = tri_rule(problem.face_quadrature_degree)
            Nf = element.tri6_shape_functions(rule.points)  # (n_qp, 6)
            dNf = element.tri6_shape_gradients(rule.points)  # (n_qp, 6, 2)
            Xf = mesh.points[dt.faces]  # (n_f, 6, 3)
            a1 = np.einsum("qa,fai->fqi", dNf[:, :, 0], Xf)  # (n_f, n_qp, 3)
            a2 = np.einsum("qa,fai->fqi", dNf[:, :, 1], Xf)
            dA = np.linalg.norm(np.cross(a1, a2), axis=-1)  # (n_f, n_qp)
            wts = np.einsum("q,qa,fq->fa", rule.weights, Nf, dA)  # (n_f, 6)  ∫ N_a dA
            self.traction_forces.append((dt.faces, wts))
        self.support_kernels = [SupportKernel(mesh.points, s.faces, problem.face_quadrature_degree)
                                for s in problem.supports]
        self.membrane_kernels = [MembraneKernel(mesh.points, m.faces, problem.face_quadrature_degree)
                                 for m in problem.membranes]
        groups = ([pk.faces for pk in self.pressure_kernels] + [tk.nodes for tk in self.truss_kernels]
                  + [sk.faces for sk in self.support_kernels] + [mk.faces for mk in self.membrane_kernels])
        self.pattern: Pattern = build_pattern(mesh.n_nodes, mesh.cells, groups)
        pat = self.pattern
        self.pressure_pos = [
            pat.node_block_positions(pk.faces[:, :, None], pk.faces[:, None, :]).transpose(0, 1, 3, 2, 4)
            for pk in self.pressure_kernels
        ]  # each (n_f, 6, 3, 6, 3)
        self.support_pos = [
            pat.node_block_positions(sk.faces[:, :, None], sk.faces[:, None, :]).transpose(0, 1, 3, 2, 4)
            for sk in self.support_kernels
        ]  # each (n_f, 6, 3, 6, 3)
        self.membrane_pos_flat = np.concatenate(
            [pat.node_block_positions(mk.faces[:, :, None], mk.faces[:, None, :]).transpose(0, 1, 3, 2, 4).ravel()
             for mk in self.membrane_kernels] + [np.zeros(0, np.int64)])  # (Σ n_f·324,)
        self.pressure_pos_flat = np.concatenate([p.ravel() for p in self.pressure_pos] + [np.zeros(0, np.int64)])
        # fibre tangents scatter linearly from 9 chord-space numbers per segment
        # (TrussKernel.tangent_map); the dense block positions are only needed to build the map
        self.truss_maps = [
            tk.tangent_map(pat.node_block_positions(tk.nodes[:, :, None], tk.nodes[:, None, :]).transpose(0, 1, 3, 2, 4),
                           pat.nnz)
            for tk in self.truss_kernels
        ]  # each sparse (nnz, 9 n_seg)
        self.truss_dofs = [(3 * tk.nodes[:, :, None] + np.arange(3)).reshape(len(tk.nodes), -1) for tk in self.truss_kernels]
        self.field_kernels = [FibreFieldKernel(self.dNdX, self.wdet, ff.elements, ff.stiffness, ff.directions)
                              for ff in problem.fibre_fields]
        self.face_dofs = [(3 * pk.faces[:, :, None] + np.arange(3)).reshape(len(pk.faces), -1) for pk in self.pressure_kernels]
        self.edofs = (3 * mesh.cells[:, :, None] + np.arange(3)).reshape(self.n_el, 30)  # (n_el, 30)


def topology_key(problem: Problem) -> tuple:
    return (
        id(problem.mesh),
        tuple(id(p.faces) for p in problem.pressures),
        tuple(id(t.segments) for t in problem.trusses),
        tuple(id(t.faces) for t in problem.tractions),
        tuple(id(f.stiffness) for f in problem.fibre_fields),
        tuple(id(s.faces) for s in problem.supports),
        tuple(id(m.faces) for m in problem.membranes),
        problem.quadrature_degree,
        problem.face_quadrature_degree,
    )


def topology_for(problem: Problem) -> Topology:
    """The (cached) :class:`Topology` of ``problem``.

    The cache lives in the problem (and is shared by ``dataclasses.replace`` copies,
    which keep the same mesh/face/fibre arrays), never at module level.
    """
    key = ("topology",) + topology_key(problem)
    topo = problem._cache.get(key)
    if topo is None:
        topo = Topology(problem)
        # keep referenced arrays alive so the id()-based key stays valid
        problem._cache[key] = topo
        problem._cache[key + ("refs",)] = (problem.mesh, problem.pressures, problem.trusses, problem.tractions,
                                           problem.fibre_fields, problem.supports, problem.membranes)
    return topo


def support_forces(problem: Problem, u: np.ndarray) -> list[np.ndarray]:
    """Resultant force (3,) [N] each elastic support of ``problem`` exerts on the body at the displacement
    ``u`` (n_nodes, 3): −Σ R over its faces (:meth:`fem.support.SupportKernel.force`), from the problem's
    cached topology."""
    return [sk.force(u, s.k_n, s.k_t) for sk, s in zip(topology_for(problem).support_kernels, problem.supports)]


class Assembler:
    """Residual, tangent and energy of a :class:`Problem` at a state.

    Parameters
    ----------
    problem : Problem
    kernel : {'auto', 'numba', 'numpy'}
        Element-tangent implementation: the compiled :mod:`fem.jit` kernel or the
        vectorised numpy one (the reference; same result to round-off). 'auto' takes
        numba when it is importable.
    """

    def __init__(self, problem: Problem, kernel: str = "auto") -> None:
        if kernel not in ("auto", "numba", "numpy"):
            raise ValueError(f"Assembler.kernel={kernel!r} is not one of 'auto', 'numba', 'numpy'")
        if kernel == "numba" and not jit.AVAILABLE:
            raise ValueError("Assembler.kernel='numba' but numba is not installed")
        self.problem = problem
        self.topo = topology_for(problem)
        self.pattern = self.topo.pattern
        #: element tangent: compiled (fem.jit) or the vectorised numpy reference
        self.kernel = ("numba" if jit.AVAILABLE else "numpy") if kernel == "auto" else kernel
        #: element energy terms: the topology's smeared fibres, then the problem's frozen stresses
        #: (problem data outside the topology, so such a problem shares the pattern of one without)
        for fs in problem.frozen_stresses:
            if fs.stress.shape[1] != self.topo.wdet.shape[1]:
                raise ProblemError(f"FrozenStress({fs.name}).stress: {fs.stress.shape[1]} points per element, the "
                                   f"tet rule of degree {problem.quadrature_degree} has {self.topo.wdet.shape[1]}")
        self.element_terms = list(self.topo.field_kernels) + [
            FrozenStressKernel(self.topo.dNdX, self.topo.wdet, fs.elements, fs.stress)
            for fs in problem.frozen_stresses]
        #: the elastic supports' constant tangent data (nnz,): their kernels' blocks of this problem's stiffnesses
        self.supports = list(zip(self.topo.support_kernels, problem.supports))
        self._support_data = None
        #: the bonded membranes: (kernel, thickness (n_f, n_qp or 1), Y, ν)
        self.membranes = []
        for mk, m in zip(self.topo.membrane_kernels, problem.membranes):
            if m.thickness.shape[1] not in (1, mk.n_qp):
                raise ProblemError(f"Membrane({m.name}).thickness: {m.thickness.shape[1]} points per face, the "
                                   f"triangle rule of degree {problem.face_quadrature_degree} has {mk.n_qp}")
            self.membranes.append((mk, m.thickness, m.youngs_modulus, m.poisson))

    def scatter_index(self) -> np.ndarray:
        """Data positions of the element tangent contributions (uu, up, pu, pp), in the order the numpy path stacks them (cached)."""
        idx = getattr(self.topo, "_scatter_index", None)
        if idx is None:
            pat = self.pattern
            idx = np.concatenate([pat.elem_uu.ravel(), pat.elem_up.ravel(), pat.elem_pu.ravel(), pat.elem_pp])
            self.topo._scatter_index = idx
        return idx

    def _kpp(self) -> np.ndarray:
        """Pressure–pressure diagonal (n_el,): −(D1/2) V_e (mixed) or 1 (inert pressures, displacement form)."""
        if self.problem.formulation == "displacement":
            return np.ones(self.topo.n_el)
        return -0.5 * self.problem.material.d1 * self.topo.vol

    def _add_load_tangents(self, data: np.ndarray, pres_out: list, truss_out: list, field_out: list,
                           memb_out: list = ()) -> np.ndarray:
        """Add the follower-pressure blocks, the fibre and membrane tangents to the tangent data (in place)."""
        topo = self.topo
        for fk, Ke in zip(self.element_terms, field_out):
            data += np.bincount(self.pattern.elem_uu[fk.elements].ravel(), Ke.ravel(), minlength=len(data))
        if pres_out:
            data += np.bincount(topo.pressure_pos_flat, np.concatenate([Kf.ravel() for Kf in pres_out]),
                                minlength=len(data))
        for B, kmat in zip(topo.truss_maps, truss_out):
            data += B @ kmat.ravel()  # (nnz,)  fibre blocks w_a w_b kmat_ik
        if self.supports:
            data += self.support_data()
        if memb_out:
            data += np.bincount(topo.membrane_pos_flat, np.concatenate([Km.ravel() for Km in memb_out]),
                                minlength=len(data))
        return data

    def support_data(self) -> np.ndarray:
        """Tangent data (nnz,) of the elastic supports: their blocks K (:mod:`fem.support`), constant (cached)."""
        if self._support_data is None:
            pos = np.concatenate([p.ravel() for p in self.topo.support_pos])
            vals = np.concatenate([sk.blocks(s.k_n, s.k_t).ravel() for sk, s in self.supports])
            self._support_data = np.bincount(pos, vals, minlength=self.pattern.nnz)  # (nnz,)
        return self._support_data


    # ------------------------------------------------------------------ kinematics
    def deformation(self, u: np.ndarray):
        """F, J, G = F⁻¹ at every quadrature point; raises InvertedElements if J ≤ 0."""
        ue = u[self.topo.cells]  # (n_el, 10, 3)
        # F_iJ = δ_iJ + Σ_a u_ai dN_aJ as a batched (3×10)·(10×3) product: several times faster than
        # the equivalent einsum "eai,eqaJ->eqiJ" (numpy's unoptimised einsum loops; the figure:
        # benchmarks/results/bench_fem.md, "Figures moved from the FE core's docstrings and comments")
        F = np.matmul(np.swapaxes(ue, 1, 2)[:, None], self.topo.dNdX)  # (n_el, n_qp, 3, 3)
        F[..., 0, 0] += 1.0
        F[..., 1, 1] += 1.0
        F[..., 2, 2] += 1.0
        J, G = det_inv3(F)  # (n_el, n_qp), (n_el, n_qp, 3, 3)
        if not np.all(np.isfinite(J)) or np.any(J <= 0):
            bad = int(np.sum(~(J > 0)))
            raise InvertedElements(bad, float(np.nanmin(J)) if np.any(np.isfinite(J)) else float("nan"))
        return F, J, G

    def min_jacobian(self, u: np.ndarray) -> float:
        """Smallest det F over all quadrature points (may be ≤ 0)."""
        ue = u[self.topo.cells]  # (n_el, 10, 3)
        F = np.matmul(np.swapaxes(ue, 1, 2)[:, None], self.topo.dNdX) + np.eye(3)  # (n_el, n_qp, 3, 3)
        return float(np.min(det3(F)))

    # ------------------------------------------------------------------ energy
    def energy(self, u: np.ndarray, p: np.ndarray, pressures=()) -> float:
        """Π(u, p) without the follower-pressure work (non-conservative in general)."""
        mat = self.problem.material
        F, J, G = self.deformation(u)
        W = mat.energy(F)  # (n_el, n_qp)
        if self.problem.formulation == "displacement":
            Pi = np.sum(self.topo.wdet * (W + (J - 1.0) ** 2 / mat.d1)) + 0.5 * np.sum(p**2)
        else:
            Pi = np.sum(self.topo.wdet * (W + p[:, None] * (J - 1.0)))
            Pi -= 0.25 * mat.d1 * np.sum(p**2 * self.topo.vol)
        x = self.problem.mesh.points + u
        for tk in self.topo.truss_kernels:
            Pi += tk.energy(x)
        for fk in self.element_terms:
            Pi += fk.energy(F)
        for sk, s in self.supports:
            Pi += sk.energy(u, s.k_n, s.k_t)
        for mk, t, Y, nu in self.membranes:
            Pi += mk.energy(x, t, Y, nu)
        return float(Pi)

    # ------------------------------------------------------------------ residual and tangent
    def evaluate(self, u: np.ndarray, p: np.ndarray, pressures: tuple[float, ...], need_tangent: bool = True,
                 tractions: tuple = ()):
        """Residual R (n_dofs,) and tangent data (nnz,) on :attr:`pattern`.

        Parameters
        ----------
        u : ndarray (n_nodes, 3)
        p : ndarray (n_el,)
        pressures : tuple of float
            Follower-pressure magnitudes, one per ``problem.pressures``.
        need_tangent : bool
        tractions : tuple of (3,) arrays
            Dead traction vectors, one per ``problem.tractions`` (dead loads add nothing to the tangent).

        Returns
        -------
        R : ndarray (n_dofs,)
        data : ndarray (nnz,) or None
        min_j : float
        """
        topo = self.topo
        mat = self.problem.material
        n_el = topo.n_el
        F, J, G = self.deformation(u)
        P_iso, coef = mat.stress_coefficients(F, G, J)  # (n_el, n_qp, 3, 3), dict of (n_el, n_qp)
        Gt = np.swapaxes(G, -1, -2)  # (n_el, n_qp, 3, 3) [i, J] = G_Ji
        disp = self.problem.formulation == "displacement"
        # pressure at the quadrature points: element unknown (mixed) or 2(J − 1)/D1 (displacement)
        pq = 2.0 * (J - 1.0) / mat.d1 if disp else np.broadcast_to(p[:, None], J.shape)  # (n_el, n_qp)
        pJ = pq * J  # (n_el, n_qp)
        P = P_iso + pJ[..., None, None] * Gt  # (n_el, n_qp, 3, 3)
        w = topo.wdet  # (n_el, n_qp)
        dN = topo.dNdX  # (n_el, n_qp, 10, 3)
        # R_e[a, i] = Σ_q w Σ_J P_iJ dN_aJ
        Re = np.matmul(dN, np.swapaxes(P * w[..., None, None], -1, -2)).sum(axis=1)  # (n_el, 10, 3)
        R = np.zeros(self.pattern.n_dofs)
        R[: 3 * topo.n_nodes] = np.bincount(topo.edofs.ravel(), Re.ravel(), minlength=3 * topo.n_nodes)
        if disp:  # inert element pressures: R_p = p, K_pp = 1
            R[3 * topo.n_nodes:] = p
        else:
            R[3 * topo.n_nodes:] = np.sum(w * (J - 1.0), axis=1) - 0.5 * mat.d1 * p * topo.vol

        x = self.problem.mesh.points + u
        pres_out = []
        for pk, dofs, val in zip(topo.pressure_kernels, topo.face_dofs, pressures):
            Rf, Kf = pk.evaluate(x, val, need_tangent)
            R[: 3 * topo.n_nodes] += np.bincount(dofs.ravel(), Rf.ravel(), minlength=3 * topo.n_nodes)
            pres_out.append(Kf)
        for (faces, wts), t0 in zip(topo.traction_forces, tractions):
            fa = wts[:, :, None] * np.asarray(t0, float)[None, None, :]  # (n_f, 6, 3)
            R[: 3 * topo.n_nodes] -= np.bincount((3 * faces[:, :, None] + np.arange(3)).ravel(), fa.ravel(),
                                                 minlength=3 * topo.n_nodes)
        for sk, s in self.supports:
            R[: 3 * topo.n_nodes] += np.bincount((3 * sk.faces[:, :, None] + np.arange(3)).ravel(),
                                                 sk.residual(u, s.k_n, s.k_t).ravel(), minlength=3 * topo.n_nodes)
        memb_out = []
        for mk, t, Y, nu in self.membranes:
            Rm, Km = mk.evaluate(x, t, Y, nu, need_tangent)
            R[: 3 * topo.n_nodes] += np.bincount((3 * mk.faces[:, :, None] + np.arange(3)).ravel(), Rm.ravel(),
                                                 minlength=3 * topo.n_nodes)
            memb_out.append(Km)
        truss_out = []
        for tk, dofs in zip(topo.truss_kernels, topo.truss_dofs):
            Rt, Kt = tk.evaluate(x, need_tangent)
            R[: 3 * topo.n_nodes] += np.bincount(dofs.ravel(), Rt.ravel(), minlength=3 * topo.n_nodes)
            truss_out.append(Kt)
        field_out = []
        for fk in self.element_terms:
            Rs, Ks = fk.evaluate(F, need_tangent)
            R[: 3 * topo.n_nodes] += np.bincount(topo.edofs[fk.elements].ravel(), Rs.ravel(),
                                                 minlength=3 * topo.n_nodes)
            field_out.append(Ks)
        min_j = float(J.min())
        if not need_tangent:
            return R, None, min_j

        if self.kernel == "numba":
            return R, self._tangent_numba(F, J, G, coef, pJ, pres_out, truss_out, field_out, memb_out), min_j

        return R, self._tangent_numpy(F, J, G, coef, pJ, pres_out, truss_out, field_out, memb_out), min_j

    def _tangent_numpy(self, F, J, G, coef, pJ, pres_out, truss_out, field_out, memb_out=()) -> np.ndarray:
        """Tangent data (nnz,) of the solid, summed in numpy (the reference the compiled kernel matches),
        plus the load terms' tangents."""
        topo = self.topo
        mat = self.problem.material
        n_el = topo.n_el
        w = topo.wdet  # (n_el, n_qp)
        dN = topo.dNdX  # (n_el, n_qp, 10, 3)
        disp = self.problem.formulation == "displacement"
        # Tangent A_iJkL = ∂P_iJ/∂F_kL (material.stress_coefficients) plus the volumetric part
        # ∂(pJ G_Ji)/∂F_kL = pJ (G_Ji G_Lk − G_Jk G_Li) [+ (2/D1) J² G_Ji G_Lk, displacement form].
        # With g[a, i] = Σ_J dN_aJ G_Ji and f[a, i] = Σ_J dN_aJ F_iJ, each dyad X⊗Y contracts to
        # the outer product of two 30-vectors and the "swap" term G_Jk G_Li to g[a, k] g[b, i]:
        #   K[ai, bk] = Σ_q w [ a (dN_a·dN_b) δ_ik + b' g_ai g_bk + g' g_ak g_bi
        #                        + h (f_ai g_bk + g_ai f_bk) + d2f dI_ai dI_bk ]
        nq = w.shape[1]
        gv = np.matmul(dN, G)  # (n_el, n_qp, 10, 3)  g[a, i]
        fv = np.matmul(dN, np.swapaxes(F, -1, -2))  # (n_el, n_qp, 10, 3)  f[a, i]
        b = coef["b"] + pJ  # (n_el, n_qp)
        if disp:
            b = b + (2.0 / mat.d1) * J**2
        gsw = coef["g"] - pJ  # (n_el, n_qp)
        gflat = gv.reshape(n_el, nq, 30)
        left = [gflat * (w * b)[..., None], fv.reshape(n_el, nq, 30) * (w * coef["h"])[..., None],
                gflat * (w * coef["h"])[..., None]]
        right = [gflat, gflat, fv.reshape(n_el, nq, 30)]
        if np.any(coef["d2f"] != 0.0):
            dv = np.matmul(dN, np.swapaxes(coef["dI"], -1, -2)).reshape(n_el, nq, 30)  # (n_el, n_qp, 30)
            left.append(dv * (w * coef["d2f"])[..., None])
            right.append(dv)
        Lm = np.concatenate(left, axis=1)  # (n_el, n_terms·n_qp, 30)
        Rm = np.concatenate(right, axis=1)  # (n_el, n_terms·n_qp, 30)
        Ke = np.matmul(np.swapaxes(Lm, 1, 2), Rm).reshape(n_el, 10, 3, 10, 3)  # (n_el, a, i, b, k)
        S = np.matmul(np.swapaxes(gflat * (w * gsw)[..., None], 1, 2), gflat)  # (n_el, 30, 30) [a k, b i]
        Ke += S.reshape(n_el, 10, 3, 10, 3).transpose(0, 1, 4, 3, 2)  # [a, i, b, k] = S[a, k, b, i]
        dNf = dN.transpose(0, 2, 1, 3).reshape(n_el, 10, 3 * nq)  # (n_el, 10, n_qp·3)
        dNw = (dN * (w * coef["a"])[..., None, None]).transpose(0, 2, 1, 3).reshape(n_el, 10, 3 * nq)
        Kid = np.matmul(dNw, np.swapaxes(dNf, 1, 2))  # (n_el, 10, 10)  Σ_q w a dN_a·dN_b
        Ke[:, :, 0, :, 0] += Kid
        Ke[:, :, 1, :, 1] += Kid
        Ke[:, :, 2, :, 2] += Kid
        Kup = np.matmul((w * J)[:, None, :], gv.reshape(n_el, nq, 30))[:, 0]  # (n_el, 30)  Σ_q w J g[a, i]
        if disp:
            Kup = np.zeros_like(Kup)

        parts_val = [Ke.reshape(n_el, 30, 30).ravel(), Kup.ravel(), Kup.ravel(), self._kpp()]
        data = np.bincount(self.scatter_index(), np.concatenate(parts_val), minlength=self.pattern.nnz)
        return self._add_load_tangents(data, pres_out, truss_out, field_out, memb_out)

    def _tangent_numba(self, F, J, G, coef, pJ, pres_out, truss_out, field_out, memb_out=()) -> np.ndarray:
        """Tangent data (nnz,) with the compiled element kernel (same sums as the numpy path)."""
        topo, pat, mat = self.topo, self.pattern, self.problem.material
        disp = self.problem.formulation == "displacement"
        shape = J.shape  # (n_el, n_qp)

        def arr(x):
            return np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), shape))

        b = coef["b"] + pJ  # (n_el, n_qp)
        if disp:
            b = b + (2.0 / mat.d1) * J**2
        d2f = arr(coef["d2f"])
        use_d2f = bool(np.any(d2f != 0.0))
        dI = np.ascontiguousarray(coef["dI"]) if use_d2f else F  # (n_el, n_qp, 3, 3)
        data = np.zeros(pat.nnz)
        jit.element_tangent_add(topo.dNdX, topo.wdet, np.ascontiguousarray(G), np.ascontiguousarray(F),
                                arr(coef["a"]), arr(b), arr(coef["g"] - pJ), arr(coef["h"]), d2f, dI, arr(J),
                                use_d2f, disp, pat.elem_uu, pat.elem_up, pat.elem_pu, data)
        data[pat.elem_pp] += self._kpp()  # one entry per element
        return self._add_load_tangents(data, pres_out, truss_out, field_out, memb_out)
