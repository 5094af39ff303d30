"""Tests of the CalculiX peer driver :mod:`peers.calculix`.

The ``ccx``-marked tests run CalculiX on tiny P2 meshes (well under a second each)
and are skipped when ``ccx`` is not installed. They pin

* the material law and deck (uniaxial stretch against the closed-form compressible
  neo-Hookean solution of a homogeneous deformation),
* the face labels: CalculiX's S1..S4 are ``fem.element.FACES[0..3]`` (pressure on a
  face given under every label yields the resultant ``p * A``),
* the node numbering round trip (a shuffled mesh returns each node's exact
  displacement in our order).

The remaining tests (deck validation, parsing, face lookup) need no ``ccx``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from fem import element
from peers.calculix import (
    CcxCase,
    CcxError,
    ccx_available,
    element_faces,
    parse_dat,
    run_ccx,
    write_deck,
)
from fem.mesh import boundary_faces, orient_linear, p1_to_p2, signed_volumes_linear

needs_ccx = pytest.mark.skipif(not ccx_available(), reason="CalculiX executable 'ccx' not on PATH")


# --------------------------------------------------------------------------- helpers


def box_mesh(n=(1, 1, 2), size=(1.0, 1.0, 2.0), jitter=0.0, seed=0):
    """P2 tets of a box [0, size]: each hex split into 6 tets, interior vertices jittered."""
    nx, ny, nz = n
    axes = [np.linspace(0.0, s, k + 1) for s, k in zip(size, n)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    pts = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
    if jitter:
        h = min(s / k for s, k in zip(size, n))
        inner = np.all((pts > 1e-12) & (pts < np.array(size) - 1e-12), axis=1)
        rng = np.random.default_rng(seed)
        pts[inner] += jitter * h * rng.uniform(-1, 1, (inner.sum(), 3))

    def idx(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    corners = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
    kuhn = [(0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6), (0, 5, 1, 6)]
    tets = []
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                c = [idx(i + a, j + b, k + d) for a, b, d in corners]
                tets += [[c[q] for q in t] for t in kuhn]
    tets = orient_linear(pts, np.array(tets))
    points, cells, _ = p1_to_p2(pts, tets)
    return points, cells


def uniaxial_reference(lam, c10, d1):
    """Lateral stretch and nominal stress of compressible neo-Hookean uniaxial tension.

    ``W = C10 (I1_bar - 3) + (J - 1)^2 / D1`` gives the Cauchy stress
    ``sigma = (2 C10 / J) dev(b_bar) + (2 / D1)(J - 1) I`` with ``b_bar = J^(-2/3) b``.
    For ``F = diag(lam, l, l)`` the lateral stretch ``l`` solves ``sigma_22 = 0``
    ("solve the lateral stretch from the zero-traction condition
    numerically"); the nominal stress is ``P_11 = J sigma_11 / lam``.
    """

    def stresses(l):
        J = lam * l * l
        pre = 2.0 * c10 / J * J ** (-2.0 / 3.0)
        tr3 = (lam**2 + 2.0 * l * l) / 3.0
        vol = 2.0 / d1 * (J - 1.0)
        return pre * (lam**2 - tr3) + vol, pre * (l * l - tr3) + vol, J

    l = brentq(lambda s: stresses(s)[1], 0.2, 2.0, xtol=1e-15, rtol=1e-15)
    s11, _, J = stresses(l)
    return l, J * s11 / lam


#: face label (1..4) -> local vertex opposite that face
_OPPOSITE = {1: 3, 2: 2, 3: 0, 4: 1}

_EVEN_PERMS = [
    p
    for p in __import__("itertools").permutations(range(4))
    if sum(p[i] > p[j] for i in range(4) for j in range(i + 1, 4)) % 2 == 0
]


def permute_tet10(cell, sigma):
    """Renumber one TET10 so that new vertex i is old vertex sigma[i] (edge nodes follow)."""
    edge_of = {frozenset(e): 4 + k for k, e in enumerate(element.EDGES.tolist())}
    new = [cell[sigma[i]] for i in range(4)]
    for a, b in element.EDGES:
        new.append(cell[edge_of[frozenset((sigma[a], sigma[b]))]])
    return np.array(new, dtype=np.int64)


def relabel_faces(cells, elems, local_faces, label):
    """Renumber ``elems`` (orientation-preserving) so their face ``local_faces`` gets ``label``."""
    cells = cells.copy()
    for e, f in zip(elems, local_faces):
        v_opp = _OPPOSITE[f + 1]
        sigma = next(s for s in _EVEN_PERMS if s[_OPPOSITE[label]] == v_opp)
        cells[e] = permute_tet10(cells[e], sigma)
    return cells


# --------------------------------------------------------------------------- ccx runs


@pytest.mark.ccx
@needs_ccx
def test_uniaxial_stretch_matches_closed_form(tmp_path):
    """Uniaxial stretch lam = 1.25 of a jittered 1x1x2 P2 block (K/mu = 1000).

    Symmetry planes x=0, y=0, z=0; the face z=2 is pulled by a prescribed uz. The
    deformation is homogeneous, so any straight-sided P2 mesh is exact: the axial
    reaction equals ``P_11 * A`` of :func:`uniaxial_reference`. Required: 0.5 %; CalculiX
    with tightened tolerances reproduces it to the printed 7 digits, so 1e-5 is asserted.
    """
    points, cells = box_mesh((2, 2, 3), jitter=0.15)
    assert signed_volumes_linear(points, cells).min() > 0
    c10, mu = 0.5, 1.0
    d1 = 2.0 / (1000.0 * mu)
    L, lam = 2.0, 1.25
    x, y, z = points.T
    tol = 1e-9
    top = np.nonzero(z > L - tol)[0]
    bcs = (
        (np.nonzero(x < tol)[0], 0, 0.0),
        (np.nonzero(y < tol)[0], 1, 0.0),
        (np.nonzero(z < tol)[0], 2, 0.0),
        (top, 2, (lam - 1.0) * L),
    )
    case = CcxCase(points, cells, c10=c10, d1=d1, boundary=bcs, n_increments=5)
    res = run_ccx(case, workdir=tmp_path)
    assert res.converged and res.n_increments == 5

    l_ref, p11 = uniaxial_reference(lam, c10, d1)
    force = res.reactions[top, 2].sum()
    assert force == pytest.approx(p11 * 1.0 * 1.0, rel=1e-5)
    # lateral contraction, and the homogeneous field at every node
    u_ref = np.column_stack([(l_ref - 1) * x, (l_ref - 1) * y, (lam - 1) * z])
    np.testing.assert_allclose(res.displacements, u_ref, atol=2e-6)


@pytest.mark.ccx
@needs_ccx
def test_face_labels_pressure_resultant(tmp_path):
    """Pressure on the face z=2 of a clamped block, given under each label S1..S4.

    Every top element is renumbered (even vertex permutation, orientation kept) so that
    its top face is ``fem.element.FACES[k - 1]``, and the load is written as ``Sk``. In
    the small-load limit (p / mu = 1e-7) the support reaction must be ``p * A`` along +z
    (pressure pushes into the solid) for every k, and the four renumbered models must
    deform identically. A mismatch of one label would load a side or interior face.
    """
    points, cells0 = box_mesh((2, 2, 2), size=(1.0, 1.5, 2.0))
    z = points[:, 2]
    tol = 1e-9
    elem, local, faces6 = boundary_faces(cells0)
    on_top = np.all(z[faces6[:, :3]] > 2.0 - tol, axis=1)
    top_elems, top_local = elem[on_top], local[on_top]
    assert len(top_elems) == 8
    area = 1.0 * 1.5
    bottom = np.nonzero(z < tol)[0]
    p = 1e-7
    disp = []
    for label in (1, 2, 3, 4):
        cells = relabel_faces(cells0, top_elems, top_local, label)
        assert signed_volumes_linear(points, cells).min() > 0
        # our FACES[label-1] is the top face of each relabelled element, outward = +z
        f6 = cells[top_elems][:, element.FACES[label - 1]]  # (n_top, 6)
        assert np.all(z[f6] > 2.0 - tol)
        xa, xb, xc = (points[f6[:, i]] for i in range(3))
        assert np.all(np.cross(xb - xa, xc - xa)[:, 2] > 0)

        case = CcxCase(
            points, cells, c10=0.5, d1=0.02,
            boundary=tuple((bottom, c, 0.0) for c in range(3)),
            pressures=((top_elems, label, p),),
            n_increments=1,
        )
        res = run_ccx(case, workdir=tmp_path / f"S{label}")
        total = res.reactions[bottom].sum(axis=0)
        assert total[2] == pytest.approx(p * area, rel=1e-6), f"label S{label}"
        assert np.all(np.abs(total[:2]) < 1e-6 * p * area), f"label S{label}"
        assert res.displacements[z > 2.0 - tol, 2].max() < 0  # the loaded face moves down
        disp.append(res.displacements)
    scale = np.abs(disp[0]).max()
    for label, d in zip((2, 3, 4), disp[1:]):
        np.testing.assert_allclose(d, disp[0], atol=1e-6 * scale, err_msg=f"S{label} vs S1")


@pytest.mark.ccx
@needs_ccx
def test_node_numbering_round_trip(tmp_path):
    """A shuffled node and element numbering returns each node's own displacement.

    Homogeneous stretch (lam_z = 1.1, symmetry planes) of a randomly renumbered mesh:
    ``result.displacements[i]`` must be the exact field at ``points[i]``.
    """
    points, cells = box_mesh((1, 2, 2), size=(1.0, 1.0, 2.0))
    rng = np.random.default_rng(3)
    perm = rng.permutation(len(points))  # new node k is old node perm[k]
    inv = np.empty_like(perm)
    inv[perm] = np.arange(len(perm))
    points = points[perm]
    cells = inv[cells][rng.permutation(len(cells))]
    c10, d1, lam = 0.5, 0.02, 1.1
    x, y, z = points.T
    tol = 1e-9
    bcs = (
        (np.nonzero(x < tol)[0], 0, 0.0),
        (np.nonzero(y < tol)[0], 1, 0.0),
        (np.nonzero(z < tol)[0], 2, 0.0),
        (np.nonzero(z > 2.0 - tol)[0], 2, 2.0 * (lam - 1.0)),
    )
    res = run_ccx(CcxCase(points, cells, c10, d1, boundary=bcs, n_increments=2), workdir=tmp_path)
    l_ref, _ = uniaxial_reference(lam, c10, d1)
    u_ref = np.column_stack([(l_ref - 1) * x, (l_ref - 1) * y, (lam - 1) * z])
    np.testing.assert_allclose(res.displacements, u_ref, atol=1e-6)
    # at free DOFs CalculiX prints the residual force: negligible against the reactions
    free = np.ones((len(points), 3), bool)
    for nodes, comp, _ in bcs:
        free[nodes, comp] = False
    assert np.abs(res.reactions[free]).max() < 1e-6 * np.abs(res.reactions).max()


@pytest.mark.ccx
@needs_ccx
def test_divergence_raises_with_log(tmp_path):
    """A huge load in one fixed increment fails with CcxError carrying the log tail."""
    points, cells = box_mesh((1, 1, 1), size=(1.0, 1.0, 1.0))
    z = points[:, 2]
    bottom, top = np.nonzero(z < 1e-9)[0], np.nonzero(z > 1 - 1e-9)[0]
    bcs = tuple((bottom, c, 0.0) for c in range(3)) + ((top, 0, 3.0), (top, 2, 4.0))
    case = CcxCase(points, cells, 0.5, 0.02, boundary=bcs, n_increments=1, max_iterations=4)
    with pytest.raises(CcxError, match="did not converge"):
        run_ccx(case, workdir=tmp_path / "a")
    res = run_ccx(case, workdir=tmp_path / "b", raise_on_failure=False)
    assert not res.converged and np.isnan(res.displacements).all()


@pytest.mark.ccx
@needs_ccx
def test_automatic_incrementation_recovers_hard_case(tmp_path):
    """Shear + stretch of a clamped, nearly incompressible block in one load step.

    One DIRECT increment diverges (it cannot be cut back); ``direct=False`` cuts back
    and lands on the same equilibrium as 16 fixed increments.
    """
    points, cells = box_mesh((1, 1, 2))
    z = points[:, 2]
    bottom, top = np.nonzero(z < 1e-9)[0], np.nonzero(z > 2 - 1e-9)[0]
    bcs = tuple((bottom, c, 0.0) for c in range(3)) + ((top, 0, 0.3), (top, 2, 0.5))
    kw = dict(c10=0.5, d1=0.002, boundary=bcs)
    with pytest.raises(CcxError, match="raise n_increments"):
        run_ccx(CcxCase(points, cells, n_increments=1, **kw), workdir=tmp_path / "direct1")
    auto = run_ccx(CcxCase(points, cells, n_increments=1, direct=False, **kw), workdir=tmp_path / "auto")
    ref = run_ccx(CcxCase(points, cells, n_increments=16, **kw), workdir=tmp_path / "direct16")
    assert auto.converged and auto.n_cutbacks >= 1 and ref.n_increments == 16
    np.testing.assert_allclose(auto.displacements, ref.displacements, atol=1e-6)


# --------------------------------------------------------------------------- no ccx needed


def test_case_validation_names_field_and_value():
    points, cells = box_mesh((1, 1, 1))
    with pytest.raises(ValueError, match=r"CcxCase\.d1: 0\.0.*hybrid"):
        CcxCase(points, cells, c10=0.5, d1=0.0)
    with pytest.raises(ValueError, match=r"CcxCase\.c10"):
        CcxCase(points, cells, c10=-1.0, d1=0.01)
    with pytest.raises(ValueError, match=r"boundary\[0\]\.component: 3"):
        CcxCase(points, cells, 0.5, 0.01, boundary=(([0, 1], 3, 0.0),))
    with pytest.raises(ValueError, match=r"boundary\[0\]\.node_ids: range"):
        CcxCase(points, cells, 0.5, 0.01, boundary=(([len(points)], 0, 0.0),))
    with pytest.raises(ValueError, match=r"pressures\[0\]\.face_labels: range \[0, 0\]"):
        CcxCase(points, cells, 0.5, 0.01, pressures=(([0], 0, 1.0),))
    with pytest.raises(ValueError, match=r"n_increments"):
        CcxCase(points, cells, 0.5, 0.01, n_increments=0)


def test_write_deck_keywords_and_line_length(tmp_path):
    points, cells = box_mesh((2, 2, 2))
    elem, local, _ = boundary_faces(cells)
    case = CcxCase(
        points, cells, 0.5, 0.01,
        boundary=((np.arange(40), 1, 0.25),),
        pressures=((elem[:5], local[:5] + 1, 0.1),),
        n_increments=4,
    )
    path = write_deck(case, tmp_path / "deck")
    assert path.suffix == ".inp"
    text = path.read_text()
    for kw in (
        "*NODE, NSET=NALL", "*ELEMENT, TYPE=C3D10", "*HYPERELASTIC, NEO HOOKE", "*STEP, NLGEOM",
        "*STATIC, DIRECT", "*CONTROLS, PARAMETERS=FIELD", "*BOUNDARY", "NBC0, 2, 2, 0.25",
        "*SURFACE, NAME=SPRESS0, TYPE=ELEMENT", "SPRESS0, P, 0.1", "*NODE PRINT", "*NODE FILE",
    ):
        assert kw in text, kw
    assert "0.25, 1.0" in text  # 4 fixed increments
    assert max(len(line) for line in text.splitlines()) <= 132
    # node and element numbering: 1-based, unchanged order
    lines = text.splitlines()
    k = lines.index("*ELEMENT, TYPE=C3D10, ELSET=EALL")
    first = [int(v) for v in lines[k + 1].split(",")]
    assert first == [1] + (cells[0] + 1).tolist()


def test_parse_dat_handles_fortran_exponents(tmp_path):
    dat = tmp_path / "x.dat"
    dat.write_text(
        "\n displacements (vx,vy,vz) for set NALL and time  0.5000000E+00\n\n"
        "         1  1.000000E+00  0.000000E+00  0.000000E+00\n\n"
        " displacements (vx,vy,vz) for set NALL and time  0.1000000E+01\n\n"
        "         1  2.000000E+00 -1.234567-100  3.000000E+00\n"
        "         3  4.000000E+00  5.000000E+00  6.000000E+00\n\n"
        " forces (fx,fy,fz) for set NALL and time  0.1000000E+01\n\n"
        "         2  7.000000E+00  8.000000E+00  9.000000E+00\n\n"
        " total force (fx,fy,fz) for set NALL and time  0.1000000E+01\n\n"
        "        7.000000E+00  8.000000E+00  9.000000E+00\n"
    )
    out = parse_dat(dat, 3)
    t, u = out["U"]
    assert t == 1.0
    np.testing.assert_array_equal(u[0], [2.0, -1.234567e-100, 3.0])
    assert np.isnan(u[1]).all()
    np.testing.assert_array_equal(u[2], [4.0, 5.0, 6.0])
    np.testing.assert_array_equal(out["RF"][1][1], [7.0, 8.0, 9.0])


def test_parse_dat_totals_and_frd_displacements_read_every_phase(tmp_path):
    """The totals of each set at each time, and each ``DISP`` block of an ASCII ``.frd`` (6-digit, fixed columns,
    a three-digit exponent, a node beyond ``n_nodes`` left out, a ``STRESS`` block skipped), as CalculiX writes them."""
    from peers.calculix import parse_dat_totals, parse_frd_displacements

    dat = tmp_path / "x.dat"
    dat.write_text(
        "\n total force (fx,fy,fz) for set BASE and time  0.1000000E+01\n\n"
        "        1.000000E-03  2.000000E+00 -3.000000E-08\n\n"
        " total force (fx,fy,fz) for set CONTACT and time  0.2000000E+01\n\n"
        "        7.165322E-06 -1.013964E-01 -7.519364-100\n\n"
        " displacements (vx,vy,vz) for set CONTACT and time  0.2000000E+01\n\n"
        "         5  1.000000E+00  0.000000E+00  0.000000E+00\n"
    )
    tot = parse_dat_totals(dat)
    assert sorted(tot) == ["BASE", "CONTACT"] and list(tot["CONTACT"]) == [2.0]
    np.testing.assert_array_equal(tot["BASE"][1.0], [1e-3, 2.0, -3e-8])
    np.testing.assert_array_equal(tot["CONTACT"][2.0], [7.165322e-06, -1.013964e-01, -7.519364e-100])

    def block(kind: str, t: float, rows: list) -> str:
        head = f"    1PSTEP                         3          10           1\n  100CL  101 {t:.9f}           3" \
               "                     0    1           1\n"
        head += f" -4  {kind:<8}    {3 if kind == 'DISP' else 6}    1\n -5  D1          1    2    1    0\n"
        return head + "".join(f" -1{n:10d}" + "".join(f"{v:12.5E}" for v in vals) + "\n" for n, vals in rows) + " -3\n"

    frd = tmp_path / "x.frd"
    frd.write_text("    1C\n" + block("DISP", 1.0, [(1, (0.0, -1.5e-3, 2.0)), (2, (1.0, 2.0, 3.0)), (3, (9.0, 9.0, 9.0))])
                   + block("STRESS", 1.0, [(1, (5.0, 5.0, 5.0, 5.0, 5.0, 5.0))])
                   + block("DISP", 2.0, [(2, (-4.0, 5.5e-120, 6.0))]) + "9999\n")
    frd.write_text(frd.read_text().replace("5.50000E-120", " 5.50000-120"))
    u = parse_frd_displacements(frd, 2)
    assert sorted(u) == [1.0, 2.0]
    np.testing.assert_array_equal(u[1.0], [[0.0, -1.5e-3, 2.0], [1.0, 2.0, 3.0]])
    assert np.isnan(u[2.0][0]).all()
    np.testing.assert_array_equal(u[2.0][1], [-4.0, 5.5e-120, 6.0])


def test_element_faces_inverts_boundary_faces():
    points, cells = box_mesh((2, 1, 2), jitter=0.1)
    elem, local, faces6 = boundary_faces(cells)
    rng = np.random.default_rng(1)
    order = rng.permutation(len(elem))
    e, lab = element_faces(cells, faces6[order][:, [1, 2, 0, 4, 5, 3]])  # rotated corners
    np.testing.assert_array_equal(e, elem[order])
    np.testing.assert_array_equal(lab, local[order] + 1)
    with pytest.raises(ValueError, match="not element faces"):
        element_faces(cells, np.array([[0, 1, 2, 3, 4, 5]]) + len(points) - 6)


def test_deck_numbers_fit_calculix_fields():
    """CalculiX reads at most 20 characters per field; long reprs are rounded to 13 digits."""
    from peers.calculix import _fmt

    for v in (-1.4473103847089728e-15, 1.0 / 3.0, -123456.78901234567, -2.2250738585072014e-308, 0.1, 70.0):
        s = _fmt(v)
        assert len(s) <= 20
        assert abs(float(s) - v) <= 5e-13 * abs(v)
