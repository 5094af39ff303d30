"""Point location in a TET10 mesh: host element and local coordinates xi.

For a query point q:

1. candidates: the ``k`` elements with the nearest vertex centroids (KD-tree);
2. linear guess: barycentric coordinates in each candidate's straight tet,
   ``xi = T^-1 (q - X_0)`` with ``T = [X_1 - X_0, X_2 - X_0, X_3 - X_0]``;
3. Newton on the isoparametric map ``X(xi) = sum_a N_a(xi) X_a``::

       xi <- xi - J(xi)^-1 (X(xi) - q),     J = dX/dxi = sum_a X_a (dN_a/dxi)^T

   for the best ``n_newton`` candidates; the host is the candidate whose converged
   xi is most inside the reference tet (largest minimum barycentric coordinate).

A point is "found" when that minimum barycentric coordinate is >= ``-tol``. Points not
found, or found only within the tolerance (slightly negative barycentric coordinate),
are retried with 4 and 16 times as many candidates and 8 x as many Newton starts (stretched or
curved elements, e.g. of the swept mesh, can have their centroids far from points near
their faces, and a straight-tet guess may rank the true host low). A point still not found
is tried last with a Newton start in each of those candidates: a strongly curved host's
straight tet can miss the point by more than the whole element, ranking it below the rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from fem import element


@dataclass(frozen=True)
class Location:
    """Host elements and local coordinates of located points.

    Attributes
    ----------
    host_elements : ndarray, shape (n,), int64
    local_coords : ndarray, shape (n, 3)
    inside : ndarray, shape (n,), bool
        Minimum barycentric coordinate >= -tol.
    residual : ndarray, shape (n,)
        ``|X(xi) - q|`` after Newton.
    """

    host_elements: np.ndarray
    local_coords: np.ndarray
    inside: np.ndarray
    residual: np.ndarray


class PointLocator:
    """Reusable locator for one mesh (see module docstring).

    Parameters
    ----------
    points : ndarray, shape (n_nodes, 3)
    cells : ndarray, shape (n_el, 10)
    """

    def __init__(self, points: np.ndarray, cells: np.ndarray) -> None:
        self.points = np.asarray(points, dtype=np.float64)
        self.cells = np.asarray(cells, dtype=np.int64)
        X = self.points[self.cells[:, :4]]  # (n_el, 4, 3)
        self.x0 = X[:, 0]
        T = np.transpose(X[:, 1:] - X[:, :1], (0, 2, 1))  # (n_el, 3, 3) columns = edges
        self.Tinv = np.linalg.inv(T)  # (n_el, 3, 3)
        self.tree = cKDTree(X.mean(axis=1))

    def linear_coords(self, q: np.ndarray, elems: np.ndarray) -> np.ndarray:
        """Straight-tet local coords of points q (n, 3) in elements elems (n, k), shape (n, k, 3)."""
        return np.einsum("nkij,nkj->nki", self.Tinv[elems], q[:, None, :] - self.x0[elems])  # (n, k, 3)

    def newton(self, q: np.ndarray, elems: np.ndarray, xi: np.ndarray, iters: int = 12) -> tuple[np.ndarray, np.ndarray]:
        """Newton inverse of the isoparametric map for points q (n,3) in elems (n,), start xi (n,3).

        Each point iterates until its own step is below 1e-14 (or ``iters`` iterations): the
        points that converged drop out, so a few far-outside starts do not keep the rest going.
        Returns xi (n, 3) and the residual ``|X(xi) - q|`` (n,).
        """
        Xe = self.points[self.cells[elems]]  # (n, 10, 3)
        xi = xi.copy()
        act = np.arange(len(q))  # points still iterating: a point stops once its own step is below 1e-14
        for _ in range(iters):
            xa, Xa = xi[act], Xe[act]  # (m, 3), (m, 10, 3)
            N = element.shape_functions(xa)  # (m, 10)
            dN = element.shape_gradients(xa)  # (m, 10, 3)
            r = np.einsum("na,nai->ni", N, Xa) - q[act]  # (m, 3)
            J = np.einsum("nai,naj->nij", Xa, dN)  # (m, 3, 3)
            J[np.abs(np.linalg.det(J)) < 1e-30] = np.eye(3)  # guard far-outside guesses
            step = np.linalg.solve(J, r[..., None])[..., 0]  # (m, 3)
            xi[act] = xa - step
            act = act[np.max(np.abs(step), axis=1) >= 1e-14]
            if len(act) == 0:
                break
        res = np.linalg.norm(np.einsum("na,nai->ni", element.shape_functions(xi), Xe) - q, axis=1)
        return xi, res

    def locate(self, q: np.ndarray, k: int = 24, n_newton: int = 4, tol: float = 1e-6) -> Location:
        """Locate points q, shape (n, 3) (see module docstring)."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        loc = self._locate(q, k, n_newton, tol)
        for factor in (4, 16):
            lam = _min_bary(loc.local_coords)
            miss = np.nonzero(~loc.inside | (lam < -1e-9))[0]  # not found, or only nearly inside
            if len(miss) == 0 or k >= len(self.cells):
                break
            k2 = min(len(self.cells), k * factor)
            self._take_better(loc, miss, self._locate(q[miss], k2, min(k2, 8 * factor), tol))
        lost = np.nonzero(~loc.inside)[0]
        if len(lost):  # rare: every candidate started, however its straight tet ranks
            k2 = min(len(self.cells), k * 16)
            self._take_better(loc, lost, self._locate(q[lost], k2, k2, tol))
        return loc

    @staticmethod
    def _take_better(loc: Location, idx: np.ndarray, sub: Location) -> None:
        """Replace the locations ``loc[idx]`` by those of ``sub`` that are inside where they were not, or more
        inside (larger minimum barycentric coordinate) with the same verdict."""
        lam = _min_bary(loc.local_coords[idx])
        better = (sub.inside & ~loc.inside[idx]) | ((sub.inside == loc.inside[idx]) & (_min_bary(sub.local_coords) > lam))
        for f in ("host_elements", "local_coords", "inside", "residual"):
            getattr(loc, f)[idx[better]] = getattr(sub, f)[better]

    def _locate(self, q: np.ndarray, k: int, n_newton: int, tol: float) -> Location:
        """One pass of :meth:`locate` with ``k`` candidates."""
        n_el = len(self.cells)
        k = min(k, n_el)
        _, cand = self.tree.query(q, k=k)
        cand = np.asarray(cand).reshape(len(q), k)
        xi_lin = self.linear_coords(q, cand)  # (n, k, 3)
        lam_min = np.minimum(1.0 - xi_lin.sum(axis=2), xi_lin.min(axis=2))  # (n, k)
        m = min(n_newton, k)
        order = np.argsort(-lam_min, axis=1)[:, :m]  # (n, m)
        rows = np.arange(len(q))[:, None]
        el = cand[rows, order]  # (n, m)
        xi0 = xi_lin[rows, order]  # (n, m, 3)
        xi, res = self.newton(np.repeat(q, m, axis=0), el.ravel(), np.clip(xi0.reshape(-1, 3), -0.5, 1.5))
        xi = xi.reshape(len(q), m, 3)
        res = res.reshape(len(q), m)
        lam = np.minimum(1.0 - xi.sum(axis=2), xi.min(axis=2))  # (n, m)
        lam = np.where(res < 1e-8 * (1.0 + np.abs(q).max()), lam, -np.inf)
        best = np.argmax(lam, axis=1)
        r = np.arange(len(q))
        return Location(
            host_elements=el[r, best].astype(np.int64),
            local_coords=xi[r, best],
            inside=lam[r, best] >= -tol,
            residual=res[r, best],
        )


def _min_bary(xi: np.ndarray) -> np.ndarray:
    """Smallest barycentric coordinate ``min(1 - sum xi, xi_1, xi_2, xi_3)``, shape (n,)."""
    return np.minimum(1.0 - xi.sum(axis=1), xi.min(axis=1))
