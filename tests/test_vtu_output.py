"""The VTU, fibre and .pvd files of solved scenes (whisker_opt.output.scenes, fem.io).

Two real scenes of the default design on the coarse preset's mesh: ``intact`` at
Q = 0.1 MPa deflected by 1 mm in two increments, and ``vented`` at Q = 0, whose
``pressurised`` state is the unloaded reference state. Every file is opened with pyvista
(VTK's own reader, as ParaView reads it); text field data are UTF-8 bytes (``UInt8``), which meshio
reads too (tests/test_result_files_open.py opens the files of each command with both).
"""

from __future__ import annotations

import math
import os
from types import SimpleNamespace

import numpy as np
import pytest

from fem import post
from fem.io import decode_text, field_values, read_pvd, write_pvd, write_vtu
from fem.material import NeoHookean
from fem.meshgen import box_mesh
from fem.query import displacement_at
from geometry.design import WhiskerDesign
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.gauge import locate_gauge
from whisker_opt.experiment.spec import SceneSpec
from whisker_opt.output import scenes as out_scenes

pv = pytest.importorskip("pyvista")

COARSE = PRESETS["coarse"]
POINT_SHAPES = {"displacement": 3, "displacement_magnitude": None, "log_strain": 6, "log_strain_axial": None,
                "cauchy_stress": 6, "von_mises": None, "on_cavity": None, "on_base": None, "on_outer": None,
                "in_contact_band": None, "in_gauge": None}
CELL_ARRAYS = ("mixed_pressure", "region", "gauge_element")
TAGS = ("on_cavity", "on_base", "on_outer", "in_contact_band", "in_gauge")


def _spec(Q: float, steps: int) -> SceneSpec:
    return SceneSpec(WhiskerDesign(), Q=Q, deflection=1.0, n_deflection_steps=steps,
                     n_pressure_steps=COARSE.n_pressure_steps, sizing=COARSE.sizing)


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    """Both scenes solved and written under the umask 022."""
    out = tmp_path_factory.mktemp("scenes")
    specs = {"intact": _spec(0.1, 2), "vented": _spec(0.0, 1)}
    old = os.umask(0o022)
    try:
        results, entries = out_scenes.solve_scenes(out, specs)
    finally:
        os.umask(old)
    return SimpleNamespace(out=out, specs=specs, results=results, entries=entries)


def _files(solved, scene):
    return sorted(solved.out.glob(f"{scene}_*.vtu"))


# ------------------------------------------------------------------ files and their order
def test_files_of_a_scene_and_the_pvd_order(solved):
    names = sorted(p.name for p in solved.out.iterdir())
    assert names == sorted([
        "intact.pvd", "intact_fibres.pvd", "intact_pressurised.vtu", "intact_delta_0.50.vtu", "intact_deflected.vtu",
        "intact_pressurised_fibres.vtu", "intact_delta_0.50_fibres.vtu", "intact_deflected_fibres.vtu",
        "vented.pvd", "vented_fibres.pvd", "vented_pressurised.vtu", "vented_deflected.vtu",
        "vented_pressurised_fibres.vtu", "vented_deflected_fibres.vtu", "scenes.pvd",
    ])
    assert read_pvd(solved.out / "intact.pvd") == [
        (0.0, "intact_pressurised.vtu", 0), (0.5, "intact_delta_0.50.vtu", 0), (1.0, "intact_deflected.vtu", 0)]
    assert [f for _, f, _ in read_pvd(solved.out / "intact_fibres.pvd")] == [
        "intact_pressurised_fibres.vtu", "intact_delta_0.50_fibres.vtu", "intact_deflected_fibres.vtu"]
    reader = pv.get_reader(str(solved.out / "intact.pvd"))  # ParaView's time steps
    assert reader.time_values == [0.0, 0.5, 1.0]
    reader.set_active_time_value(0.5)
    block = reader.read()
    assert block[0].field_data["delta_mm"][0] == 0.5


def test_file_modes_are_ordinary(solved, tmp_path):
    modes = {p.name: p.stat().st_mode & 0o777 for p in solved.out.iterdir()}
    assert set(modes.values()) == {0o644}, modes
    old = os.umask(0o077)
    try:
        m = box_mesh(1.0, 1.0, 1.0, 1, 1, 1)
        a = write_vtu(tmp_path / "a.vtu", m, field_data={"Q_MPa": 0.1})
        b = write_pvd(tmp_path / "a.pvd", [(0.0, a)])
    finally:
        os.umask(old)
    assert a.stat().st_mode & 0o777 == 0o600 and b.stat().st_mode & 0o777 == 0o600
    assert read_pvd(b) == [(0.0, "a.vtu", 0)]  # made relative to the .pvd's folder
    assert not list(tmp_path.glob(".*"))  # no temporary left behind


