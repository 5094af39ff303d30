"""The simulated experiment: pressurise, then deflect, reading the gauge.

:func:`run_scene` runs three named steps on a :class:`~whisker_opt.experiment.gauge.GaugedMesh`
(a mesh with its gauge located in it when it is built):

1. :func:`pressurise`
    Base held by the mechanism ``spec.base_support`` (:mod:`whisker_opt.experiment.base_supports`: by default
    every base node fixed; or sliding, axial, gripped over a depth, on elastic supports), follower pressure Q
    on every cavity face, fibres
    embedded as trusses; the rubber is :func:`scene_material` (one law, or a cap of another).
    Skipped when Q = 0 (the state is then the reference state).
    Outputs the axial extension Δl(Q) (mean axial displacement of the tip face), the new
    length L_Q = L + Δl and the radial growth at mid-chamber (mean radial displacement of
    the outer surface nodes within ±0.5 mm of x = (c + l)/2).

2. Place the contact (:func:`whisker_opt.experiment.contact.place_contact_ring`)
    Off the tip on a structured mesh, mesh again (and pressurise again) until a node ring
    sits at the pressurised contact point a·L_Q.

3. :func:`deflect_and_read`
    The contact is modelled as a *band* of nodes whose current axial position after
    step 1 lies within ``band_width``/2 of the contact point x = a·L_Q (for a = 1 the nodes
    of the tip face only, so the tip may rotate). The band's y-displacement is prescribed (pushed by δ
    in −y from its pressurised position), its x and z displacements are free, so the
    section may slide axially and rotate under the edge: a frictionless edge whose local
    indentation is ignored, as the thesis neglected the contact's lateral slip. The
    band's width changes the reading little (measured in tests/test_scene.py and
    benchmarks/performance/bench_scene.py). The gauge (:mod:`whisker_opt.experiment.gauge`) is
    zeroed at contact onset and read at each solved deflection, and so are the contact force F
    (the band's reaction in −y, work-conjugate to δ) and the base reaction
    (:func:`contact_reactions`).

Only gauge quantities are evaluated per increment; full states are kept only when asked
(``keep_states=True``), e.g. for VTU output.
"""

from __future__ import annotations

import math
import contextlib
import logging
import time
from typing import Iterator
from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline

