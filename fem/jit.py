"""Compiled (numba) element-tangent kernel: builds each 30×30 element matrix in registers
and adds it straight into the sparse tangent's data.

Why compiled: the vectorised numpy tangent (:meth:`fem.assembly.Assembler.evaluate`)
materialises the (n_el, 30, 30) element matrices plus (n_el, n_terms·n_qp, 30) factors and
scatters them with ``np.bincount``: memory traffic that made assembly the larger part of a
modified-Newton iteration in ``benchmarks/performance/bench_fem.py`` and kept our solve short of
its 5× target against CalculiX (the figures before and after: ``benchmarks/results/bench_fem.md``).
This kernel computes the same sums per element and quadrature
point with no temporaries. The numpy path stays the reference implementation and the
fallback when numba is missing; ``tests/test_fem_jit.py`` checks the two agree to
round-off.

The element tangent (see :mod:`fem.assembly` for the derivation)::

    K[ai, bk] = Σ_q w [ a (dN_a·dN_b) δ_ik + b' g_ai g_bk + g' g_ak g_bi
                        + h (f_ai g_bk + g_ai f_bk) + d2f v_ai v_bk ]
    K_up[ai]  = Σ_q w J g_ai

with g[a, i] = Σ_J dN_aJ G_Ji (G = F⁻¹), f[a, i] = Σ_J dN_aJ F_iJ, v[a, i] = Σ_J dN_aJ
(∂I/∂F)_iJ, b' = b + pJ (+ 2J²/D1 in the displacement form) and g' = g − pJ.
"""

from __future__ import annotations


import numpy as np

try:  # numba is a dependency of cadquery, hence always installed with whisker-opt
    import numba

    AVAILABLE = True
except ImportError:  # pragma: no cover - exercised only without numba
    numba = None
    AVAILABLE = False


def _element_tangent_add(dN, w, G, F, ca, cb, cg, ch, cd2f, dI, J, use_d2f, disp_up,
                         pos_uu, pos_up, pos_pu, data):  # pragma: no cover - compiled
    """Add every element's K_uu, K_up and K_pu into ``data`` (in place).

    Parameters
    ----------
    dN : (n_el, n_qp, 10, 3)   shape-function gradients dN_a/dX_J
    w : (n_el, n_qp)           quadrature weight × det J0
    G, F : (n_el, n_qp, 3, 3)  F⁻¹ and F
    ca, cb, cg, ch, cd2f : (n_el, n_qp)   tangent coefficients (cb, cg already include ±pJ)
    dI : (n_el, n_qp, 3, 3)    ∂I/∂F of the d2f term (ignored unless use_d2f)
    J : (n_el, n_qp)
    use_d2f : bool
    disp_up : bool             displacement form: no K_up / K_pu (they are zero)
    pos_uu : (n_el, 30, 30) int64; pos_up, pos_pu : (n_el, 30) int64
    data : (nnz,) float64
    """
    n_el, n_qp = w.shape
    Ke = np.empty((30, 30))
    Kup = np.empty(30)
    g = np.empty((10, 3))
    f = np.empty((10, 3))
    v = np.empty((10, 3))
    for e in range(n_el):
        Ke[:, :] = 0.0
        Kup[:] = 0.0
        for q in range(n_qp):
            wq = w[e, q]
            for a in range(10):
                for i in range(3):
                    sg = 0.0
                    sf = 0.0
                    sv = 0.0
                    for jj in range(3):
                        d = dN[e, q, a, jj]
                        sg += d * G[e, q, jj, i]
                        sf += d * F[e, q, i, jj]
                        if use_d2f:
                            sv += d * dI[e, q, i, jj]
                    g[a, i] = sg
                    f[a, i] = sf
                    v[a, i] = sv
            wa = wq * ca[e, q]
            wb = wq * cb[e, q]
            wg = wq * cg[e, q]
            wh = wq * ch[e, q]
            wd = wq * cd2f[e, q]
            wj = wq * J[e, q]
            for a in range(10):
                for i in range(3):
                    r = 3 * a + i
                    Kup[r] += wj * g[a, i]
                    gai = g[a, i]
                    fai = f[a, i]
                    vai = v[a, i]
                    # K is symmetric (every term is): the upper triangle c >= r, mirrored below
                    for b in range(a, 10):
                        dd = (dN[e, q, a, 0] * dN[e, q, b, 0] + dN[e, q, a, 1] * dN[e, q, b, 1]
                              + dN[e, q, a, 2] * dN[e, q, b, 2])
                        for k in range(i if b == a else 0, 3):
                            val = wb * gai * g[b, k] + wg * g[a, k] * g[b, i] + wh * (fai * g[b, k] + gai * f[b, k])
                            if use_d2f:
                                val += wd * vai * v[b, k]
                            if i == k:
                                val += wa * dd
                            Ke[r, 3 * b + k] += val
        for r in range(30):
            for c in range(r + 1, 30):
                Ke[c, r] = Ke[r, c]
        for r in range(30):
            for c in range(30):
                data[pos_uu[e, r, c]] += Ke[r, c]
            if not disp_up:
                data[pos_up[e, r]] += Kup[r]
                data[pos_pu[e, r]] += Kup[r]


if AVAILABLE:
    element_tangent_add = numba.njit(cache=True, nogil=True)(_element_tangent_add)
else:  # pragma: no cover
    element_tangent_add = None