# ------------------------------------------------------------------ arrays
@pytest.mark.parametrize("scene", ["intact", "vented"])
def test_every_array_with_its_shape(solved, scene):
    wm = solved.results[scene].mesh
    n, n_el = wm.mesh.n_nodes, wm.mesh.n_elements
    for path in [p for p in _files(solved, scene) if not p.stem.endswith("_fibres")]:
        g = pv.read(path)
        assert g.n_points == n and g.n_cells == n_el
        for name, comps in POINT_SHAPES.items():
            shape = (n,) if comps is None else (n, comps)
            assert np.asarray(g.point_data[name]).shape == shape, name
        for name in CELL_ARRAYS:
            assert np.asarray(g.cell_data[name]).shape == (n_el,), name
        assert "pressure" not in g.cell_data  # renamed: mixed_pressure
        vm = g.point_data["von_mises"]
        assert np.all(np.isfinite(vm)) and vm.min() >= 0
        for name in POINT_SHAPES:
            assert np.all(np.isfinite(g.point_data[name])), name
        # ParaView's component names of the tensors
        for name in ("log_strain", "cauchy_stress"):
            arr = g.GetPointData().GetArray(name)
            assert [arr.GetComponentName(i) for i in range(6)] == ["XX", "YY", "ZZ", "XY", "YZ", "XZ"]


def test_arrays_agree_with_the_state(solved):
    """Exact relations between the written arrays and the solved state."""
    res, spec = solved.results["intact"], solved.specs["intact"]
    mesh = res.mesh.mesh
    for state, st in (("pressurised", res.states["pressurised"]), ("deflected", res.states["deflected"])):
        g = pv.read(solved.out / f"intact_{state}.vtu")
        u = np.asarray(g.point_data["displacement"])
        np.testing.assert_array_equal(u, st.u)
        np.testing.assert_allclose(g.point_data["displacement_magnitude"], np.linalg.norm(u, axis=1), rtol=1e-15)
        le, sig = np.asarray(g.point_data["log_strain"]), np.asarray(g.point_data["cauchy_stress"])
        np.testing.assert_array_equal(g.point_data["log_strain_axial"], le[:, 0])
        np.testing.assert_allclose(le[:, 0], post.axial_log_strain(mesh.points, mesh.cells, st.u), atol=1e-15)
        np.testing.assert_array_equal(g.cell_data["mixed_pressure"], st.p)
        # the mean stress is the nodal mean of the element pressures: tr σ / 3 = p̄ (> 0 in tension)
        np.testing.assert_allclose(sig[:, :3].sum(axis=1) / 3, post.element_to_nodes(mesh.cells, st.p, mesh.n_nodes),
                                   atol=1e-12)
        # von Mises from the 6 components (XY, YZ, XZ counted twice in s:s) and from F alone
        s = sig[:, :3] - sig[:, :3].mean(axis=1, keepdims=True)
        vm = np.sqrt(1.5 * ((s**2).sum(axis=1) + 2 * (sig[:, 3:] ** 2).sum(axis=1)))
        np.testing.assert_allclose(g.point_data["von_mises"], vm, rtol=1e-10, atol=1e-14)
        F, _ = post.nodal_deformation_gradient(mesh.points, mesh.cells, st.u)
        np.testing.assert_allclose(g.point_data["von_mises"], NeoHookean(spec.c10).von_mises(F), rtol=1e-10,
                                   atol=1e-14)
    assert np.abs(res.states["pressurised"].u).max() > 0.1  # a loaded state: the relations above are not 0 = 0


def test_unloaded_reference_state_is_free_of_strain_and_stress(solved):
    """Q = 0: the 'pressurised' state is the reference state, u = 0, p = 0."""
    g = pv.read(solved.out / "vented_pressurised.vtu")
    for name in ("displacement", "displacement_magnitude", "log_strain", "log_strain_axial", "cauchy_stress",
                 "von_mises"):
        assert np.abs(g.point_data[name]).max() == 0.0, name
    np.testing.assert_array_equal(g.point_data["J"], 1.0)
    np.testing.assert_array_equal(g.point_data["principal_stretches"], 1.0)
    assert np.abs(g.cell_data["mixed_pressure"]).max() == 0.0
    defl = pv.read(solved.out / "vented_deflected.vtu")
    assert defl.point_data["von_mises"].max() > 1e-3  # deflecting it does stress it