from fem.loadpath import solve_path
from fem.loads import LoadState
from fem.material import IsochoricI1Material
from fem.problem import Dirichlet, EmbeddedTrusses, FollowerPressure, Problem
from fem.state import State
from geometry.design import WhiskerDesign
from geometry.fibre_field import smeared_fibres
from geometry.mesh import MeshSizing, WhiskerMesh, build_mesh
from whisker_opt.experiment.base_supports import BaseHold, base_hold
from whisker_opt.experiment.contact import Contact, contact_band, place_contact_ring
from whisker_opt.experiment.gauge import GaugedMesh, GaugeReader, ReadingContext
from whisker_opt.experiment.gauge_patches import patch_membranes
from whisker_opt.experiment.gauge_variants import GAUGE_VARIANTS
from whisker_opt.experiment.cap_joints import cap_factor
from whisker_opt.experiment.rubber_laws import cap_law, rubber_material
from whisker_opt.experiment.spec import SceneSpec, cap_elements
from whisker_opt.wall.law import apply_law, chamber_elements, mid_chamber_x

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SceneResult:
    """Outputs of one scene.

    Attributes
    ----------
    delta : ndarray, shape (k + 1,)
        Solved deflections [mm], starting at 0.
    eps : dict of str -> ndarray, shape (k + 1,)
        Calibrated gauge readings [-] by name, one per registered reading
        (:data:`whisker_opt.experiment.gauge_variants.GAUGE_READINGS`: ``line``, ``centroid``).
    delta_l : float
        Axial extension of the tip after pressurisation [mm].
    length_q : float
        Whisker length after pressurisation, L_Q [mm].
    radial_growth : float
        Mean radial displacement of the outer surface at mid-chamber [mm].
    reports : tuple
        Solver step reports (pressurise, then deflect).
    timings : dict
        Seconds spent in 'mesh' (building the mesh and locating its gauge; about 0 for a
        given mesh), 'pressurise', 'contact_placement' (only when the contact needed new
        meshes), 'deflect', 'readout'.
    mesh : WhiskerMesh or None
    states : dict or None
        'pressurised' and 'deflected' :class:`fem.state.State` when kept.
    problems : dict or None
        The problems that solved the kept states, 'pressurised' and 'deflection' (their
        constitutive law, a wall law's scaling and frozen stress included, without the solver's
        caches), when the states are kept: :meth:`problem_of`.
    contact_x : float
        Mean current axial position of the contact nodes at contact onset [mm]; equals
        ``a·L_Q`` within :data:`whisker_opt.experiment.contact.CONTACT_TOL` on structured
        meshes (the ring is placed there, see :func:`run_scene`), within ``band_width``/2
        on fresh meshes.
    contact_force : ndarray, shape (k + 1,)
        Force the pusher exerts on the whisker in −y at each solved δ [N] (0 at onset):
        F = −Σ R_y over the contact band, R the residual f_int − f_ext of the deflection
        problem, which at a prescribed degree of freedom is the support's reaction
        (:func:`contact_reactions`).
    base_reaction : ndarray, shape (k + 1, 3)
        Force the base support exerts on the whisker at each solved δ [N] (x, y, z): Σ R
        over the held base nodes plus the force of any elastic supports (:func:`contact_reactions`).
        With Q = 0 its y component balances the contact force.
    von_mises_max : float
        Largest nodal von Mises stress of the deflected state (δ = ``spec.deflection``) [MPa]:
        :func:`peak_von_mises` of the deflection's problem (NaN when not computed).
    """

    spec: SceneSpec
    delta: np.ndarray
    eps: dict[str, np.ndarray]
    delta_l: float
    length_q: float
    radial_growth: float
    reports: tuple
    timings: dict
    mesh: WhiskerMesh | None = None
    states: dict | None = None
    contact_x: float = float("nan")
    contact_force: np.ndarray | None = None
    base_reaction: np.ndarray | None = None
    von_mises_max: float = float("nan")
    problems: dict | None = None

    def problem_of(self, state: str):
        """The problem that solved the kept state named ``state`` (a key of :attr:`states`): the
        pressurisation's for 'pressurised', the deflection's for the others; None when the
        result keeps no problems."""
        if self.problems is None:
            return None
        return self.problems["pressurised" if state == "pressurised" else "deflection"]

    @property
    def contact_stiffness(self) -> float:
        """Secant force–deflection stiffness over the first solved step, k = F(δ₁)/δ₁ [N/mm]
        (NaN without forces or steps)."""
        if self.contact_force is None or len(self.delta) < 2 or self.delta[1] <= 0:
            return float("nan")
        return float(self.contact_force[1] / self.delta[1])

    def curve(self, delta: np.ndarray, variant: str = "line") -> np.ndarray:
        """Gauge reading at arbitrary deflections by a cubic spline through the solved points.

        The spline is 'not-a-knot' with >= 4 points, otherwise linear interpolation. Its
        error against densely solved increments is measured in benchmarks/performance/bench_scene.py.
        """
        if variant not in GAUGE_VARIANTS:
            raise ValueError(f"gauge variant {variant!r} is not one of {', '.join(map(repr, GAUGE_VARIANTS))}")
        return self._spline(self.eps[variant], delta)

    def force(self, delta: np.ndarray, which: str = "contact") -> np.ndarray:
        """Contact force F (``which='contact'``) or the base reaction's y component (``'base_y'``)
        [N] at arbitrary deflections, by the spline of :meth:`curve`."""
        if self.contact_force is None:
            raise ValueError("force: this result holds no forces")
        return self._spline(self.contact_force if which == "contact" else self.base_reaction[:, 1], delta)

    def _spline(self, y: np.ndarray, delta: np.ndarray) -> np.ndarray:
        delta = np.asarray(delta, dtype=float)
        if np.any(delta < -1e-12) or np.any(delta > self.delta[-1] * (1 + 1e-9)):
            raise ValueError(
                f"curve: deflections must lie in [0, {self.delta[-1]}] mm, got "
                f"[{delta.min()}, {delta.max()}]"
            )
        if len(self.delta) >= 4:
            return CubicSpline(self.delta, y)(delta)
        return np.interp(delta, self.delta, y)


