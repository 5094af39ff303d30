"""Consistent tangent of the mixed u–p assembly against central finite differences.

Reference: the tangent is the exact Jacobian ∂R/∂x of the residual (Wriggers,
*Nonlinear Finite Element Methods* 2008, §4.2); a central difference with step h has
truncation error O(h²)·|R'''| and round-off O(ε|R|/h), both ≪ 1e-6 relative at h = 1e-6.
Required: agreement to ≤ 1e-6 relative separately for the material, the
follower-pressure and the fibre parts. For the conservative parts (material + fibres)
the residual must also be the gradient of the discrete potential Π (Assembler.energy).
"""

from __future__ import annotations

import numpy as np
import pytest

from fem.assembly import Assembler
from fem.material import NeoHookean, Yeoh
from fem.mesh import TetMesh, boundary_faces
from fem.meshgen import box_mesh
from fem.problem import EmbeddedTrusses, FollowerPressure, Problem

TOL = 1e-6  # tangent vs central FD, relative
H = 1e-6


@pytest.fixture(scope="module")
def mesh():
    """Distorted 1×1×2-cell P2 box (12 tets), small enough for a dense FD Jacobian."""
    return _distorted(box_mesh(1.0, 1.0, 2.0, 1, 1, 2))


def _distorted(m):
    """Move every node (also mid-edge and boundary ones) by a smooth map so elements are curved."""
    X = m.points
    Y = X + 0.08 * np.stack([np.sin(2.0 * X[:, 2]) + X[:, 1] ** 2, np.cos(1.5 * X[:, 0]) * X[:, 2],
                             0.5 * X[:, 0] * X[:, 1]], axis=1)
    return TetMesh(Y, m.cells)


def _state(problem, seed=1, scale=0.05):
    rng = np.random.default_rng(seed)
    u = scale * rng.standard_normal((problem.mesh.n_nodes, 3))
    p = 0.3 * rng.standard_normal(problem.mesh.n_elements)
    return u, p


def _dense(asm, u, p, pressures):
    R, data, _ = asm.evaluate(u, p, pressures, True)
    return R, asm.pattern.matrix(data).toarray()


def _fd_jacobian(fun, x):
    """Central-difference Jacobian of fun at x (dense)."""
    cols = []
    for j in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[j] += H
        xm[j] -= H
        cols.append((fun(xp) - fun(xm)) / (2 * H))
    return np.stack(cols, axis=1)


def _residual_fun(asm, pressures):
    n_u = asm.problem.n_u

    def fun(x):
        return asm.evaluate(x[:n_u].reshape(-1, 3), x[n_u:], pressures, False)[0]

    return fun


def energy_gradient_fd(asm, u, p):
    """Central-difference gradient of Assembler.energy over (u, p), flattened like the residual."""
    n_u = asm.problem.n_u
    x = np.concatenate([u.ravel(), p])
    g = np.empty_like(x)
    for j in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[j] += H
        xm[j] -= H
        g[j] = (asm.energy(xp[:n_u].reshape(-1, 3), xp[n_u:]) - asm.energy(xm[:n_u].reshape(-1, 3), xm[n_u:])) / (2 * H)
    return g


def _rel(K, Kfd):
    err = np.abs(K - Kfd).max() / np.abs(Kfd).max()
    print(f"tangent vs FD: max rel error {err:.2e}")
    return err


@pytest.mark.parametrize(
    "material",
    [NeoHookean(0.5, 0.0), NeoHookean(0.5, 0.8), Yeoh((0.5, -0.05, 0.02), 0.0), Yeoh((0.5, 0.1, 0.03), 0.4)],
    ids=["neohooke_d1=0", "neohooke_d1>0", "yeoh_d1=0", "yeoh_d1>0"],
)
def test_material_tangent_matches_fd(mesh, material):
    """Material + volumetric (u–p) tangent, all four blocks K_uu, K_up, K_pu, K_pp, vs central FD."""
    prob = Problem(mesh, material)
    asm = Assembler(prob)
    u, p = _state(prob)
    R, K = _dense(asm, u, p, ())
    Kfd = _fd_jacobian(_residual_fun(asm, ()), np.concatenate([u.ravel(), p]))
    assert _rel(K, Kfd) <= TOL
    # the tangent must be symmetric for a conservative material (sanity of the block layout)
    assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()