def test_region_and_point_tags(solved):
    res, spec = solved.results["intact"], solved.specs["intact"]
    wm, d = res.mesh, spec.design
    g = pv.read(solved.out / "intact_deflected.vtu")
    region = np.asarray(g.cell_data["region"])
    assert set(np.unique(region)) == {1, 2, 3}  # every cell tagged, every region present
    x = out_scenes.element_centroids(wm.mesh)[:, 0]
    np.testing.assert_array_equal(region == 1, x < d.c)
    np.testing.assert_array_equal(region == 2, (x >= d.c) & (x < d.l))
    np.testing.assert_array_equal(region == 3, x >= d.l)
    for tag in TAGS:
        assert set(np.unique(g.point_data[tag])) == {0, 1}, tag
    for tag, key in out_scenes.NODE_SET_TAGS.items():
        np.testing.assert_array_equal(np.nonzero(g.point_data[tag])[0], np.unique(wm.node_sets[key]))
    np.testing.assert_array_equal(np.nonzero(g.point_data["in_contact_band"])[0], np.unique(wm.node_sets["tip"]))
    gauge = locate_gauge(wm, d)
    ge = np.asarray(g.cell_data["gauge_element"])
    assert set(np.nonzero(ge & out_scenes.GAUGE_LINE_HOST)[0]) == set(gauge.host_elements.tolist())
    assert np.nonzero(ge & out_scenes.GAUGE_CENTROID_ELEMENT)[0].tolist() == [gauge.centroid_element]
    np.testing.assert_array_equal(np.nonzero(g.point_data["in_gauge"])[0], np.unique(wm.mesh.cells[ge > 0]))
    # the gauge sits on the outer surface near x_ss..x_ss + e on the +y side
    pts = g.points[np.asarray(g.point_data["in_gauge"], dtype=bool)]
    assert pts[:, 1].max() > 0.8 * d.r_outer(d.x_ss) and pts[:, 0].min() <= d.x_ss + d.e and pts[:, 0].max() >= d.x_ss


def test_axial_strain_under_the_gauge_follows_the_reading(solved):
    """The gauge reads ξ·ln(λ(δ)/λ(0)) along its line; the nodal LE_xx change at the outer gauge
    nodes on +y between onset and δ is the same quantity, nodally averaged: close, not equal."""
    res, spec = solved.results["intact"], solved.specs["intact"]
    onset, end = (pv.read(solved.out / f"intact_{s}.vtu") for s in ("pressurised", "deflected"))
    sel = (np.asarray(end.point_data["in_gauge"], bool) & np.asarray(end.point_data["on_outer"], bool)
           & (end.points[:, 1] > 0))
    change = float(np.mean(end.point_data["log_strain_axial"][sel] - onset.point_data["log_strain_axial"][sel]))
    reading = res.eps["line"][-1] / spec.calibration
    assert reading > 0 and change == pytest.approx(reading, rel=0.25)


# ------------------------------------------------------------------ metadata
def test_field_data(solved):
    for scene in ("intact", "vented"):
        spec = solved.specs[scene]
        for delta, file, _ in read_pvd(solved.out / f"{scene}.pvd"):
            for fd in (pv.read(solved.out / file).field_data,):
                # text is UTF-8 bytes (no VTK string array, which meshio cannot read); numbers are not bytes
                assert fd["scene"].dtype == np.uint8 and decode_text(fd["scene"]) == [scene]
                assert {k for k, v in fd.items() if v.dtype == np.uint8} == {
                    "scene", "state", "contact_at", "formulation", "wall_law", "fidelity_preset", "units"}
                assert decode_text(fd["wall_law"]) == ["embedded"] and fd["wall_slope_per_MPa"][0] == 0.0
                assert fd["Q_MPa"][0] == spec.Q and fd["trim_mm"][0] == 0.0
                assert fd["delta_mm"][0] == pytest.approx(delta) and fd["TimeValue"][0] == pytest.approx(delta)
                assert fd["C10_MPa"][0] == spec.c10 and fd["D1_per_MPa"][0] == spec.d1
                assert fd["calibration_xi"][0] == spec.calibration and fd["contact_ratio"][0] == spec.contact_ratio
                for k, v in spec.design.as_dict().items():
                    assert fd[f"design_{k}"][0] == v, k
                assert decode_text(fd["scene"]) == [scene]
                assert decode_text(fd["state"]) == [file[len(scene) + 1: -len(".vtu")]]
                assert decode_text(fd["fidelity_preset"]) == ["coarse"]
                assert decode_text(fd["formulation"]) == ["mixed"]
    m = pv.read(solved.out / "intact_deflected.vtu")
    units = dict(u.split("=", 1) for u in decode_text(m.field_data["units"]))
    assert {*m.point_data, *m.cell_data} <= set(units)
    assert {k for k, v in field_values(m.field_data).items() if not isinstance(v, list)} <= set(units)
    assert units["contact_force_N"] == "N" and units["J"] == "-" and units["principal_stretches"] == "-"
    assert units["displacement"] == "mm" and units["cauchy_stress"] == "MPa" and units["von_mises"] == "MPa"
    assert units["mixed_pressure"] == "MPa" and units["log_strain"] == "-" and units["Q_MPa"] == "MPa"
    assert units["design_alpha"] == "deg" and "unknown" not in units.values()