def scene_material(mesh, spec: SceneSpec) -> IsochoricI1Material:
    """The rubber of the scene on ``mesh`` (:attr:`SceneSpec.rubber`, :attr:`SceneSpec.cap_rubber`): one
    law, or the cap's law on :func:`cap_elements` and the body's elsewhere, the cap scaled by its joint
    (:attr:`SceneSpec.cap_joint`; :func:`whisker_opt.experiment.rubber_laws.rubber_material`)."""
    return rubber_material(spec.rubber, spec.cap_rubber, spec.c10, spec.d1, cap_elements(mesh, spec.design.c),
                           scene_cap_factor(spec))


def scene_cap_factor(spec: SceneSpec) -> float:
    """The factor of :attr:`SceneSpec.cap_joint` on the cap's moduli (1 for a tied cap)."""
    mu = cap_law(spec.rubber, spec.cap_rubber, spec.c10, spec.d1).shear_modulus
    return cap_factor(spec.cap_joint, spec, spec.design.c, mu)


def base_dirichlet(wm: WhiskerMesh, spec: SceneSpec) -> list[Dirichlet]:
    """The base's displacement sets (:attr:`SceneSpec.base_support`, its mechanism's
    :class:`~whisker_opt.experiment.base_supports.BaseHold`), all prescribed to zero; empty for a base on
    elastic supports alone."""
    return list(base_hold(wm, spec).dirichlet)


def make_problem(wm: WhiskerMesh, spec: SceneSpec, band_nodes: np.ndarray | None,
                 hold: BaseHold | None = None) -> Problem:
    """FE problem of the scene: the held base (``hold``, default that of ``spec.base_support``), cavity pressure
    (if Q > 0), fibres, the gauge's sheet (``spec.gauge_patch``), contact band."""
    d = spec.design
    hold = base_hold(wm, spec) if hold is None else hold
    dirichlet = list(hold.dirichlet)
    if band_nodes is not None:
        dirichlet.append(Dirichlet(band_nodes, (1,)))
    pressures = (FollowerPressure(wm.face_sets["cavity"]),) if spec.Q > 0 else ()
    if spec.fibre_model == "smeared":
        trusses, fields = (), (smeared_fibres(wm.mesh, d),)
    else:
        trusses, fields = tuple(EmbeddedTrusses(f.host_elements, f.local_coords, f.segments, d.fibre_E, d.fibre_area)
                                for f in wm.fibres), ()
    return Problem(
        mesh=wm.mesh,
        material=scene_material(wm.mesh, spec),
        dirichlet=tuple(dirichlet),
        pressures=pressures,
        trusses=trusses,
        fibre_fields=fields,
        supports=hold.supports,
        membranes=patch_membranes(wm, spec),
        formulation=spec.formulation,
    )


def mid_chamber_radial_growth(wm: WhiskerMesh, u: np.ndarray) -> float:
    """Mean radial displacement of the outer-surface nodes nearest to mid-chamber.

    Nodes within ±0.5 mm of x = (c + l)/2, widened to the nearest node ring on coarse
    meshes (at most a quarter of the chamber length either side).
    """
    d = wm.design
    X = wm.mesh.points
    outer = wm.node_sets["outer"]
    xm = mid_chamber_x(d)
    dist = np.abs(X[outer, 0] - xm)
    half = min(max(0.5, float(dist.min()) + 1e-9), 0.25 * (d.l - d.c))
    sel = outer[dist <= half]
    if len(sel) == 0:
        raise ValueError(f"no outer-surface node within {half:.3g} mm of mid-chamber x = {xm:.3g} mm")
    r = np.linalg.norm(X[sel, 1:], axis=1)  # (k,)
    ur = np.einsum("ki,ki->k", u[sel, 1:], X[sel, 1:]) / r  # (k,)
    return float(ur.mean())


