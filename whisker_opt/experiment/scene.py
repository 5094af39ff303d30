"""The simulated experiment: pressurise, then deflect, reading the gauge (SPEC §5).

Step 1, pressurise
    Base face fixed (all components), follower pressure Q on every cavity face, fibres
    embedded as trusses. Skipped when Q = 0 (the state is then the reference state).
    Outputs the axial extension Δl(Q) (mean axial displacement of the tip face), the new
    length L_Q = L + Δl and the radial growth at mid-chamber (mean radial displacement of
    the outer surface nodes within ±0.5 mm of x = (c + l)/2).

Step 2, deflect
    The contact is modelled as a *band* of nodes whose current axial position after
    step 1 lies within ``band_width``/2 of the contact point x = a·L_Q (for a = 1 the nodes
    of the tip face only, so the tip may rotate). The band's y-displacement is prescribed (pushed by δ
    in −y from its pressurised position), its x and z displacements are free, so the
    section may slide axially and rotate under the edge: a frictionless edge whose local
    indentation is ignored, as the thesis neglected the contact's lateral slip. The
    band's width changes the reading little (measured in tests/test_scene.py and
    benchmarks/bench_scene.py).

Gauge
    See :mod:`whisker_opt.experiment.gauge`; it is zeroed at contact onset.

Only gauge quantities are evaluated per increment; full states are kept only when asked
(``keep_states=True``), e.g. for VTU output.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.interpolate import CubicSpline

from fem.loads import LoadState
from fem.material import NeoHookean
from fem.problem import Dirichlet, EmbeddedTrusses, FollowerPressure, Problem
from fem.state import State
from fem.stepping import SolveOptions, solve_path
from geometry.design import WhiskerDesign
from geometry.mesh import MeshSizing, WhiskerMesh, build_mesh
from whisker_opt.experiment.gauge import GaugeGeometry, GaugeReader, gauge_points

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SceneSpec:
    """Everything that determines one scene's result (hashable, so it keys the memo).

    Attributes
    ----------
    design : WhiskerDesign
        Geometry, including the trim (the whisker's length is ``design.length``).
    Q : float
        Chamber pressure [MPa], >= 0.
    contact_ratio : float
        a in (0, 1]; the contact is at x = a·L_Q.
    contact_at : {'pressurised', 'reference'}
        'pressurised' (SPEC §5): x = a·L_Q, the contact moves out with the extension
        (a = 1 is the tip face). 'reference': x = a·L, the pusher stays where it stood
        before pressurisation (for Q > 0 and a = 1 that is a section short of the tip).
        The two differ in the pressure trend of off-tip readings; see
        benchmarks/README.md (default design, a = 0.5: ε(1 mm) at 0.2 MPa +0.1 % of the
        vented value with 'pressurised', +10 % with 'reference').
    deflection : float
        Final deflection [mm].
    c10, d1 : float
        Neo-Hookean constants [MPa], [1/MPa].
    calibration : float
        Gauge factor ξ [-].
    band_width : float
        Axial width of the contact band [mm].
    n_pressure_steps, n_deflection_steps : int
        Solved (reported) load levels in each step; the solver may substep between them.
    sizing : MeshSizing
    mesh_method : str
        'auto' | 'fresh' | 'template'.
    solve_options : SolveOptions
    formulation : {'mixed', 'displacement'}
        :class:`fem.problem.Problem` formulation: 'mixed' (P2/P0 u–p, locking-free, the
        default) or 'displacement' (C3D10-like, needs D1 > 0; for cross-checks with
        CalculiX; it locks on coarse meshes: +12 % on ε(5 mm) of the default preset mesh
        at K/μ = 1000, benchmarks/README.md).
    """

    design: WhiskerDesign
    Q: float = 0.0
    contact_ratio: float = 1.0
    contact_at: str = "pressurised"
    deflection: float = 5.0
    c10: float = 0.14
    d1: float = 0.0
    calibration: float = 3.9
    band_width: float = 1.0
    n_pressure_steps: int = 2
    n_deflection_steps: int = 5
    sizing: MeshSizing = field(default_factory=MeshSizing)
    mesh_method: str = "auto"
    solve_options: SolveOptions = field(default_factory=lambda: SolveOptions(reuse_tangent=0.3))
    formulation: str = "mixed"

    def __post_init__(self) -> None:
        checks = [
            ("Q", self.Q, self.Q >= 0, ">= 0 MPa"),
            ("contact_ratio", self.contact_ratio, 0 < self.contact_ratio <= 1, "in (0, 1]"),
            ("contact_at", self.contact_at, self.contact_at in ("pressurised", "reference"),
             "'pressurised' or 'reference'"),
            ("formulation", self.formulation, self.formulation in ("mixed", "displacement"),
             "'mixed' or 'displacement'"),
            ("deflection", self.deflection, self.deflection > 0, "> 0 mm"),
            ("band_width", self.band_width, self.band_width > 0, "> 0 mm"),
            ("n_pressure_steps", self.n_pressure_steps, self.n_pressure_steps >= 1, ">= 1"),
            ("n_deflection_steps", self.n_deflection_steps, self.n_deflection_steps >= 1, ">= 1"),
        ]
        for name, value, ok, allowed in checks:
            if not ok:
                raise ValueError(f"SceneSpec.{name}={value!r}: must be {allowed}")


@dataclass(frozen=True)
class SceneResult:
    """Outputs of one scene.

    Attributes
    ----------
    delta : ndarray, shape (k + 1,)
        Solved deflections [mm], starting at 0.
    eps_line, eps_centroid : ndarray, shape (k + 1,)
        Calibrated gauge readings (line and thesis-centroid variants) [-].
    delta_l : float
        Axial extension of the tip after pressurisation [mm].
    length_q : float
        Whisker length after pressurisation, L_Q [mm].
    radial_growth : float
        Mean radial displacement of the outer surface at mid-chamber [mm].
    reports : tuple
        Solver step reports (pressurise, then deflect).
    timings : dict
        Seconds spent in 'mesh', 'setup', 'pressurise', 'deflect', 'readout'.
    mesh : WhiskerMesh or None
    states : dict or None
        'pressurised' and 'deflected' :class:`fem.state.State` when kept.
    contact_x : float
        Mean current axial position of the contact nodes at contact onset [mm]; equals
        ``a·L_Q`` within :data:`CONTACT_TOL` on structured meshes (the ring is placed
        there, see :func:`run_scene`), within ``band_width``/2 on fresh meshes.
    """

    spec: SceneSpec
    delta: np.ndarray
    eps_line: np.ndarray
    eps_centroid: np.ndarray
    delta_l: float
    length_q: float
    radial_growth: float
    reports: tuple
    timings: dict
    mesh: WhiskerMesh | None = None
    states: dict | None = None
    contact_x: float = float("nan")

    def curve(self, delta: np.ndarray, variant: str = "line") -> np.ndarray:
        """Gauge reading at arbitrary deflections by a cubic spline through the solved points.

        The spline is 'not-a-knot' with >= 4 points, otherwise linear interpolation. Its
        error against densely solved increments is measured in benchmarks/bench_scene.py.
        """
        y = self.eps_line if variant == "line" else self.eps_centroid
        delta = np.asarray(delta, dtype=float)
        if np.any(delta < -1e-12) or np.any(delta > self.delta[-1] * (1 + 1e-9)):
            raise ValueError(
                f"curve: deflections must lie in [0, {self.delta[-1]}] mm, got "
                f"[{delta.min()}, {delta.max()}]"
            )
        if len(self.delta) >= 4:
            return CubicSpline(self.delta, y)(delta)
        return np.interp(delta, self.delta, y)


def make_problem(wm: WhiskerMesh, spec: SceneSpec, band_nodes: np.ndarray | None) -> Problem:
    """FE problem of the scene: fixed base, cavity pressure (if Q > 0), fibres, contact band."""
    d = spec.design
    dirichlet = [Dirichlet(wm.node_sets["base"], (0, 1, 2))]
    if band_nodes is not None:
        dirichlet.append(Dirichlet(band_nodes, (1,)))
    pressures = (FollowerPressure(wm.face_sets["cavity"]),) if spec.Q > 0 else ()
    area = np.pi * d.fibre_diameter**2 / 4.0
    trusses = tuple(
        EmbeddedTrusses(f.host_elements, f.local_coords, f.segments, d.fibre_E, area) for f in wm.fibres
    )
    return Problem(
        mesh=wm.mesh,
        material=NeoHookean(spec.c10, spec.d1),
        dirichlet=tuple(dirichlet),
        pressures=pressures,
        trusses=trusses,
        formulation=spec.formulation,
    )


def locate_gauge(wm: WhiskerMesh, design: WhiskerDesign, n: int = 16) -> GaugeGeometry:
    """Host elements and local coordinates of the gauge's Gauss points and its centre.

    ``n`` Gauss–Legendre points along the gauge: the axial strain is piecewise
    polynomial and discontinuous across the elements the gauge crosses, so few points
    integrate it poorly. Measured on the default design (Q = 0, δ = 5 mm, swept meshes
    of 1128–9648 elements): 4 points differ from 64 by up to 0.46 % of the reading,
    16 points by at most 0.05 %.
    """
    from geometry.locate import PointLocator

    pts, w, tangent = gauge_points(design.x_ss, design.e, design.r_outer, design.alpha, n)
    centre = np.array([[design.x_ss + 0.5 * design.e, design.r_outer(design.x_ss + 0.5 * design.e), 0.0]])
    # Points on the exact cone lie up to the P2 surface-interpolation error outside the
    # mesh; a host whose local coordinates are slightly outside (barycentric >= -0.05)
    # with an exact inverse map is the right host (the field extends smoothly).
    loc = PointLocator(wm.mesh.points, wm.mesh.cells).locate(np.vstack([pts, centre]), tol=0.05)
    if not np.all(loc.inside) or np.any(loc.residual > 1e-8 * (1.0 + design.D)):
        raise ValueError(f"gauge points not located in the mesh (inside {loc.inside}, residuals {loc.residual})")
    elems, xi = loc.host_elements, loc.local_coords
    return GaugeGeometry(elems[:n], xi[:n], w, tangent, int(elems[n]))


def contact_band(wm: WhiskerMesh, u: np.ndarray, x_contact: float, width: float, at_tip: bool) -> np.ndarray:
    """Nodes whose current axial position lies within ``width``/2 of ``x_contact``.

    For ``at_tip`` the nodes of the tip face. Raises ValueError when the band holds no
    node; :func:`run_scene` places a node ring at the contact first (:func:`place_contact`).
    """
    if at_tip:
        # the tip face only: a slab of finite width would hold every node of the slab at the
        # same y and clamp the tip's rotation (measured on fTetWild meshes: gauge/beam ratio
        # 0.82 with the face, 0.98 with a 1 mm slab, 1.09 with 2 mm)
        return np.asarray(wm.node_sets["tip"], dtype=np.int64)
    xc = wm.mesh.points[:, 0] + u[:, 0]  # (n_nodes,)
    nodes = np.nonzero(np.abs(xc - x_contact) <= 0.5 * width)[0]
    if len(nodes) == 0:
        nearest = float(xc[np.argmin(np.abs(xc - x_contact))])
        raise ValueError(f"contact band of width {width} mm at x = {x_contact:.3f} mm holds no node "
                         f"(nearest node at x = {nearest:.3f} mm)")
    return nodes


#: Largest distance [mm] between the contact ring's current axial position and a·L_Q that
#: :func:`place_contact` accepts. The reading scales about as 1/x_c² at the contact
#: (SPEC §8: ε/δ ∝ (x_c − x_g)/x_c³), so 0.02 mm moves it by ≈ 0.1 % at a = 0.5, L = 70.
CONTACT_TOL = 0.02


def station_positions(wm: WhiskerMesh, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axial node stations of a structured mesh: reference X_k and mean current x_k.

    Nodes are grouped by reference x (rounded to 1e-9 of the length); ``x_k = X_k + ū_x``
    with ū_x the mean axial displacement of the station's nodes.
    """
    X = wm.mesh.points[:, 0]
    key = np.round(X / (1e-9 * max(float(X.max()), 1.0))).astype(np.int64)
    _, inv = np.unique(key, return_inverse=True)
    cnt = np.bincount(inv).astype(float)
    Xk = np.bincount(inv, X) / cnt  # (n_stations,)
    xk = Xk + np.bincount(inv, u[:, 0]) / cnt  # (n_stations,)
    return Xk, xk


def place_contact(wm: WhiskerMesh, u: np.ndarray, x_contact: float, a: float) -> tuple[float, float]:
    """Does a node ring of this structured mesh sit at the contact, and where should one be?

    Parameters
    ----------
    wm : WhiskerMesh
        A swept or mapped-template mesh (node rings on axial stations).
    u : ndarray, shape (n_nodes, 3)
        Displacement after step 1 (zeros when Q = 0).
    x_contact : float
        Contact point a·L_Q [mm].
    a : float
        Contact ratio (the ``contact_fractions`` entry to replace).

    Returns
    -------
    error : float
        Distance [mm] from ``x_contact`` to the nearest station's current position.
    fraction : float
        The reference fraction f = X/L whose station lands on the contact,
        X + ū_x(X) = x_contact, with ū_x interpolated linearly between stations (the
        body beyond the chamber only translates, so this is exact there up to the
        meshes' difference in Δl).
    """
    Xk, xk = station_positions(wm, u)
    error = float(np.min(np.abs(xk - x_contact)))
    X_new = float(np.interp(x_contact, xk, Xk))  # x(X) is increasing: invert by interpolation
    L = wm.design.length
    f = X_new / L
    if not 0 < f < 1:
        raise ValueError(f"contact ratio a = {a}: the contact x = {x_contact:.3f} mm maps to the reference "
                         f"fraction {f:.4f}, outside (0, 1)")
    return error, f


def _placed_sizing(sizing: MeshSizing, a: float, f: float) -> MeshSizing:
    """``sizing`` with the contact fraction nearest to ``a`` replaced by ``f``."""
    fr = list(sizing.contact_fractions)
    if fr:
        fr[int(np.argmin(np.abs(np.asarray(fr) - a)))] = f
    else:
        fr = [f]
    return replace(sizing, contact_fractions=tuple(fr))


def mid_chamber_radial_growth(wm: WhiskerMesh, u: np.ndarray) -> float:
    """Mean radial displacement of the outer-surface nodes nearest to mid-chamber.

    Nodes within ±0.5 mm of x = (c + l)/2, widened to the nearest node ring on coarse
    meshes (at most a quarter of the chamber length either side).
    """
    d = wm.design
    X = wm.mesh.points
    outer = wm.node_sets["outer"]
    xm = 0.5 * (d.c + d.l)
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
    (design, trim, Q, a, fidelity) is solved once per runner.

    Parameters
    ----------
    mesh_cache_dir : path or None
        Passed to :func:`geometry.mesh.build_mesh` (on-disk mesh cache).
    memo_size : int
        Maximum number of memoised results (oldest dropped first).
    """

    def __init__(self, mesh_cache_dir=None, memo_size: int = 256) -> None:
        self.mesh_cache_dir = mesh_cache_dir
        self.memo_size = memo_size
        self._memo: dict[SceneSpec, SceneResult] = {}
        self._meshes: dict[tuple, WhiskerMesh] = {}
        self.memo_hits = 0

    def mesh_for(self, spec: SceneSpec) -> WhiskerMesh:
        """The (cached) mesh of a scene's design, sizing and method."""
        return self._mesh(spec.design, spec.sizing, spec.mesh_method)

    def _mesh(self, design: WhiskerDesign, sizing: MeshSizing, method: str) -> WhiskerMesh:
        key = (design, sizing, method)
        wm = self._meshes.get(key)
        if wm is None:
            wm = build_mesh(design, sizing, method=method, cache_dir=self.mesh_cache_dir)
            if len(self._meshes) >= 8:
                self._meshes.pop(next(iter(self._meshes)))
            self._meshes[key] = wm
        return wm

    def run(self, spec: SceneSpec, keep_states: bool = False) -> SceneResult:
        """Solve one scene (or return the memoised result)."""
        hit = self._memo.get(spec)
        if hit is not None and (hit.states is not None or not keep_states):
            self.memo_hits += 1
            return hit
        res = run_scene(spec, self.mesh_for(spec), keep_states=keep_states, mesh_for=self._mesh)
        if len(self._memo) >= self.memo_size:
            self._memo.pop(next(iter(self._memo)))
        self._memo[spec] = res
        return res


def _pressurise(spec: SceneSpec, wm: WhiskerMesh):
    """Step 1 on ``wm``: (problem, zero base displacements, state, reports); the state is
    the reference state when Q = 0."""
    prob1 = make_problem(wm, spec, None)
    zeros_base = np.zeros((len(wm.node_sets["base"]), 3))
    state = State.zero(prob1)
    if spec.Q <= 0:
        return prob1, zeros_base, state, []
    fr = tuple(np.linspace(0, 1, spec.n_pressure_steps + 1)[1:])
    states, rep = solve_path(
        prob1,
        state,
        LoadState((0.0,), (zeros_base,)),
        LoadState((spec.Q,), (zeros_base,)),
        fractions=fr,
        # full Newton: pressurising a fibre-wound chamber is strongly nonlinear, where
        # a reused tangent converges slowly (reuse ratio 0.05-0.2: 48-54 iterations
        # instead of 21), and increments of at most a third of Q with the secant
        # predictor: 19 iterations to 0.2 MPa, against 21 with quarters, 22 with
        # halves and 20 in one step (default design and mesh, measured 2026-11-23)
        options=replace(spec.solve_options, reuse_tangent=0.0,
                        initial_step=min(spec.solve_options.initial_step, 0.34),
                        max_step=min(spec.solve_options.max_step, 0.34)),
    )
    return prob1, zeros_base, states[-1], list(rep)


#: Meshes :func:`run_scene` builds at most to place the contact ring (a < 1).
MAX_CONTACT_REMESH = 2


def run_scene(spec: SceneSpec, wm: WhiskerMesh | None = None, keep_states: bool = False,
              mesh_for=None) -> SceneResult:
    """Pressurise-then-deflect one whisker and read its gauge.

    Off-tip contact (a < 1) on a structured (swept or mapped-template) mesh needs a node
    ring where the pressurised contact is: a ring at f·L moves to about f·L + Δl, not to
    a·L_Q = a(L + Δl). After step 1 the scene checks that a station lies within
    :data:`CONTACT_TOL` of a·L_Q (:func:`place_contact`); if not, it meshes again with
    the ring at the reference fraction that lands there (the preset's contact fraction
    nearest to a replaced; swept mesh) and repeats step 1, at most
    :data:`MAX_CONTACT_REMESH` times. The time goes to ``timings['contact_placement']``. Fresh (fTetWild) meshes have no rings: their band
    is the slab of nodes within ``band_width``/2 of a·L_Q.

    Parameters
    ----------
    spec : SceneSpec
    wm : WhiskerMesh, optional
        A mesh of ``spec.design``; built when not given.
    keep_states : bool
        Keep the pressurised and final states and every solved deflection increment
        (keys ``pressurised``, ``deflected`` and ``delta_<δ>`` with δ in mm to two
        decimals, e.g. ``delta_1.00``; the last is the ``deflected`` state), for VTU output.
    mesh_for : callable, optional
        ``mesh_for(design, sizing, method) -> WhiskerMesh`` for the contact placement's
        meshes (e.g. a cache); default :func:`geometry.mesh.build_mesh`.

    Raises
    ------
    geometry.design.InvalidDesignError
        Impossible geometry.
    fem.stepping.SolveFailed
        The nonlinear solve did not converge (carries the report).
    """
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    design = spec.design
    design.validate()
    if mesh_for is None:
        def mesh_for(d, sizing, method):
            return build_mesh(d, sizing, method=method)
    if wm is None:
        wm = mesh_for(design, spec.sizing, spec.mesh_method)
    timings["mesh"] = time.perf_counter() - t0

    # ---- step 1: pressurise (skipped when Q = 0), with the contact ring placed for a < 1
    t = time.perf_counter()
    prob1, zeros_base, state, reports = _pressurise(spec, wm)
    reference = spec.contact_at == "reference" and spec.Q > 0
    at_tip = spec.contact_ratio >= 1.0 and not reference
    structured = not wm.report.method.startswith("fresh")
    sizing = spec.sizing

    def contact_point(u: np.ndarray) -> float:
        if reference:
            return spec.contact_ratio * design.length
        return spec.contact_ratio * (design.length + float(u[wm.node_sets["tip"], 0].mean()))

    for attempt in range(MAX_CONTACT_REMESH + 1):
        x_contact = contact_point(state.u)
        if at_tip or not structured:
            break
        error, f = place_contact(wm, state.u, x_contact, spec.contact_ratio)
        # a mapped template is replaced even when a ring fits, so that every pressure of an
        # off-tip study runs on the same swept family (template and swept meshes of the
        # default preset differ by ~1 % in the a = 0.5 reading, as large as the effect of Q)
        if error <= CONTACT_TOL and not wm.report.method.startswith("template"):
            break
        if attempt == MAX_CONTACT_REMESH:
            logger.warning("contact ring %.3f mm from a·L_Q = %.3f mm after %d re-meshes (tolerance %g mm)",
                           error, x_contact, attempt, CONTACT_TOL)
            break
        tp = time.perf_counter()
        sizing = _placed_sizing(sizing, spec.contact_ratio, f)
        method = "swept"  # the structured family (a template cannot carry a new ring)
        logger.info("contact a = %g: nearest node ring %.3f mm from a·L_Q = %.3f mm; meshing with the ring "
                    "at f = %.6f", spec.contact_ratio, error, x_contact, f)
        wm = mesh_for(design, sizing, method)
        prob1, zeros_base, state, reports = _pressurise(spec, wm)
        timings["contact_placement"] = timings.get("contact_placement", 0.0) + time.perf_counter() - tp
    u1 = state.u
    tip = wm.node_sets["tip"]
    delta_l = float(u1[tip, 0].mean())
    length_q = design.length + delta_l
    radial = mid_chamber_radial_growth(wm, u1) if spec.Q > 0 else 0.0
    timings["pressurise"] = time.perf_counter() - t - timings.get("contact_placement", 0.0)

    t = time.perf_counter()
    gauge = locate_gauge(wm, design)
    reader = GaugeReader(wm.mesh, gauge, spec.calibration)
    timings["setup"] = time.perf_counter() - t

    # ---- step 2: deflect
    t = time.perf_counter()
    band = contact_band(wm, u1, contact_point(u1), spec.band_width, at_tip)
    # same mesh, faces and fibres: replace() shares the topology cache (sparsity
    # pattern, PARDISO analysis) with the pressurise problem
    prob2 = replace(prob1, dirichlet=make_problem(wm, spec, band).dirichlet)
    uy0 = u1[band, 1:2]  # (k, 1)
    pq = (spec.Q,) if spec.Q > 0 else ()
    load0 = LoadState(pq, (zeros_base, uy0))
    load1 = LoadState(pq, (zeros_base, uy0 - spec.deflection))
    reader.zero(u1)
    fractions = tuple(np.linspace(0, 1, spec.n_deflection_steps + 1)[1:])
    readings = [(0.0, 0.0)]
    t_read = [0.0]

    def _read(fraction: float, st: State) -> None:
        tr = time.perf_counter()
        readings.append(reader.read(st.u))
        t_read[0] += time.perf_counter() - tr

    states2, rep2 = solve_path(prob2, state, load0, load1, fractions=fractions, options=spec.solve_options, callback=_read)
    reports.extend(rep2)
    timings["deflect"] = time.perf_counter() - t - t_read[0]
    timings["readout"] = t_read[0]
    arr = np.array(readings)
    delta = np.concatenate([[0.0], np.asarray(fractions) * spec.deflection])
    kept = ({"pressurised": state, "deflected": states2[-1],
             **{f"delta_{f * spec.deflection:.2f}": st for f, st in zip(fractions, states2)}}
            if keep_states else None)
    logger.debug("scene %s: %s", design, timings)
    return SceneResult(
        spec=spec,
        delta=delta,
        eps_line=arr[:, 0],
        eps_centroid=arr[:, 1],
        delta_l=delta_l,
        length_q=length_q,
        radial_growth=radial,
        reports=tuple(reports),
        timings=timings,
        mesh=wm if keep_states else None,
        states=kept,
        contact_x=float(np.mean(wm.mesh.points[band, 0] + u1[band, 0])),
    )


def with_design(spec: SceneSpec, **changes) -> SceneSpec:
    """A copy of ``spec`` whose design has ``changes`` applied (e.g. ``trim=5``)."""
    return replace(spec, design=replace(spec.design, **changes))
