"""Where the local fits start: a coarse scan of the parameter box, and whether the fits agree.

A local least-squares fit finds the minimum of the cost whose basin holds its start; a cost with more
than one minimum over the box (e.g. restore observations the model matches over part of it only)
gives a result that depends on the start. Before the local fits, the cost is therefore evaluated on
a coarse, deterministic scan of the box: a centred Latin hypercube of :func:`scan_size` points in the
normalised parameters u ∈ [0, 1]^n (each parameter's range cut into that many equal cells, each cell
centre taken once; the cells are paired across parameters by a permutation drawn with the fixed seed
:data:`SEED`, so the same box gives the same points on every run and from every start). One local
fit starts at the run file's start; when a scanned point has a lower cost, a second one starts at the
best of them. The fit of lower final cost is the result (:func:`whisker_opt.calibration.fit.fit`);
two fits that end apart (:func:`disagree`: in cost, or in a parameter the data determine) make the
result start-dependent, and that is reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Seed of the scan's pairing of cells across parameters (a fixed number: the scan is part of the method).
SEED = 0
#: Two local fits agree when their costs, and their ends in every determined parameter, lie within this many
#: ``tolerance`` (of the cost, of the range) of each other.
AGREEMENT = 10.0
#: Costs C = χ²/2 closer than this are the same: Δχ² < 1 is within one standard deviation.
COST_SAME = 0.5
#: What started a local fit.
FROM_START = "the run file's start"
FROM_SCAN = "the scan's best point"


def scan_size(n: int) -> int:
    """Points of the scan for n parameters: 4n + 2 (six cells of each range for one parameter)."""
    return 4 * int(n) + 2


def scan_points(n: int, seed: int = SEED) -> np.ndarray:
    """The scan's points in the normalised parameters, shape (:func:`scan_size`, n), in [0, 1].

    Parameters
    ----------
    n : int
        Number of parameters.
    seed : int

    Returns
    -------
    ndarray, shape (4n + 2, n)
        Centres of the cells (k + ½)/N, k = 0 … N − 1, of each parameter, once each, sorted by the
        first parameter.
    """
    from scipy.stats import qmc

    pts = qmc.LatinHypercube(d=int(n), scramble=False, seed=seed).random(scan_size(n))  # (N, n)
    return pts[np.lexsort(pts.T[::-1])]


@dataclass(frozen=True)
class LocalFit:
    """One local least-squares fit.

    Attributes
    ----------
    origin : str
        :data:`FROM_START` or :data:`FROM_SCAN`.
    start, values : ndarray, shape (n,)
        Where it started and ended, in the parameters' units.
    cost_start, cost : float
        C there.
    status : int
    message : str
        ``least_squares``' status (> 0: converged) and message.
    evaluations : int
        Distinct parameter sets it evaluated (its Jacobian's included).
    """

    origin: str
    start: np.ndarray
    values: np.ndarray
    cost_start: float
    cost: float
    status: int
    message: str
    evaluations: int


def disagree(fits, widths, tolerance: float, determined=None) -> bool:
    """Some two fits end apart: their costs differ by more than :data:`AGREEMENT` × ``tolerance`` of the
    larger and by more than :data:`COST_SAME` (χ² by more than 1: statistically distinct), or a
    determined parameter's ends by more than :data:`AGREEMENT` × ``tolerance`` × its range (a parameter
    the data do not determine may end anywhere; it is reported as such).

    Parameters
    ----------
    fits : sequence of LocalFit
    widths : array_like, shape (n,)
        upper − lower of each parameter.
    tolerance : float
        The fit's tolerance (a fraction of each range, and of the cost).
    determined : sequence of bool, shape (n,), optional
        The parameters compared (default all).

    Returns
    -------
    bool
    """
    if len(fits) < 2:
        return False
    ends = np.array([f.values for f in fits], dtype=float)  # (n_fits, n)
    costs = np.array([f.cost for f in fits], dtype=float)  # (n_fits,)
    mask = np.ones(ends.shape[1], dtype=bool) if determined is None else np.asarray(determined, dtype=bool)
    spread = ends.max(axis=0) - ends.min(axis=0)  # (n,)
    apart = np.any(spread[mask] > AGREEMENT * tolerance * np.asarray(widths, dtype=float)[mask])
    gap = costs.max() - costs.min()
    return bool(apart or gap > max(AGREEMENT * tolerance * costs.max(), COST_SAME))