class SceneRunner:
    """Runs scenes, with a memo of results and of meshes.

    A memo entry is keyed by the whole :class:`SceneSpec`, so an identical
    (design, trim, Q, a, fidelity) is solved once per runner. A mesh is kept with its
    located gauge (:class:`~whisker_opt.experiment.gauge.GaugedMesh`), so scenes on the
    same mesh locate the gauge once.

    Parameters
    ----------
    mesh_cache_dir : path or None
        Passed to :func:`geometry.mesh.build_mesh` (on-disk mesh cache).
    memo_size : int
        Maximum number of memoised results (oldest dropped first).
    pressurise_with : callable, optional
        ``pressurise_with(spec, wm) -> Pressurised`` in place of :func:`pressurise` (passed to
        :func:`run_scene`); e.g. a warm start of the Newton solve from a neighbouring pressure
        (:class:`whisker_opt.compensation.WarmPressurise`). Default: :func:`pressurise`.
    """

    def __init__(self, mesh_cache_dir=None, memo_size: int = 256, pressurise_with=None) -> None:
        self.mesh_cache_dir = mesh_cache_dir
        self.memo_size = memo_size
        self.pressurise_with = pressurise_with
        self._memo: dict[SceneSpec, SceneResult] = {}
        self._meshes: dict[tuple, GaugedMesh] = {}
        self.memo_hits = 0

    def mesh_for(self, spec: SceneSpec) -> WhiskerMesh:
        """The (cached) mesh of a scene's design, sizing and method."""
        return self.gauged_mesh(spec.design, spec.sizing, spec.mesh_method).wm

    def gauged_mesh(self, design: WhiskerDesign, sizing: MeshSizing, method: str) -> GaugedMesh:
        """The (cached) mesh of ``design`` with its gauge located in it."""
        key = (design, sizing, method)
        gm = self._meshes.get(key)
        if gm is None:
            wm = build_mesh(design, sizing, method=method, cache_dir=self.mesh_cache_dir)
            gm = GaugedMesh.locate(wm, design)
            if len(self._meshes) >= 8:
                self._meshes.pop(next(iter(self._meshes)))
            self._meshes[key] = gm
        return gm

    def run(self, spec: SceneSpec, keep_states: bool = False) -> SceneResult:
        """Solve one scene (or return the memoised result)."""
        hit = self._memo.get(spec)
        if hit is not None and (hit.states is not None or not keep_states):
            self.memo_hits += 1
            return hit
        gm = self.gauged_mesh(spec.design, spec.sizing, spec.mesh_method)
        res = run_scene(spec, gm, keep_states=keep_states, mesh_for=self.gauged_mesh,
                        pressurise_with=self.pressurise_with)
        if len(self._memo) >= self.memo_size:
            self._memo.pop(next(iter(self._memo)))
        self._memo[spec] = res
        return res


@dataclass(frozen=True, eq=False)
class Pressurised:
    """Step 1 on one mesh.

    Attributes
    ----------
    problem : Problem
        The pressurise problem (held base, cavity pressure, fibres); the deflection
        problem shares its topology cache.
    base_values : tuple of ndarray
        The zero values of the base's displacement sets (one (k, n_components) array per set of
        ``hold.dirichlet``, none for a base on elastic supports alone). Load states list these, then
        the contact band.
    state : State
        Pressurised state; the reference state when Q = 0.
    reports : list of fem.loadpath.StepReport
    hold : BaseHold
        What holds the base (:mod:`whisker_opt.experiment.base_supports`).
    """

    problem: Problem
    base_values: tuple
    state: State
    reports: list
    hold: BaseHold