# ------------------------------------------------------------------ fibres
def test_fibre_files(solved):
    res = solved.results["intact"]
    wm, st = res.mesh, res.states["deflected"]
    g = pv.read(solved.out / "intact_deflected_fibres.vtu")
    X = np.vstack([f.points_ref for f in wm.fibres])
    n_seg = sum(len(f.segments) for f in wm.fibres)
    assert set(g.celltypes.tolist()) == {pv.CellType.LINE} and g.n_cells == n_seg
    np.testing.assert_allclose(g.points, X)
    disp = np.vstack([displacement_at(wm.mesh, st.u, f.host_elements, f.local_coords) for f in wm.fibres])
    np.testing.assert_allclose(g.point_data["displacement"], disp, atol=1e-12)
    assert g.point_data["displacement"].shape == (len(X), 3)
    assert sorted(np.unique(g.point_data["fibre"]).tolist()) == list(range(len(wm.fibres)))
    # the fibres keep the chamber from growing: little strain along them
    assert np.abs(g.cell_data["fibre_log_strain"]).max() < 0.01
    assert g.field_data["Q_MPa"][0] == 0.1 and decode_text(g.field_data["state"]) == ["deflected"]


def test_the_viewer_finds_the_states_not_the_fibres(solved):
    from whisker_opt.viewer import rundir

    c = rundir.discover(solved.out)
    assert c.scene_names(".") == ["intact", "vented"]
    assert [f.state for f in c.states(".", "intact")] == ["pressurised", "delta_0.50", "deflected"]
    assert all(not f.path.stem.endswith("_fibres") for f in c.files)
    assert rundir.is_fibre_file(solved.out / "intact_deflected_fibres.vtu")
    assert not rundir.is_fibre_file(solved.out / "intact_deflected.vtu")


# ------------------------------------------------------------------ state order without a solve
def test_ordered_states_by_deflection():
    st = {k: SimpleNamespace(name=k) for k in ("pressurised", "d1", "d2", "d3")}
    res = SimpleNamespace(states={"pressurised": st["pressurised"], "deflected": st["d3"], "delta_2.00": st["d2"],
                                  "delta_0.67": st["d1"], "delta_3.00": st["d3"]},
                          delta=np.array([0.0, 2 / 3, 2.0, 3.0]))
    got = [(n, d, s.name) for n, d, s in out_scenes.ordered_states(res)]
    assert got == [("pressurised", 0.0, "pressurised"), ("delta_0.67", 2 / 3, "d1"), ("delta_2.00", 2.0, "d2"),
                   ("deflected", 3.0, "d3")]
    with pytest.raises(ValueError, match="keep_states"):
        out_scenes.ordered_states(SimpleNamespace(states=None))
    with pytest.raises(ValueError, match="'odd'"):
        out_scenes.ordered_states(SimpleNamespace(states={"odd": 1}))
    assert math.isclose(out_scenes.ordered_states(SimpleNamespace(states={"delta_1.50": 1, "deflected": 2}))[-1][1], 1.5)


# ------------------------------------------------------------------ forces, J, stretches, one collection
def test_forces_of_each_state_in_the_field_data(solved):
    """Each state's VTU holds the contact force and the base reaction of its δ (the scene's own arrays)."""
    res = solved.results["intact"]
    for delta, file, _ in read_pvd(solved.out / "intact.pvd"):
        fd = pv.read(solved.out / file).field_data
        i = int(np.argmin(np.abs(res.delta - delta)))
        assert fd["contact_force_N"][0] == res.contact_force[i]
        np.testing.assert_array_equal(fd["base_reaction_N"], res.base_reaction[i])
    assert res.contact_force[-1] > 0 and solved.entries["intact"]["contact_force_N"] == res.contact_force.tolist()
    assert solved.entries["intact"]["contact_stiffness_N_per_mm"] == res.contact_force[1] / res.delta[1]


