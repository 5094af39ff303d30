"""Sparsity pattern of the mixed u–p system and scatter maps for fast assembly.

The pattern is built once per topology (mesh, loaded faces, fibres) at the level of
node pairs, then expanded to DOFs arithmetically, so that assembling a matrix is a
single ``np.bincount`` of element contributions into the CSR data array.

DOF numbering: displacement DOF 3·node + component for node < n_nodes, then one
pressure DOF ``n_u + e`` per element. CSR rows of node ``r`` (three of them, one per
component) hold, in column order: the three DOFs of every node coupled to ``r`` (sorted
by node), then the pressure DOFs of the elements containing ``r`` (sorted). Pressure
row ``n_u + e`` holds the 30 displacement DOFs of the element's nodes, then itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp


@dataclass(frozen=True)
class Pattern:
    """CSR structure of the tangent and the maps used to scatter into it.

    Attributes
    ----------
    n_nodes, n_elements : int
    indptr, indices : ndarray
        CSR structure, shape (n_dofs + 1,) and (nnz,).
    elem_uu : ndarray (n_el, 30, 30)
        Data position of element entry (3a+i, 3b+k).
    elem_up, elem_pu : ndarray (n_el, 30)
        Positions of (3a+i, p_e) and (p_e, 3a+i).
    elem_pp : ndarray (n_el,)
        Position of (p_e, p_e).
    diag : ndarray (n_dofs,)
        Position of each diagonal entry.
    """

    n_nodes: int
    n_elements: int
    indptr: np.ndarray
    indices: np.ndarray
    elem_uu: np.ndarray
    elem_up: np.ndarray
    elem_pu: np.ndarray
    elem_pp: np.ndarray
    diag: np.ndarray
    _node_ptr: np.ndarray
    _node_cols: np.ndarray
    _base: np.ndarray
    _rowlen: np.ndarray

    @property
    def n_u(self) -> int:
        return 3 * self.n_nodes

    @property
    def n_dofs(self) -> int:
        return self.n_u + self.n_elements

    @property
    def nnz(self) -> int:
        return len(self.indices)

    def node_block_positions(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Data positions of the 3×3 blocks of node pairs (rows[..], cols[..]).

        Parameters
        ----------
        rows, cols : ndarray of int, same shape S
            Node pairs that must be part of the pattern.

        Returns
        -------
        ndarray, shape S + (3, 3)
            ``pos[..., i, k]`` = position of (3·row + i, 3·col + k).
        """
        rows = np.asarray(rows, dtype=np.int64)
        cols = np.asarray(cols, dtype=np.int64)
        start = self._node_ptr[rows]
        # position of col within row's sorted neighbour list
        n = self.n_nodes
        keys = rows * n + cols
        flat_keys = self._node_ptr_keys()
        k = np.searchsorted(flat_keys, keys)
        if np.any(k >= len(flat_keys)) or np.any(flat_keys[np.minimum(k, len(flat_keys) - 1)] != keys):
            raise ValueError("node pair outside the sparsity pattern")
        j = k - start  # (S)
        base = self._base[rows][..., None, None]
        rl = self._rowlen[rows][..., None, None]
        i = np.arange(3)[:, None]
        kk = np.arange(3)[None, :]
        return base + i * rl + 3 * j[..., None, None] + kk

    def _node_ptr_keys(self) -> np.ndarray:
        rows = np.repeat(np.arange(self.n_nodes, dtype=np.int64), np.diff(self._node_ptr))
        return rows * self.n_nodes + self._node_cols

    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """CSR matrix with this structure and ``data`` (no copy)."""
        A = sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs, self.n_dofs))
        A.has_sorted_indices = True
        return A