def pressurise(spec: SceneSpec, wm: WhiskerMesh, start: tuple[float, State] | None = None) -> Pressurised:
    """Step 1 on ``wm``: held base, cavity pressure raised from 0 to Q (skipped when Q = 0).

    ``start = (Q0, state)``: a warm start, the pressure raised from Q0 to Q in one requested
    step from ``state``, a converged state at Q0 of this mesh or of one with the same nodes
    and elements (Newton removes the difference); the result equals the cold path's within
    the solver tolerances (measured in benchmarks/studies/compensation_map.py). Default: from the
    reference state at 0 in ``spec.n_pressure_steps`` steps.
    """
    hold = base_hold(wm, spec)
    prob1 = make_problem(wm, spec, None, hold)
    zeros = tuple(np.zeros(dr.shape) for dr in prob1.dirichlet)
    state = State.zero(prob1)
    if spec.Q <= 0:
        return Pressurised(prob1, zeros, state, [], hold)
    fr = tuple(np.linspace(0, 1, spec.n_pressure_steps + 1)[1:])
    q0, step = 0.0, 0.34
    if start is not None:
        q0, state, fr, step = float(start[0]), start[1], (1.0,), 1.0
    states, rep = solve_path(
        prob1,
        state,
        LoadState((q0,), zeros),
        LoadState((spec.Q,), zeros),
        fractions=fr,
        # full Newton: pressurising a fibre-wound chamber is strongly nonlinear, where
        # a reused tangent converges slowly (reuse ratio 0.05-0.2: 48-54 iterations
        # instead of 21), increments of at most a third of Q with the secant
        # predictor, and the increments before the last converged only to
        # PRESSURE_INTERMEDIATE_RTOL (the last one, at Q, to rtol): with the line search of
        # the first iteration and the factorisation kept near the solution (SolveOptions),
        # 9 factorisations to 0.2 MPa instead of 19 (benchmarks/README.md, ab_eval.py)
        options=replace(spec.solve_options, reuse_tangent=0.0,
                        initial_step=min(spec.solve_options.initial_step, step),
                        max_step=min(spec.solve_options.max_step, step),
                        intermediate_rtol=_pressure_intermediate_rtol(spec.solve_options)),
    )
    return Pressurised(prob1, zeros, states[-1], list(rep), hold)


#: Residual tolerance of the pressurisation's increments below Q (their energy tolerance is its
#: square); the state at Q is converged to the scene's own ``rtol``/``etol``.
PRESSURE_INTERMEDIATE_RTOL = 0.1


def _pressure_intermediate_rtol(opts) -> float:
    """The pressurisation's intermediate tolerance: the scene's own when set, else
    :data:`PRESSURE_INTERMEDIATE_RTOL` (never below ``opts.rtol``)."""
    return opts.intermediate_rtol if opts.intermediate_rtol is not None else max(PRESSURE_INTERMEDIATE_RTOL, opts.rtol)


def scene_contact(spec: SceneSpec) -> Contact:
    """The contact of ``spec``: at a·L_Q, or at a·L for ``contact_at='reference'`` under pressure."""
    reference = spec.contact_at == "reference" and spec.Q > 0
    return Contact(spec.contact_ratio, spec.design.length, follows_extension=not reference)


@dataclass(frozen=True, eq=False)
class Deflection:
    """Step 2: the gauge readings along the deflection.

    Attributes
    ----------
    fractions : tuple of float
        Solved fractions of ``spec.deflection``.
    readings : ndarray, shape (k + 1, n_readings)
        Calibrated readings, one column per registered reading in :data:`GAUGE_VARIANTS` order, the first
        row at onset (0, ...).
    states : list of State
        The state at each fraction.
    reports : list of fem.loadpath.StepReport
    band : ndarray
        The contact nodes.
    time_read : float
        Seconds spent reading the gauge.
    forces : ndarray, shape (k + 1, 4)
        Contact force F [N] and base reaction (x, y, z) [N] at onset and at each fraction
        (:func:`contact_reactions`).
    problem : Problem or None
        The problem the deflection was solved with (the wall law applied).
    """

    fractions: tuple
    readings: np.ndarray
    states: list
    reports: list
    band: np.ndarray
    time_read: float
    forces: np.ndarray | None = None
    problem: Problem | None = None


