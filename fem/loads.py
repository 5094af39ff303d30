"""Load magnitudes applied to a :class:`fem.problem.Problem`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem.problem import ProblemError


@dataclass(frozen=True)
class LoadState:
    """Magnitudes of a problem's loads at one point of a load path.

    Parameters
    ----------
    pressures : tuple of float
        One magnitude [MPa] per ``Problem.pressures`` entry.
    dirichlet_values : tuple of ndarray
        One (k, n_comp) array [mm] per ``Problem.dirichlet`` entry (a scalar broadcasts).
    tractions : tuple of array-like (3,)
        One traction vector [MPa] per ``Problem.tractions`` entry (empty = all zero).
    """

    pressures: tuple[float, ...] = ()
    dirichlet_values: tuple = ()
    tractions: tuple = ()

    @classmethod
    def zero(cls, problem) -> "LoadState":
        return cls(tuple(0.0 for _ in problem.pressures), tuple(np.zeros(d.shape) for d in problem.dirichlet),
                   tuple(np.zeros(3) for _ in problem.tractions))

    def check(self, problem) -> "LoadState":
        """Validate against ``problem`` and return a copy with full-shape arrays."""
        if len(self.pressures) != len(problem.pressures):
            raise ProblemError(
                f"LoadState.pressures: {len(self.pressures)} values for {len(problem.pressures)} pressure sets"
            )
        if len(self.dirichlet_values) != len(problem.dirichlet):
            raise ProblemError(
                f"LoadState.dirichlet_values: {len(self.dirichlet_values)} arrays for {len(problem.dirichlet)} sets"
            )
        vals = []
        for d, v in zip(problem.dirichlet, self.dirichlet_values):
            try:
                vals.append(np.broadcast_to(np.asarray(v, dtype=float), d.shape).copy())
            except ValueError:
                raise ProblemError(
                    f"LoadState.dirichlet_values[{d.name}]: shape {np.shape(v)} does not broadcast to {d.shape}"
                ) from None
        tr = self.tractions if self.tractions else tuple(np.zeros(3) for _ in problem.tractions)
        if len(tr) != len(problem.tractions):
            raise ProblemError(f"LoadState.tractions: {len(tr)} vectors for {len(problem.tractions)} traction sets")
        tr = tuple(np.broadcast_to(np.asarray(t, float), (3,)).copy() for t in tr)
        for k, p in enumerate(self.pressures):
            if not np.isfinite(p):
                raise ProblemError(f"LoadState.pressures[{k}]={p!r} must be finite")
        return LoadState(tuple(float(p) for p in self.pressures), tuple(vals), tr)

    def interpolate(self, other: "LoadState", s: float) -> "LoadState":
        """(1 − s)·self + s·other."""
        return LoadState(
            tuple((1 - s) * a + s * b for a, b in zip(self.pressures, other.pressures)),
            tuple((1 - s) * np.asarray(a) + s * np.asarray(b) for a, b in zip(self.dirichlet_values, other.dirichlet_values)),
            tuple((1 - s) * np.asarray(a) + s * np.asarray(b) for a, b in zip(self.tractions, other.tractions)),
        )

    def prescribed_vector(self, problem) -> tuple[np.ndarray, np.ndarray]:
        """(dofs, values) of all prescribed displacement components."""
        if not problem.dirichlet:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        dofs = np.concatenate([d.dofs().ravel() for d in problem.dirichlet])
        vals = np.concatenate([np.broadcast_to(np.asarray(v, float), d.shape).ravel()
                               for d, v in zip(problem.dirichlet, self.dirichlet_values)])
        return dofs, vals