def build_pattern(n_nodes: int, cells: np.ndarray, extra_node_groups: list[np.ndarray] = ()) -> Pattern:
    """Build the pattern for ``cells`` plus groups of coupled nodes.

    Parameters
    ----------
    n_nodes : int
    cells : ndarray (n_el, 10)
    extra_node_groups : list of ndarray (n_groups, m)
        Each row is a set of nodes that are all coupled (a loaded face, the two
        host elements of a fibre segment).
    """
    cells = np.asarray(cells, dtype=np.int64)
    n_el, nen = cells.shape
    n = n_nodes
    key_parts = [(cells[:, :, None] * n + cells[:, None, :]).ravel()]
    for g in extra_node_groups:
        g = np.asarray(g, dtype=np.int64)
        if g.size:
            key_parts.append((g[:, :, None] * n + g[:, None, :]).ravel())
    keys = np.unique(np.concatenate(key_parts))  # sorted node-pair keys
    rows = keys // n
    cols = keys - rows * n
    node_ptr = np.zeros(n + 1, dtype=np.int64)
    np.add.at(node_ptr, rows + 1, 1)
    node_ptr = np.cumsum(node_ptr)
    m = np.diff(node_ptr)  # neighbours per node
    if np.any(m == 0):
        raise ValueError(f"{int(np.sum(m == 0))} nodes belong to no element (empty rows)")

    # elements containing each node (pressure columns), sorted
    node_el = np.unique(cells.ravel() * n_el + np.repeat(np.arange(n_el), nen))
    ne_node = node_el // n_el
    ne_el = node_el - ne_node * n_el
    q_ptr = np.zeros(n + 1, dtype=np.int64)
    np.add.at(q_ptr, ne_node + 1, 1)
    q_ptr = np.cumsum(q_ptr)
    q = np.diff(q_ptr)

    rowlen = 3 * m + q  # length of each of the 3 DOF rows of a node
    base = np.concatenate([[0], np.cumsum(3 * rowlen)[:-1]])  # start of node r's first row
    n_u = 3 * n
    nnz_u = int(np.sum(3 * rowlen))
    # pressure rows: unique nodes of the element (10 normally) * 3 + 1
    nnz = nnz_u + n_el * (3 * nen + 1)

    indptr = np.empty(n_u + n_el + 1, dtype=np.int64)
    indptr[:n_u] = (base[:, None] + np.arange(3)[None, :] * rowlen[:, None]).ravel()
    indptr[n_u:] = nnz_u + np.arange(n_el + 1) * (3 * nen + 1)
    indices = np.empty(nnz, dtype=np.int64)
    # u rows: node-pair columns then pressure columns
    for i in range(3):
        # displacement columns
        start_rows = base + i * rowlen  # (n,)
        pos = np.repeat(start_rows, m) + 3 * (np.arange(len(cols)) - np.repeat(node_ptr[:-1], m))
        for k in range(3):
            indices[pos + k] = 3 * cols + k
        ppos = np.repeat(start_rows + 3 * m, q) + (np.arange(len(ne_el)) - np.repeat(q_ptr[:-1], q))
        indices[ppos] = n_u + ne_el
    # pressure rows: sorted element DOFs then the diagonal
    srt = np.sort(cells, axis=1)  # (n_el, 10)
    if np.any(srt[:, 1:] == srt[:, :-1]):
        raise ValueError("an element repeats a node")
    pcols = (3 * srt[:, :, None] + np.arange(3)[None, None, :]).reshape(n_el, 3 * nen)
    prow = np.concatenate([pcols, (n_u + np.arange(n_el))[:, None]], axis=1)
    indices[nnz_u:] = prow.ravel()

    pat = Pattern(n, n_el, indptr, indices, None, None, None, None, None, node_ptr, cols, base, rowlen)
    # element maps ------------------------------------------------------------
    uu = pat.node_block_positions(cells[:, :, None], cells[:, None, :])  # (n_el, 10, 10, 3, 3)
    elem_uu = uu.transpose(0, 1, 3, 2, 4).reshape(n_el, 3 * nen, 3 * nen)  # (n_el, 30, 30) [3a+i, 3b+k]
    # (3a+i, p_e): row of node a comp i, column position of element e among node a's elements
    loc = np.searchsorted(node_el, cells * n_el + np.arange(n_el)[:, None])  # (n_el, 10) index into node_el
    jq = loc - q_ptr[cells]  # position among node's elements
    elem_up = (base[cells][:, :, None] + np.arange(3)[None, None, :] * rowlen[cells][:, :, None]
               + 3 * m[cells][:, :, None] + jq[:, :, None]).reshape(n_el, 3 * nen)
    # (p_e, 3a+i): position of 3a+i in the sorted pressure row
    order = np.argsort(cells, axis=1, kind="stable")
    rank = np.empty_like(order)
    np.put_along_axis(rank, order, np.arange(nen)[None, :].repeat(n_el, 0), axis=1)
    elem_pu = (nnz_u + (3 * nen + 1) * np.arange(n_el)[:, None, None] + 3 * rank[:, :, None]
               + np.arange(3)[None, None, :]).reshape(n_el, 3 * nen)
    elem_pp = nnz_u + (3 * nen + 1) * np.arange(n_el) + 3 * nen
    # diagonal
    dn = pat.node_block_positions(np.arange(n), np.arange(n))  # (n, 3, 3)
    diag = np.concatenate([dn[:, [0, 1, 2], [0, 1, 2]].ravel(), elem_pp])
    return Pattern(n, n_el, indptr, indices, elem_uu, elem_up, elem_pu, elem_pp, diag, node_ptr, cols, base, rowlen)