def contact_reactions(problem: Problem, state: State, pressures: tuple, band: np.ndarray,
                      base: np.ndarray, residual: np.ndarray | None = None) -> np.ndarray:
    """Contact force and base reaction of ``state``: ``[F, R_x, R_y, R_z]`` [N].

    The residual R = f_int − f_ext (:meth:`fem.assembly.Assembler.evaluate`) vanishes at the free
    degrees of freedom of a converged state; at a prescribed one it is the force the support
    exerts on the body (equilibrium f_int = f_ext + r). So the contact force in −y is
    F = −Σ_{band} R_y and the base reaction is Σ_{base} R (x, y, z components) plus the force of
    the problem's elastic supports (:func:`fem.assembly.support_forces`; a base on springs has no
    prescribed degree of freedom, so the springs carry the whole reaction). F is work-conjugate to δ:
    F dδ is the work of the pusher.

    Parameters
    ----------
    problem : Problem
        The deflection problem (base and band prescribed).
    state : State
    pressures : tuple of float
        The follower pressures' magnitudes at ``state``.
    band, base : ndarray of int
        Contact band and the held base nodes (:attr:`whisker_opt.experiment.base_supports.BaseHold.nodes`).
    residual : ndarray, optional
        R of ``state`` under ``problem`` and ``pressures`` when already known (the converged
        Newton solve's last evaluation, :attr:`fem.state.State.residual`); evaluated otherwise.

    Returns
    -------
    ndarray, shape (4,)
    """
    from fem.assembly import Assembler, support_forces

    R = residual
    if R is None:
        R = Assembler(problem).evaluate(state.u, state.p, pressures, need_tangent=False)[0]
    Ru = R[: 3 * problem.mesh.n_nodes].reshape(-1, 3)  # (n_nodes, 3)
    held = Ru[base].sum(axis=0) + sum(support_forces(problem, state.u), np.zeros(3))  # (3,)
    return np.concatenate([[-Ru[band, 1].sum()], held])


def reading_context(spec: SceneSpec) -> ReadingContext:
    """What the gauge readings know of ``spec``: the wall cell's transfer G(Q) at its pressure and wall
    (:meth:`whisker_opt.wall.law.WallLaw.gauge_transfer`; NaN outside the wall table, where the ``section``
    reading is then NaN)."""
    try:
        return ReadingContext(spec.law.gauge_transfer(spec.Q, spec.design))
    except ValueError as exc:
        logger.debug("section reading unavailable: %s", exc)
        return ReadingContext(math.nan)


def deflect_and_read(spec: SceneSpec, gm: GaugedMesh, pre: Pressurised, contact: Contact) -> Deflection:
    """Step 2: push the contact band by ``spec.deflection`` in −y, reading the gauge.

    The band's y-displacement goes linearly from its pressurised value u_y⁰ to
    u_y⁰ − δ (its x, z free); the pressure stays at Q. The gauge is zeroed on the
    pressurised state and read at each of ``spec.n_deflection_steps`` equal fractions.
    A wall law other than 'embedded' (``spec.wall_law``) changes the chamber wall's incremental
    stiffness about the pressurised state (:func:`whisker_opt.wall.law.apply_law`).
    """
    wm, u1 = gm.wm, pre.state.u
    reader = GaugeReader(wm.mesh, gm.gauge, spec.calibration, reading_context(spec))
    band = contact_band(wm, u1, contact.x(wm, u1), spec.band_width, contact.at_tip)
    # same mesh, faces and fibres: replace() shares the topology cache (sparsity
    # pattern, PARDISO analysis) with the pressurise problem
    prob2 = replace(pre.problem, dirichlet=(*pre.hold.dirichlet, Dirichlet(band, (1,))))
    if not spec.law.identity:  # the wall law about the pressurised state (whisker_opt.wall.law)
        prob2 = apply_law(prob2, pre.state, spec.law.factor(spec.Q, spec.design),
                          chamber_elements(wm.mesh.points, wm.mesh.cells, spec.design))
    uy0 = u1[band, 1:2]  # (k, 1)
    pq = (spec.Q,) if spec.Q > 0 else ()
    load0 = LoadState(pq, (*pre.base_values, uy0))
    load1 = LoadState(pq, (*pre.base_values, uy0 - spec.deflection))
    reader.zero(u1)
    fractions = tuple(np.linspace(0, 1, spec.n_deflection_steps + 1)[1:])
    readings = [(0.0,) * len(GAUGE_VARIANTS)]
    t_read = [0.0]
    base = np.asarray(pre.hold.nodes, dtype=np.int64)
    forces = [contact_reactions(prob2, pre.state, pq, band, base)]
    forces[0][0] = 0.0  # onset: the pusher only touches (the band's residual is the solver's round-off)

    def _read(fraction: float, st: State) -> None:
        tr = time.perf_counter()
        readings.append(tuple(reader.read(st.u).values()))
        forces.append(contact_reactions(prob2, st, pq, band, base, st.residual))  # R of prob2's solve
        t_read[0] += time.perf_counter() - tr

    states, reports = solve_path(prob2, pre.state, load0, load1, fractions=fractions, options=spec.solve_options,
                                 callback=_read)
    return Deflection(fractions, np.array(readings), states, list(reports), band, t_read[0], np.array(forces),
                      prob2)