def test_follower_pressure_tangent_matches_fd(mesh):
    """Follower-pressure part: K(p) − K(0) vs FD of R(p) − R(0) on an open loaded surface.

    The pressure stiffness is non-symmetric for an open surface (Bonet & Wood 2008, §8.4);
    we check that the tested block indeed is.
    """
    _, _, f6 = boundary_faces(mesh.cells)
    X = mesh.points
    faces = f6[np.all(X[f6][:, :, 2] > 1.5, axis=1)]  # the (curved) top face
    assert len(faces) >= 2
    prob = Problem(mesh, NeoHookean(0.5, 0.0), pressures=(FollowerPressure(faces),))
    asm = Assembler(prob)
    u, p = _state(prob, seed=2, scale=0.04)
    pval = 0.7
    R1, K1 = _dense(asm, u, p, (pval,))
    R0, K0 = _dense(asm, u, p, (0.0,))
    Kp = K1 - K0
    f1, f0 = _residual_fun(asm, (pval,)), _residual_fun(asm, (0.0,))
    Kfd = _fd_jacobian(lambda x: f1(x) - f0(x), np.concatenate([u.ravel(), p]))
    assert np.abs(Kfd).max() > 1e-2  # the pressure part is not negligible
    assert _rel(Kp, Kfd) <= TOL
    assert np.abs(Kp - Kp.T).max() > 1e-3 * np.abs(Kp).max()  # non-symmetric, as it must be


def _fibres(mesh):
    """A polyline through 4 host elements (points at interior local coordinates)."""
    he = np.array([0, 3, 7, 11, 5])
    xi = np.array([[0.2, 0.2, 0.2], [0.1, 0.3, 0.2], [0.25, 0.25, 0.25], [0.3, 0.1, 0.1], [0.15, 0.5, 0.2]])
    seg = np.array([[0, 1], [1, 2], [2, 3], [3, 4]])
    return EmbeddedTrusses(he, xi, seg, youngs_modulus=3.0e4, area=0.01)


def added_tangent_vs_fd(mesh, kernel: str = "auto", **terms):
    """Tangent of a neo-Hookean problem with extra ``terms`` (Problem fields) minus that without them,
    and the central-FD Jacobian of the difference of their residuals.

    Returns (K_with, K_without, Kfd), dense.
    """
    mat = NeoHookean(0.5, 0.0)
    prob_m = Problem(mesh, mat)
    prob_f = Problem(mesh, mat, **terms)
    asm_m, asm_f = Assembler(prob_m), Assembler(prob_f, kernel=kernel)
    u, p = _state(prob_f, seed=3, scale=0.05)
    _, Km = _dense(asm_m, u, p, ())
    _, Kf = _dense(asm_f, u, p, ())
    fm, ff = _residual_fun(asm_m, ()), _residual_fun(asm_f, ())
    return Kf, Km, _fd_jacobian(lambda x: ff(x) - fm(x), np.concatenate([u.ravel(), p]))


def test_fibre_tangent_matches_fd(mesh):
    """Embedded-truss part: K(material+fibres) − K(material) vs FD of the fibre residual.

    E_f·A / (μ·L²) ≈ 600, so the fibre part dominates its rows, as in the application
    (fibre/rubber stiffness ratio ~1e5 at the real fibre area).
    """
    Kf, Km, Kfd = added_tangent_vs_fd(mesh, trusses=(_fibres(mesh),))
    assert np.abs(Kfd).max() > 10 * np.abs(Km).max()
    assert _rel(Kf - Km, Kfd) <= TOL