def test_jacobian_and_principal_stretches(solved):
    """J = det F and λ₁ ≥ λ₂ ≥ λ₃ with λ² the eigenvalues of F Fᵀ of the nodal F; λ₁λ₂λ₃ = J; the
    incompressible rubber keeps J near 1 at most nodes (the mixed solve holds the element mean of J, so the
    nodal averages of F scatter about 1: measured median |J − 1| 0.007, largest 0.33 at a few nodes)."""
    res = solved.results["intact"]
    mesh, st = res.mesh.mesh, res.states["deflected"]
    g = pv.read(solved.out / "intact_deflected.vtu")
    F, _ = post.nodal_deformation_gradient(mesh.points, mesh.cells, st.u)
    J, lam = np.asarray(g.point_data["J"]), np.asarray(g.point_data["principal_stretches"])
    np.testing.assert_allclose(J, np.linalg.det(F), rtol=1e-12)
    assert np.all(np.diff(lam, axis=1) <= 0)
    np.testing.assert_allclose(lam.prod(axis=1), J, rtol=1e-10)
    np.testing.assert_allclose(np.sort(lam**2, axis=1), np.linalg.eigvalsh(F @ np.swapaxes(F, 1, 2)), rtol=1e-10)
    print(f"|J - 1|: median {np.median(np.abs(J - 1)):.3g}, largest {np.abs(J - 1).max():.3g}")
    assert np.median(np.abs(J - 1)) < 0.01 and lam[:, 0].max() > 1.01  # loaded


def test_fibre_force_is_the_truss_force(solved):
    """N = E_f A E ℓ/L with E = (ℓ² − L²)/(2L²) (fem.truss), from the written log strain s = ln(ℓ/L);
    positive in tension. The stored energy of the written forces, Σ ½ E_f A L E² with E = N L/(E_f A ℓ),
    equals the solver's own truss energy on the state (fem.truss.TrussKernel.energy) to round-off."""
    from fem.assembly import topology_for
    from whisker_opt.experiment.scene import make_problem

    res, d = solved.results["intact"], solved.specs["intact"].design
    g = pv.read(solved.out / "intact_deflected_fibres.vtu")
    s = np.asarray(g.cell_data["fibre_log_strain"])
    N = np.asarray(g.cell_data["fibre_force"])
    EA = d.fibre_E * d.fibre_area
    np.testing.assert_allclose(N, EA * 0.5 * (np.exp(2 * s) - 1) * np.exp(s), rtol=1e-9)
    assert N.max() > 0  # pressurised: the winding is in tension
    L0 = np.concatenate([np.linalg.norm(f.points_ref[f.segments[:, 1]] - f.points_ref[f.segments[:, 0]], axis=1)
                         for f in res.mesh.fibres])  # (m,) in the order of the written segments
    green = N / (EA * np.exp(s))  # E = N L/(E_f A ℓ), ℓ/L = e^s
    psi_written = float(np.sum(0.5 * EA * L0 * green**2))
    prob = make_problem(res.mesh, res.spec, None)
    x = prob.mesh.points + res.states["deflected"].u
    psi_solver = sum(tk.energy(x) for tk in topology_for(prob).truss_kernels)
    print(f"fibre energy: written forces {psi_written:.9g} N mm, solver {psi_solver:.9g} N mm")
    assert psi_written == pytest.approx(psi_solver, rel=1e-9)


def test_one_collection_holds_every_scene(solved):
    """scenes.pvd: each scene's solid and fibres a named block, time step δ; ParaView's reader steps through δ."""
    import xml.etree.ElementTree as ET

    entries = read_pvd(solved.out / out_scenes.RESULT_PVD)
    names = {int(e.get("part")): e.get("name") for e in ET.parse(solved.out / out_scenes.RESULT_PVD).iter("DataSet")}
    assert names == {0: "intact", 1: "intact_fibres", 2: "vented", 3: "vented_fibres"}
    assert sorted(f for _, f, _ in entries) == sorted(p.name for p in solved.out.glob("*.vtu"))
    reader = pv.get_reader(str(solved.out / out_scenes.RESULT_PVD))
    assert reader.time_values == [0.0, 0.5, 1.0]
    reader.set_active_time_value(1.0)
    blocks = reader.read()
    assert blocks.n_blocks == 4
    assert sorted(decode_text(b.field_data["scene"])[0] for b in blocks) == ["intact", "intact", "vented", "vented"]