def _gauged(m: WhiskerMesh | GaugedMesh, design: WhiskerDesign) -> GaugedMesh:
    """``m`` with its gauge: as given, or located now."""
    return m if isinstance(m, GaugedMesh) else GaugedMesh.locate(m, design)


#: Attribute names under which a failing step leaves its context on the exception it raises.
FAILED_WITH, FAILED_WHILE = "scene_spec", "scene_step"


@contextlib.contextmanager
def _step(spec: SceneSpec, step: str) -> Iterator[None]:
    """Leave the scene's spec and the step (e.g. ``"pressurising"``) on an exception raised inside,
    keeping its type (the evaluator classifies failures by type); the innermost step wins."""
    try:
        yield
    except Exception as exc:
        for attr, value in ((FAILED_WITH, spec), (FAILED_WHILE, step)):
            if getattr(exc, attr, None) is None:
                try:
                    setattr(exc, attr, value)
                except AttributeError:  # pragma: no cover - an exception type without a __dict__
                    pass
        raise


def run_scene(spec: SceneSpec, wm: WhiskerMesh | GaugedMesh | None = None, keep_states: bool = False,
              mesh_for=None, pressurise_with=None) -> SceneResult:
    """Pressurise-then-deflect one whisker and read its gauge.

    The steps: :func:`pressurise`; for off-tip contact on a structured mesh, place a
    node ring at a·L_Q (:func:`whisker_opt.experiment.contact.place_contact_ring`, which
    meshes and pressurises again, the time going to ``timings['contact_placement']``);
    :func:`deflect_and_read`.

    Parameters
    ----------
    spec : SceneSpec
    wm : WhiskerMesh or GaugedMesh, optional
        A mesh of ``spec.design`` (its gauge is located unless given with it); built
        when not given.
    keep_states : bool
        Keep the pressurised and final states and every solved deflection increment
        (keys ``pressurised``, ``deflected`` and ``delta_<δ>`` with δ in mm to two
        decimals, e.g. ``delta_1.00``; the last is the ``deflected`` state), for VTU output.
    mesh_for : callable, optional
        ``mesh_for(design, sizing, method) -> WhiskerMesh`` (or ``GaugedMesh``) for the
        mesh and the contact placement's meshes (e.g. a cache); default
        :func:`geometry.mesh.build_mesh`.
    pressurise_with : callable, optional
        ``pressurise_with(spec, wm) -> Pressurised`` for every pressurisation of the scene (its
        mesh's and the contact placement's); default :func:`pressurise`.

    Raises
    ------
    geometry.design.InvalidDesignError
        Impossible geometry.
    fem.newton.SolveFailed
        The nonlinear solve did not converge (carries the report).

    Any exception leaves the spec and the step that failed on itself (:data:`FAILED_WITH`,
    :data:`FAILED_WHILE`), so a caller can say which scene failed where without a second type.
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    design = spec.design
    design.validate()
    if mesh_for is None:
        def mesh_for(d, sizing, method):
            return build_mesh(d, sizing, method=method)

    def remesh(sizing: MeshSizing, method: str) -> GaugedMesh:
        with _step(spec, "meshing"):
            return _gauged(mesh_for(design, sizing, method), design)

    def pressurised(g: GaugedMesh) -> Pressurised:
        with _step(spec, "pressurising"):
            return (pressurise if pressurise_with is None else pressurise_with)(spec, g.wm)

    gm = remesh(spec.sizing, spec.mesh_method) if wm is None else _gauged(wm, design)
    timings["mesh"] = time.perf_counter() - t0

    t = time.perf_counter()
    pre = pressurised(gm)
    timings["pressurise"] = time.perf_counter() - t
    t = time.perf_counter()
    contact = scene_contact(spec)
    with _step(spec, "placing the contact"):
        placed, pre = place_contact_ring(contact, gm, pre, spec.sizing, remesh, pressurised)
    if placed is not gm:
        timings["contact_placement"] = time.perf_counter() - t
    gm = placed
    wm, u1 = gm.wm, pre.state.u
    delta_l = float(u1[wm.node_sets["tip"], 0].mean())
    radial = mid_chamber_radial_growth(wm, u1) if spec.Q > 0 else 0.0

    t = time.perf_counter()
    with _step(spec, "deflecting"):
        dfl = deflect_and_read(spec, gm, pre, contact)
    timings["deflect"] = time.perf_counter() - t - dfl.time_read
    timings["readout"] = dfl.time_read
    delta = np.concatenate([[0.0], np.asarray(dfl.fractions) * spec.deflection])
    kept, problems = _kept(spec, pre, dfl) if keep_states else (None, None)
    logger.debug("scene %s: %s", design, timings)
    return SceneResult(
        spec=spec,
        delta=delta,
        eps={name: dfl.readings[:, j] for j, name in enumerate(GAUGE_VARIANTS)},
        delta_l=delta_l,
        length_q=design.length + delta_l,
        radial_growth=radial,
        reports=tuple(pre.reports + dfl.reports),
        timings=timings,
        mesh=wm if keep_states else None,
        states=kept,
        contact_x=float(np.mean(wm.mesh.points[dfl.band, 0] + u1[dfl.band, 0])),
        contact_force=dfl.forces[:, 0],
        base_reaction=dfl.forces[:, 1:],
        von_mises_max=peak_von_mises(dfl.problem, dfl.states[-1]),
        problems=problems,
    )


def _kept(spec: SceneSpec, pre: Pressurised, dfl: Deflection) -> tuple[dict, dict]:
    """The states a result keeps (:attr:`SceneResult.states`) and the problems that solved them
    (:attr:`SceneResult.problems`), without their caches (sparsity, factorisation): a kept result
    holds no solver."""
    states = {"pressurised": pre.state, "deflected": dfl.states[-1],
              **{f"delta_{f * spec.deflection:.2f}": st for f, st in zip(dfl.fractions, dfl.states)}}
    return states, {"pressurised": replace(pre.problem, _cache={}), "deflection": replace(dfl.problem, _cache={})}


def peak_von_mises(problem: Problem, state: State) -> float:
    """Largest nodal von Mises stress of a state solved with ``problem`` [MPa].

    σ_vM = sqrt(3/2 s:s), s the deviator of the nodal Cauchy stress of the problem's own
    constitutive law (:func:`fem.post.problem_strain_stress`: the scene's rubber, and under a wall
    law its scaled moduli and frozen stress; the stress the result files and the viewer show),
    maximised over the nodes of the mesh.
    """
    from fem import post
    from fem.material import von_mises_stress

    sigma = post.problem_strain_stress(problem, state.u, state.p)[1]  # (n_nodes, 3, 3)
    return float(np.nanmax(von_mises_stress(sigma)))