def test_fibre_tangent_map_equals_dense_blocks(mesh):
    """TrussKernel.tangent_map (B @ kmat) equals scattering the dense 60×60 blocks
    w_a w_b kmat_ik, including a segment whose two points share a host (duplicate nodes)."""
    from fem.sparsity import build_pattern
    from fem.truss import TrussKernel

    he = np.array([0, 0, 3, 7])
    xi = np.array([[0.2, 0.2, 0.2], [0.1, 0.3, 0.2], [0.25, 0.25, 0.25], [0.3, 0.1, 0.1]])
    seg = np.array([[0, 1], [1, 2], [2, 3]])
    tk = TrussKernel(mesh.points, mesh.cells, he, xi, seg, 3.0e4, 0.01)
    pat = build_pattern(mesh.n_nodes, mesh.cells, [tk.nodes])
    pos = pat.node_block_positions(tk.nodes[:, :, None], tk.nodes[:, None, :]).transpose(0, 1, 3, 2, 4)
    x = mesh.points + np.random.default_rng(4).normal(scale=0.05, size=mesh.points.shape)
    _, kmat = tk.evaluate(x)
    dense = np.bincount(pos.ravel(), tk.blocks(kmat).ravel(), minlength=pat.nnz)  # (nnz,)
    mapped = tk.tangent_map(pos, pat.nnz) @ kmat.ravel()  # (nnz,)
    assert np.abs(dense).max() > 1.0
    np.testing.assert_allclose(mapped, dense, rtol=0, atol=1e-12 * np.abs(dense).max())
    # the merged weights: per segment and node the same total, held by one occurrence
    wm = tk.merged_weights()
    for nodes, w, m in zip(tk.nodes, tk.w, wm):
        for n in np.unique(nodes):
            at = nodes == n
            assert np.isclose(m[at].sum(), w[at].sum(), rtol=0, atol=1e-15)
            assert np.count_nonzero(m[at]) <= 1
    assert not np.any(wm[0, 10:]) and np.any(wm[0, :10])  # both points in element 0: its 10 nodes once each

@pytest.mark.parametrize("material", [NeoHookean(0.5, 0.0), Yeoh((0.5, 0.1, 0.03), 0.4)], ids=["neohooke", "yeoh"])
def test_residual_is_energy_gradient(mesh, material):
    """R = ∂Π/∂x (u and p blocks) for material + fibres, Π = Assembler.energy, by central FD.

    Π(u, p) = Σ_e ∫ W_iso + p_e ∫(J − 1) − (D1/4) p_e² V_e + Σ ½ E_f A L0 E_GL²
    (docstring of fem.assembly).
    """
    prob = Problem(mesh, material, trusses=(_fibres(mesh),))
    asm = Assembler(prob)
    u, p = _state(prob, seed=4)
    R = asm.evaluate(u, p, (), False)[0]
    g = energy_gradient_fd(asm, u, p)
    err = np.abs(g - R).max() / np.abs(R).max()
    print(f"residual vs energy gradient: max rel error {err:.2e}")
    assert err <= TOL


def test_only_follower_pressure_breaks_symmetry(mesh):
    """The material + fibre + displacement-formulation tangents are exactly symmetric; a
    loaded pressure face makes the tangent non-symmetric, a zero pressure value does not
    (what fem.linsolve's symmetry probe and its refinement on the full matrix rely on)."""
    _, _, f6 = boundary_faces(mesh.cells)
    faces = f6[np.all(mesh.points[f6][:, :, 2] > 1.5, axis=1)]
    for prob in (Problem(mesh, NeoHookean(0.5, 0.0), trusses=(_fibres(mesh),), pressures=(FollowerPressure(faces),)),
                 Problem(mesh, NeoHookean(0.5, 0.8), formulation="displacement", pressures=(FollowerPressure(faces),))):
        asm = Assembler(prob)
        u, p = _state(prob, seed=4, scale=0.05)
        _, K0 = _dense(asm, u, p, (0.0,))
        _, K1 = _dense(asm, u, p, (0.7,))
        assert np.abs(K0 - K0.T).max() <= 1e-13 * np.abs(K0).max()
        assert np.abs(K1 - K1.T).max() > 1e-4 * np.abs(K1).max()
