"""Off-screen tests of the pyvista result viewer (whisker_opt/viewer/).

Synthetic scenes are small TET10 boxes (fem.meshgen.box_mesh) written with fem.io.write_vtu,
with displacement fields whose deformed bounds and log strains are known in closed form.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from fem import post  # noqa: E402
from fem.io import write_vtu  # noqa: E402
from fem.material import NeoHookean  # noqa: E402
from fem.mesh import TetMesh, volumes  # noqa: E402
from fem.meshgen import box_mesh, map_mesh  # noqa: E402
from whisker_opt.viewer import command, evaluations, fields, guard, overlays, rundir, sceneinfo  # noqa: E402
from whisker_opt.viewer import colours  # noqa: E402
from whisker_opt.viewer import labels as vlabels  # noqa: E402
from whisker_opt.viewer import render as rendering  # noqa: E402
from whisker_opt.viewer import state as vstate  # noqa: E402
from whisker_opt.viewer.rubber import RunRubber  # noqa: E402

WS = (320, 200)  # small images keep the tests fast


def _bend(points: np.ndarray, a: float) -> np.ndarray:
    """u = (0, -a x², 0): the tip (x = 10) moves by -100 a in y."""
    u = np.zeros_like(points)
    u[:, 1] = -a * points[:, 0] ** 2
    return u


@pytest.fixture(scope="module")
def box() -> TetMesh:
    return box_mesh(10.0, 2.0, 2.0, 5, 1, 1)


@pytest.fixture()
def box_vtu(tmp_path, box):
    path = tmp_path / "scene_deflected.vtu"
    write_vtu(path, box, point_data={"displacement": _bend(box.points, 0.01)})
    return path


def _image(path):
    import matplotlib.image as mpimg

    return np.asarray(mpimg.imread(path), dtype=float)


# ------------------------------------------------------------------ fields and geometry
def test_warp_moves_bounds_by_the_displacement(box_vtu):
    for scale in (1.0, 2.5):
        sv = vstate.prepare_state(box_vtu, scale=scale)
        assert sv.displacement == "displacement"
        b = np.array(sv.outer.bounds)
        # x unchanged, y from -100·a·scale (tip, y=0) to 2 (base, y=2), z unchanged
        np.testing.assert_allclose(b, [0.0, 10.0, -1.0 * scale, 2.0, 0.0, 2.0], atol=1e-9)
        np.testing.assert_allclose(np.array(sv.warped.bounds), b, atol=1e-9)
    ref = vstate.prepare_state(box_vtu, scale=0.0)
    np.testing.assert_allclose(ref.outer.bounds, [0, 10, 0, 2, 0, 2], atol=1e-12)


def test_axial_log_strain_closed_forms(box):
    X = box.points
    k = 0.2
    u = np.zeros_like(X)
    u[:, 0] = k * X[:, 0]  # uniform stretch: LE_xx = ln(1 + k)
    np.testing.assert_allclose(post.axial_log_strain(X, box.cells, u), math.log(1 + k), atol=1e-12)
    th = math.radians(30.0)  # rigid rotation about z: no strain (a linear strain would give cos θ - 1)
    R = np.array([[math.cos(th), -math.sin(th), 0], [math.sin(th), math.cos(th), 0], [0, 0, 1]])
    np.testing.assert_allclose(post.axial_log_strain(X, box.cells, X @ R.T - X), 0.0, atol=1e-12)
    # stretch λ along x then rotation: Eulerian ln V has xx = ln λ cos² θ
    lam = 1.3
    Fu = R @ np.diag([lam, 1.0, 1.0])
    np.testing.assert_allclose(post.axial_log_strain(X, box.cells, X @ Fu.T - X), math.log(lam) * math.cos(th) ** 2,
                               atol=1e-12)


def test_quadratic_cell_ordering_matches_vtk(tmp_path):
    """VTK's own volumes of the written TET10 cells are positive and equal ours (curved mesh)."""
    m = map_mesh(box_mesh(1.0, 1.0, 1.0, 2, 2, 2, distort=0.2, seed=3),
                 lambda p: np.c_[p[:, 0] * (1 + 0.3 * p[:, 1] ** 2), p[:, 1], p[:, 2] + 0.2 * np.sin(3 * p[:, 0])])
    path = write_vtu(tmp_path / "m.vtu", m)
    grid = fields.load_grid(path)
    np.testing.assert_array_equal(np.unique(grid.celltypes), [pv.CellType.QUADRATIC_TETRA])
    vol_vtk = fields.cell_volumes(grid)
    vol_fem = volumes(m.points, m.cells)
    assert vol_vtk.min() > 0
    np.testing.assert_allclose(vol_vtk, vol_fem, rtol=0.05)  # VTK integrates a linear sub-tet split
    assert abs(vol_vtk.sum() / vol_fem.sum() - 1) < 0.01
    # the test can fail: Gmsh's order (last two edge nodes swapped) is detected
    gmsh = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TETRA: m.cells[:, [0, 1, 2, 3, 4, 5, 6, 7, 9, 8]]}, m.points)
    assert np.max(np.abs(fields.cell_volumes(gmsh) / vol_fem - 1)) > 0.2


def test_surfaces_outer_and_cavity_are_separated():
    """A box with a box-shaped hole: the hole's faces form the cavity surface."""
    m = box_mesh(3.0, 3.0, 3.0, 3, 3, 3)
    cent = m.points[m.cells[:, :4]].mean(axis=1)
    keep = ~np.all((cent > 1.0) & (cent < 2.0), axis=1)
    used = np.unique(m.cells[keep])
    remap = -np.ones(len(m.points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    holed = TetMesh(m.points[used], remap[m.cells[keep]])
    grid = pv.UnstructuredGrid({pv.CellType.QUADRATIC_TETRA: holed.cells}, holed.points)
    grid.point_data["u"] = np.zeros_like(holed.points)
    sv = vstate.prepare_state(grid)
    np.testing.assert_allclose(sv.outer.bounds, [0, 3, 0, 3, 0, 3], atol=1e-12)
    np.testing.assert_allclose(sv.cavity.bounds, [1, 2, 1, 2, 1, 2], atol=1e-12)
    assert sv.outline is not None and sv.outline.n_points > 0


def test_fields_and_errors(box_vtu):
    sv = vstate.prepare_state(box_vtu)
    names = fields.field_names(sv.grid)
    assert names[:2] == [fields.STRAIN_FIELD, fields.MAGNITUDE_FIELD]
    assert fields.resolve_field(sv.grid, None)[0] == fields.STRAIN_FIELD
    assert fields.resolve_field(sv.grid, "LE11")[0] == fields.STRAIN_FIELD
    assert fields.resolve_field(sv.grid, "|u|")[0] == fields.MAGNITUDE_FIELD
    assert fields.resolve_field(sv.grid, "displacement:y") == ("displacement", "displacement, y component [mm]", 1)
    assert fields.resolve_field(sv.grid, "none")[0] is None
    with pytest.raises(guard.ViewerError, match=r"no field 'stress'.*available fields"):
        fields.resolve_field(sv.grid, "stress", str(box_vtu))
    with pytest.raises(guard.ViewerError, match="displacement array 'w' not found"):
        vstate.prepare_state(box_vtu, displacement="w")
    with pytest.raises(guard.ViewerError, match="scale"):
        vstate.prepare_state(box_vtu, scale=-1.0)
    lo, hi = colours.shared_clim([sv], (fields.STRAIN_FIELD, "", None))
    assert (lo, hi) == pytest.approx(sv.field_range(fields.STRAIN_FIELD))  # one sign: the data range
    sv.outer.point_data[fields.STRAIN_FIELD][0] = 0.002
    # both signs: symmetric
    assert colours.shared_clim([sv], (fields.STRAIN_FIELD, "", None)) == pytest.approx((lo, -lo))
    # percentile range: one outlier node (a cavity corner) no longer sets the colours
    n = sv.outer.n_points
    vals = np.linspace(-0.01, 0.02, n)
    vals[n // 2] = 5.0
    sv.outer.point_data[fields.STRAIN_FIELD] = vals
    f = (fields.STRAIN_FIELD, "", None)
    assert colours.shared_clim([sv], f, percentile=0.0) == pytest.approx((-5.0, 5.0))
    lo1, hi1 = colours.shared_clim([sv], f, percentile=1.0)
    assert n >= 100 and 0.019 < hi1 < 0.021 and lo1 == pytest.approx(-hi1)
    with pytest.raises(guard.ViewerError, match="percentile"):
        colours.shared_clim([sv], f, percentile=60.0)


# ------------------------------------------------------------------ discovery and metadata
def test_missing_files_name_the_path(tmp_path):
    missing = tmp_path / "no_such_run"
    with pytest.raises(FileNotFoundError, match=str(missing)):
        rundir.discover(missing)
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "curve.csv").write_text("delta_mm\n0\n")
    with pytest.raises(FileNotFoundError, match=r"empty: no \*\.vtu file found"):
        rundir.discover(tmp_path / "empty")
    with pytest.raises(FileNotFoundError, match="nothing.vtu"):
        fields.load_grid(tmp_path / "nothing.vtu")
    (tmp_path / "broken.vtu").write_text("not xml")
    with pytest.raises(guard.ViewerError, match="broken.vtu"):
        fields.load_grid(tmp_path / "broken.vtu")
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(guard.ViewerError, match="notes.txt: not a .vtu"):
        rundir.discover(tmp_path / "notes.txt")


def test_split_stem_and_state_order():
    assert rundir.split_stem("intact_deflected") == ("intact", "deflected")
    assert rundir.split_stem("trimmed_vented_pressurised") == ("trimmed_vented", "pressurised")
    assert rundir.split_stem("trimmed_vented_deflected", ["trimmed_vented"]) == ("trimmed_vented", "deflected")
    assert rundir.split_stem("mesh") == ("mesh", "reference")
    assert rundir.split_stem("intact_delta_1.5") == ("intact", "delta_1.5")
    states = ["deflected", "delta_2", "pressurised", "delta_0.5", "reference"]
    assert sorted(states, key=rundir.state_sort_key) == [
        "reference", "pressurised", "delta_0.5", "delta_2", "deflected"]


def _pair_dir(tmp_path, box):
    """A simulate-like directory: intact (long) and trimmed (short) boxes, two states each."""
    run = tmp_path / "pair"
    short = box_mesh(8.0, 2.0, 2.0, 4, 1, 1)
    for scene, mesh in (("intact", box), ("trimmed", short)):
        write_vtu(run / f"{scene}_pressurised.vtu", mesh, point_data={"u": 0.1 * _bend(mesh.points, 0.01)})
        write_vtu(run / f"{scene}_deflected.vtu", mesh, point_data={"u": _bend(mesh.points, 0.01)})
    scenes = {
        "intact": {"Q_MPa": 0.03, "delta_l_mm": 0.1, "solved_delta_mm": [0, 1, 2], "eps_line": [0, 0.01, 0.02],
                   "gauge": {"x_ss": 2.0, "e": 2.0}, "contact_x": 9.5},
        "trimmed": {"Q_MPa": 0.0, "trim": 2.0, "solved_delta_mm": [0, 1, 2], "eps_line": [0, 0.012, 0.025]},
        "f1": 0.004,
    }
    (run / "scenes.json").write_text(json.dumps(scenes))
    (run / "curve.csv").write_text("delta_mm,eps_intact,eps_trimmed\n0,0,0\n1,0.01,0.012\n2,0.02,0.025\n")
    return run


def test_discover_run_directory(tmp_path, box):
    run = _pair_dir(tmp_path, box)
    c = rundir.discover(run)
    assert c.groups == ["."]
    assert c.scene_names(".") == ["intact", "trimmed"]
    assert [f.state for f in c.states(".", "intact")] == ["pressurised", "deflected"]
    info = c.info(".", "intact")
    assert info.Q == 0.03 and info.gauge == sceneinfo.GaugeSpot(2.0, 2.0, 20.0) and info.contact_x == 9.5
    assert info.reading("deflected") == (2.0, 0.02)
    assert c.info(".", "trimmed").trim == 2.0
    assert [f.state for f in c.select(".", state="press")] == ["pressurised", "pressurised"]
    with pytest.raises(guard.ViewerError, match=r"no state 'bent'.*pressurised"):
        c.select(".", state="bent")
    with pytest.raises(guard.ViewerError, match=r"no scene 'vented'.*intact"):
        c.select(".", scenes=["vented"])
    (run / "scenes.json").write_text("{broken")
    with pytest.raises(guard.ViewerError, match="scenes.json: not valid JSON"):
        rundir.discover(run)


def test_rank_and_eval_selection(tmp_path, box):
    run = tmp_path / "run"
    write_vtu(run / "best" / "intact_deflected.vtu", box, point_data={"u": _bend(box.points, 0.01)})
    write_vtu(run / "eval_7" / "intact_deflected.vtu", box, point_data={"u": _bend(box.points, 0.02)})
    (run / "evaluations.csv").write_text(
        "eval_id,generation,alpha,l,t,Q_i,f1,F_p,status,reason,time_s,cache_hit\n"
        "3,0,2,15,3,0.03,0.01,0.5,ok,,1,False\n"
        "7,0,2.5,14,3,0.03,0.005,0.2,ok,,1,False\n"
        "9,1,3,16,3,0.03,,1e9,solve_failed,diverged,1,False\n"
    )
    c = rundir.discover(run)
    assert c.default_group() == "best"
    assert evaluations.evaluation_row(run, rank=1)["eval_id"] == "7"
    assert evaluations.evaluation_row(run, eval_id=3)["F_p"] == "0.5"
    assert evaluations.group_for_evaluation(c, "7") == "eval_7"
    with pytest.raises(guard.ViewerError, match=r"rank 3 out of range: 1\.\.2"):
        evaluations.evaluation_row(run, rank=3)
    with pytest.raises(guard.ViewerError, match="no meshes stored for evaluation 3"):
        evaluations.group_for_evaluation(c, "3")


# ------------------------------------------------------------------ rendering
def test_screenshot_written_not_blank_and_follows_displacement(tmp_path, box):
    shots = []
    for k, a in enumerate((0.0, 0.03)):
        path = write_vtu(tmp_path / f"s{k}.vtu", box, point_data={"displacement": _bend(box.points, a)})
        sv = vstate.prepare_state(path)
        out = rendering.render([sv], field="displacement", screenshot=tmp_path / f"shot{k}.png", window_size=WS)
        assert out.is_file() and out.stat().st_size > 0
        img = _image(out)
        assert img.shape[:2] == (WS[1], WS[0])
        assert img[..., :3].var() > 1e-3  # not blank: background is uniform white
        shots.append(img)
    diff = np.abs(shots[0][..., :3] - shots[1][..., :3]).mean()
    assert diff > 1e-3


def test_side_by_side_compare_with_markers(tmp_path, box):
    run = _pair_dir(tmp_path, box)
    c = rundir.discover(run)
    views = vstate.load_views(c, ".")
    assert [v.title for v in views] == ["intact · deflected", "trimmed, vented · deflected"]
    assert overlays.gauge_patch(views[0]) is not None and overlays.contact_point(views[0]) is not None
    assert overlays.gauge_patch(views[1]) is None
    f = fields.resolve_field(views[0].grid, None)
    lo, hi = colours.shared_clim(views, f, percentile=0.0)
    for v in views:
        r = v.field_range(f[0])
        assert lo <= r[0] and r[1] <= hi
    for cav in rendering.CAVITY_MODES:
        out = rendering.render(views, screenshot=tmp_path / f"cmp_{cav}.png", window_size=(320, 360), cavity=cav)
        img = _image(out)
        assert img.shape[:2] == (360, 320) and img[..., :3].var() > 1e-3
    with pytest.raises(guard.ViewerError, match="cavity='open'"):
        rendering.render(views, screenshot=tmp_path / "x.png", window_size=WS, cavity="open")


def test_interactive_plotter_steps_states_offscreen(tmp_path, box):
    run = _pair_dir(tmp_path, box)
    c = rundir.discover(run)
    series = [[vstate.prepare_state(f.path, c.info(".", f.scene), f.state) for f in c.select(".", state=s)]
              for s in ("pressurised", "deflected")]
    p, set_step = rendering.interactive_plotter(series, "displacement", off_screen=True, window_size=(320, 360))
    img_last = p.screenshot()
    set_step(0)
    img_first = p.screenshot()
    p.close()
    assert np.abs(img_last.astype(float) - img_first.astype(float)).mean() > 0.1


# ------------------------------------------------------------------ command line
def _args(*argv):
    ap = argparse.ArgumentParser()
    command.VIEW_COMMAND[1](ap)
    return ap.parse_args([str(a) for a in argv])


def test_cli_screenshot_list_plots_and_errors(tmp_path, box, capsys):
    run = _pair_dir(tmp_path, box)
    out = tmp_path / "shots" / "view.png"
    assert command.VIEW_COMMAND[2](_args(run, "--screenshot", out, "--window-size", 320, 360, "--plots")) == 0
    assert out.is_file() and (tmp_path / "shots" / "curves.png").is_file()
    assert command.VIEW_COMMAND[2](_args(run, "--list")) == 0
    assert "scene intact" in capsys.readouterr().out
    missing = tmp_path / "gone"
    assert command.VIEW_COMMAND[2](_args(missing)) == 2
    assert str(missing) in capsys.readouterr().err
    assert command.VIEW_COMMAND[2](_args(run, "--field", "stress", "--screenshot", out)) == 2
    assert "no field 'stress'" in capsys.readouterr().err


def test_headless_detection_and_missing_pyvista(monkeypatch):
    assert guard.is_headless({}, "linux")
    assert not guard.is_headless({"DISPLAY": ":0"}, "linux")
    assert not guard.is_headless({"WAYLAND_DISPLAY": "wayland-0"}, "linux")
    assert not guard.is_headless({}, "darwin")
    monkeypatch.setitem(sys.modules, "pyvista", None)
    with pytest.raises(guard.ViewerUnavailable, match=r"whisker-opt\[viewer\]"):
        guard.require_pyvista()


def test_cli_without_screenshot_headless_and_with_display(tmp_path, box, monkeypatch, capsys):
    run = _pair_dir(tmp_path, box)
    monkeypatch.setattr(command, "is_headless", lambda *a, **k: True)
    assert command.VIEW_COMMAND[2](_args(run, "--window-size", 320, 360)) == 0
    assert (run / "view.png").is_file()
    assert "no display found" in capsys.readouterr().err
    # a display: the interactive plotter with the state slider (pv.OFF_SCREEN keeps it off-screen here)
    monkeypatch.setattr(command, "is_headless", lambda *a, **k: False)
    assert command.VIEW_COMMAND[2](_args(run, "--scene", "intact", "--window-size", 320, 200)) == 0
    assert command.VIEW_COMMAND[2](_args(run, "--scene", "vented", "--window-size", 320, 200)) == 2
    assert "no scene 'vented'" in capsys.readouterr().err


def test_registers_in_the_cli(tmp_path, box, monkeypatch):
    from whisker_opt.cli import commands, main as cli

    monkeypatch.setitem(commands.REGISTRY, "view", command.VIEW_COMMAND)
    run = _pair_dir(tmp_path, box)
    out = tmp_path / "v.png"
    assert cli.main(["view", str(run), "--screenshot", str(out), "--state", "pressurised", "--field", "|u|",
                     "--window-size", "320", "360"]) == 0
    assert out.is_file()
    assert cli.main(["view", str(tmp_path / "missing")]) == 2


def test_von_mises_uniaxial_closed_form(box):
    lam, c10 = 1.4, 0.14
    X = box.points
    Fu = np.diag([lam, lam**-0.5, lam**-0.5])  # incompressible uniaxial stretch
    F, used = post.nodal_deformation_gradient(X, box.cells, X @ Fu.T - X)
    assert used.all()
    np.testing.assert_allclose(NeoHookean(c10).von_mises(F), 2 * c10 * (lam**2 - 1 / lam), rtol=1e-12)
    # a superposed rigid rotation changes nothing
    th = 0.7
    R = np.array([[1, 0, 0], [0, math.cos(th), -math.sin(th)], [0, math.sin(th), math.cos(th)]])
    np.testing.assert_allclose(NeoHookean(c10).von_mises(R @ F), 2 * c10 * (lam**2 - 1 / lam), rtol=1e-12)


def test_run_directory_best_without_scenes_json(tmp_path, box):
    """A `whisker-opt run` directory: best/ meshes, best.json, best_curves.csv, config.yaml."""
    run = tmp_path / "run"
    for scene in ("intact", "trimmed"):
        for state, a in (("pressurised", 0.001), ("deflected", 0.01)):
            write_vtu(run / "best" / f"{scene}_{state}.vtu", box, point_data={"displacement": _bend(box.points, a)},
                      cell_data={"pressure": np.zeros(box.n_elements)})
    (run / "config.yaml").write_text(
        "design: {D: 2.5, L: 10.0, alpha: 1.0, c: 1.0, l: 6.0, t: 0.5, x_ss: 2.0, e: 1.0}\n"
        "material: {C10: 0.14, D1: 0.0}\nscene: {contact_ratio: 1.0}\noptimiser: {delta_max: 2.0}\n"
    )
    (run / "best.json").write_text(json.dumps(
        {"genes": {"alpha": 1.5, "l": 5.5, "t": 0.6, "Q_i": 0.02}, "f1": 0.003, "F_p": 0.004, "eval_id": 11}))
    (run / "best_curves.csv").write_text("delta_mm,eps_i,eps_c\n0,0,0\n1,0.01,0.011\n2,0.02,0.023\n")
    c = rundir.discover(run)
    assert c.default_group() == "best" and c.rubber == RunRubber("neo_hookean", "same", 0.14, 0.0, 1.0)
    intact, trimmed = c.info("best", "intact"), c.info("best", "trimmed")
    assert intact.design["alpha"] == 1.5 and intact.design["t"] == 0.6 and intact.Q == 0.02
    assert trimmed.trim == 2.0 and trimmed.Q == 0.0 and trimmed.reading("deflected") == (2.0, 0.023)
    assert intact.notes["F_p"] == 0.004 and intact.contact_x == pytest.approx(10.0)
    views = vstate.load_views(c, "best")
    assert fields.MISES_FIELD in fields.field_names(views[0].grid) and "pressure" in fields.field_names(views[0].grid)
    assert len(overlays.fibre_lines(views[0])) == 2
    out = tmp_path / "best.png"
    assert command.VIEW_COMMAND[2](_args(run, "--screenshot", out, "--field", "mises", "--window-size", 320, 360)) == 0
    assert _image(out)[..., :3].var() > 1e-3


def test_repeated_loads_and_renders_keep_the_heap_intact(tmp_path, box):
    """Regression: surfaces once shared VTK-backed arrays with their source grid, which
    corrupted the heap (segfault / free(): invalid pointer within a few iterations)."""
    c = rundir.discover(_pair_dir(tmp_path, box))
    for k in range(5):
        views = vstate.load_views(c, ".", edges=bool(k % 2))
        rendering.render(views, screenshot=tmp_path / "loop.png", window_size=(200, 240), show_edges=False,
                 cavity="translucent")
    assert (tmp_path / "loop.png").is_file()


# ------------------------------------------------------------------ three panels, deflection states, other evaluations
class _FakeResult:
    """What :func:`whisker_opt.output.scenes.write_scene_files` needs of a SceneResult."""

    def __init__(self, mesh: TetMesh, deltas, amplitude: float, pre: float = 0.0):
        from types import SimpleNamespace

        st = lambda a: SimpleNamespace(u=_bend(mesh.points, a), p=np.zeros(mesh.n_elements))  # noqa: E731
        self.mesh = SimpleNamespace(mesh=mesh)
        self.states = {"pressurised": st(pre)}
        for d in deltas:
            self.states[f"delta_{d:.2f}"] = st(pre + amplitude * d)
        self.states["deflected"] = self.states[f"delta_{deltas[-1]:.2f}"]


def _write_triple(folder, box, with_json=True):
    """A scene folder as `simulate`/`run` write it: intact at Q_i, trimmed uncompensated, trimmed vented,
    solved at delta = 1, 2, 3 mm."""
    from whisker_opt.output.scenes import write_scene_files

    short = box_mesh(8.0, 2.0, 2.0, 4, 1, 1)
    deltas = [1.0, 2.0, 3.0]
    cases = {  # name: (mesh, Q, trim, eps per delta, bend per mm)
        "intact": (box, 0.03, 0.0, [0, 0.010, 0.020, 0.030], 0.004),
        "trimmed_uncompensated": (short, 0.03, 2.0, [0, 0.014, 0.028, 0.042], 0.006),
        "trimmed": (short, 0.0, 2.0, [0, 0.011, 0.021, 0.031], 0.0045),
    }
    entries = {}
    for name, (mesh, q, trim, eps, amp) in cases.items():
        paths = write_scene_files(folder, name, _FakeResult(mesh, deltas, amp, pre=0.0005 if q else 0.0)).states
        assert len(paths) == 4  # pressurised, delta_1.00, delta_2.00, deflected (delta_3.00 is the same state)
        entries[name] = {"Q_MPa": q, "trim": trim, "solved_delta_mm": [0.0, *deltas], "eps_line": eps,
                         "eps_centroid": [e * 0.9 for e in eps], "gauge_variant": "line"}
    if with_json:
        (folder / "scenes.json").write_text(json.dumps({**entries, "f1": 0.001}))
    return entries


def test_three_panel_intact_uncompensated_vented(tmp_path, box):
    run = tmp_path / "sim"
    _write_triple(run, box)
    c = rundir.discover(run)
    assert c.scene_names(".") == ["intact", "trimmed_uncompensated", "trimmed"]
    views = vstate.load_views(c, ".")
    assert [v.title for v in views] == ["intact · deflected", "trimmed, uncompensated · deflected",
                                        "trimmed, vented · deflected"]
    texts = [overlays.text_lines(v) for v in views]
    assert [t[1].splitlines()[0] for t in texts] == [
        "gauge ε = 0.03 at δ = 3 mm", "gauge ε = 0.042 at δ = 3 mm", "gauge ε = 0.031 at δ = 3 mm"]
    assert "Q=0.03 MPa" in texts[1][0] and "trim=2 mm" in texts[1][0] and "Q=0 MPa" in texts[2][0]
    f = fields.resolve_field(views[0].grid, None)
    lo, hi = colours.shared_clim(views, f, percentile=0.0)
    assert all(lo <= v.field_range(f[0])[0] and v.field_range(f[0])[1] <= hi for v in views)
    out = tmp_path / "three.png"
    assert command.VIEW_COMMAND[2](_args(run, "--screenshot", out, "--window-size", 300, 540)) == 0
    img = _image(out)
    assert img.shape[:2] == (540, 300)
    for k in range(3):  # a long whisker: one panel per row, each drawn
        assert img[180 * k: 180 * (k + 1), :, :3].var() > 1e-3
    # the centroid gauge when the run used it
    data = json.loads((run / "scenes.json").read_text())
    data["trimmed"]["gauge_variant"] = "centroid"
    (run / "scenes.json").write_text(json.dumps(data))
    assert rundir.discover(run).info(".", "trimmed").reading("deflected") == pytest.approx((3.0, 0.031 * 0.9))


def test_delta_states_select_step_and_screenshot(tmp_path, box, capsys):
    run = tmp_path / "sim"
    _write_triple(run, box)
    c = rundir.discover(run)
    sts = c.states(".", "trimmed_uncompensated")
    assert [f.state for f in sts] == ["pressurised", "delta_1.00", "delta_2.00", "deflected"]
    assert [c.delta_of(f) for f in sts] == [0.0, 1.0, 2.0, 3.0]
    assert [f.state for f in c.select_delta(".", 2.0)] == ["delta_2.00"] * 3
    assert [f.state for f in c.select_delta(".", 3.0, ["intact"])] == ["deflected"]
    assert [f.state for f in c.select_delta(".", 0)] == ["pressurised"] * 3
    with pytest.raises(guard.ViewerError,
                       match=r"no state at delta=1\.5 mm; states exist at delta = \[0\.0, 1\.0, 2\.0"):
        c.select_delta(".", 1.5)
    steps = c.delta_steps(".")
    assert [d for d, _ in steps] == [0.0, 1.0, 2.0, 3.0]
    assert [f.state for f in steps[1][1]] == ["delta_1.00"] * 3
    views = vstate.load_views(c, ".", files=steps[2][1])
    assert views[0].title == "intact · delta = 2 mm"
    assert overlays.text_lines(views[0])[1].startswith("gauge ε = 0.02 at δ = 2 mm")
    assert [v.title for v in vstate.load_views(c, ".", files=steps[0][1])] == [
        "intact · pressurised", "trimmed, uncompensated · pressurised", "trimmed, vented · not pressurised (Q = 0)"]
    # screenshots at two deflections differ; same size, not blank
    shots = []
    for d in (1, 3):
        out = tmp_path / f"d{d}.png"
        assert command.VIEW_COMMAND[2](_args(run, "--delta", d, "--screenshot", out, "--window-size", 300, 540)) == 0
        img = _image(out)
        assert img.shape[:2] == (540, 300) and img[..., :3].var() > 1e-3
        shots.append(img)
    assert np.abs(shots[0][..., :3] - shots[1][..., :3]).mean() > 1e-3
    assert command.VIEW_COMMAND[2](_args(run, "--delta", 1.5, "--screenshot", tmp_path / "x.png")) == 2
    assert "states exist at delta" in capsys.readouterr().err
    assert command.VIEW_COMMAND[2](
        _args(run, "--delta", 1, "--state", "deflected", "--screenshot", tmp_path / "x.png")) == 2
    assert "--state and --delta are exclusive" in capsys.readouterr().err
    # the interactive slider runs over delta
    series = [vstate.load_views(c, ".", files=files) for _, files in steps]
    p, set_step = rendering.interactive_plotter(series, "displacement", off_screen=True, window_size=(300, 540),
                                        step_values=[d for d, _ in steps], start=1)
    img1 = p.screenshot()
    set_step(3)
    img3 = p.screenshot()
    p.close()
    assert np.abs(img1.astype(float) - img3.astype(float)).mean() > 0.1


def test_delta_steps_without_metadata_go_by_index(tmp_path, box):
    run = tmp_path / "sim"
    _write_triple(run, box, with_json=False)
    c = rundir.discover(run)
    steps = c.delta_steps(".", ["intact"])
    assert [d for d, _ in steps] == [None] * 4  # 'deflected' has no known delta without scenes.json
    assert [f.state for _, (f,) in steps] == ["pressurised", "delta_1.00", "delta_2.00", "deflected"]


def _fake_run(tmp_path, box):
    """A run directory: best/ (= evaluation 7), evaluations.csv, best.json, config.yaml."""
    run = tmp_path / "run"
    _write_triple(run / "best", box)
    (run / "evaluations.csv").write_text(
        "eval_id,generation,alpha,l,t,Q_i,f1,F_p,status,reason,time_s,cache_hit\n"
        "3,0,2,15,3,0.03,0.01,0.5,ok,,1,False\n"
        "7,0,2.5,14,3,0.03,0.005,0.2,ok,,1,False\n"
        "9,1,3,16,3,0.03,,1e9,solve_failed,diverged,1,False\n"
    )
    (run / "best.json").write_text(json.dumps(
        {"genes": {"alpha": 2.5, "l": 14, "t": 3, "Q_i": 0.03}, "f1": 0.005, "F_p": 0.2, "eval_id": 7}))
    (run / "config.yaml").write_text("fidelity: {preset: coarse}\noptimiser: {delta_max: 2.0}\n")
    return run


def test_rank_and_eval_rerun_into_a_cached_folder(tmp_path, box, monkeypatch, capsys, caplog):
    from geometry.design import InvalidDesignError
    from whisker_opt import workflows

    run = _fake_run(tmp_path, box)
    calls = []

    def fake_write(out, cfg, genes, specs=None):
        calls.append((out, genes))
        assert out.name.startswith(".") and cfg.optimiser.trim == 2.0  # a hidden folder, the run's config
        if genes["alpha"] == 3.0:
            raise InvalidDesignError(["alpha=3.0: cone tip radius < 0"], {"alpha"})
        _write_triple(out, box)

    monkeypatch.setattr(workflows, "write_design_scenes", fake_write)
    out = tmp_path / "eval3.png"
    with caplog.at_level("WARNING", logger="whisker_opt.viewer.evaluations"):
        assert command.VIEW_COMMAND[2](_args(run, "--eval", 3, "--screenshot", out, "--window-size", 300, 540)) == 0
    assert "evaluation 3" in caplog.text and "re-running its scenes" in caplog.text and "eval_3" in caplog.text
    assert len(calls) == 1 and calls[0][1] == {"alpha": 2.0, "l": 15.0, "t": 3.0, "Q_i": 0.03}
    assert (run / "eval_3" / "scenes.json").is_file() and not (run / ".eval_3.partial").exists()
    assert _image(out)[..., :3].var() > 1e-3
    c = rundir.discover(run)
    assert c.groups == ["best", "eval_3"] and c.scene_names("eval_3") == ["intact", "trimmed_uncompensated", "trimmed"]
    # cached: shown again without solving; rank 2 is evaluation 3
    assert command.VIEW_COMMAND[2](_args(run, "--rank", 2, "--screenshot", out, "--delta", 2)) == 0
    assert len(calls) == 1
    # rank 1 is the best design, stored in best/
    c2, group = evaluations.evaluation_group(c, evaluations.evaluation_row(run, rank=1))
    assert group == "best" and len(calls) == 1
    views = vstate.load_views(c2, group, notes={"eval_id": "7"})
    assert len(views) == 3
    # a design that cannot be re-run: a clear error, nothing left behind
    assert command.VIEW_COMMAND[2](_args(run, "--eval", 9, "--screenshot", out)) == 2
    err = capsys.readouterr().err
    assert "evaluation 9" in err and "cannot be re-run" in err and "cone tip radius" in err
    assert not (run / "eval_9").exists() and not (run / ".eval_9.partial").exists()
    with pytest.raises(guard.ViewerError, match="no meshes stored for evaluation 9"):
        evaluations.evaluation_group(c, evaluations.evaluation_row(run, eval_id=9), rerun=False)


def test_design_scene_specs_three_scenes():
    from whisker_opt.wiring import UNCOMPENSATED, design_scene_specs
    from whisker_opt.config.model import WhiskerConfig

    cfg = WhiskerConfig.model_validate({"optimiser": {"trim": 4.0}, "fidelity": {"preset": "coarse"}})
    genes = {"alpha": 2.0, "l": 20.0, "t": 1.6, "Q_i": 0.15}
    specs = design_scene_specs(cfg, genes)
    assert list(specs) == ["intact", UNCOMPENSATED, "trimmed"] and UNCOMPENSATED == rundir.UNCOMPENSATED
    assert [(s.Q, s.design.trim) for s in specs.values()] == [(0.15, 0.0), (0.15, 4.0), (0.0, 4.0)]
    assert specs[UNCOMPENSATED].design == specs["trimmed"].design
    assert list(design_scene_specs(cfg, dict(genes, Q_i=0.0))) == ["intact", "trimmed"]


# ------------------------------------------------------------------ colour ranges per panel, legend, notes
def _outer_ranges(p, n):
    """The colour range each panel's whisker surface is actually drawn with."""
    return [tuple(p.renderers[i].actors[f"{i}:outer"].mapper.scalar_range) for i in range(n)]


def test_each_panel_has_its_own_colour_range_by_default(tmp_path, box):
    run = tmp_path / "sim"
    _write_triple(run, box)
    c = rundir.discover(run)
    views = vstate.load_views(c, ".")  # intact, trimmed uncompensated, trimmed vented, all deflected
    f = fields.resolve_field(views[0].grid, None)
    panels = [[v] for v in views]
    own = colours.panel_clims(panels, f, 1.0)
    shared = colours.panel_clims(panels, f, 1.0, "shared")
    assert shared == [colours.shared_clim(views, f, 1.0)] * 3
    assert own == [colours.shared_clim([v], f, 1.0) for v in views]
    assert colours.panel_scopes(panels, f, 1.0) == ["panel"] * 3
    vented = own[2]
    assert vented != own[0] and vented != own[1] and vented[1] - vented[0] > 1e-3  # its own, not degenerate

    def width(r):
        return r[1] - r[0]

    data = views[2].field_range(f[0], None, 1.0)
    assert width(data) / width(shared[2]) < 0.6  # a shared range leaves the vented panel part of the colours
    assert width(data) / width(vented) == pytest.approx(1.0)  # its own range spans all of them
    # what VTK draws: pyvista merges same-titled bars' ranges unless each panel has a bar of its own
    for mode, expected, n_bars in (("panel", own, 3), ("shared", shared, 1)):
        p = rendering.make_plotter(views, off_screen=True, window_size=(300, 540))
        rendering.draw(p, views, f, expected, clim_mode=mode)
        np.testing.assert_allclose(_outer_ranges(p, 3), expected)
        assert len(p.scalar_bars) == n_bars
        titles = [bar.GetTitle() for bar in p.scalar_bars.values()]
        assert all("[-]" in t and ("range of this panel" if mode == "panel" else "same for all panels") in t
                   for t in titles)
        p.close()
    # unloaded (vented at delta = 0: no strain at all): that panel takes the range of all panels
    at_rest = vstate.load_views(c, ".", files=c.delta_steps(".")[0][1])
    rest = [[v] for v in at_rest]
    assert colours.panel_scopes(rest, f, 1.0) == ["panel", "panel", "uniform"]
    clims = colours.panel_clims(rest, f, 1.0)
    assert clims[2] == colours.shared_clim(at_rest, f, 1.0) and clims[2][1] > clims[2][0]
    assert "uniform here" in vlabels.bar_title(f[1], "uniform")
    # in a window each panel's range spans all its steps: the vented one is not degenerate though δ = 0 is
    series = [vstate.load_views(c, ".", files=files) for _, files in c.delta_steps(".")]
    by_panel = [[step[i] for step in series] for i in range(3)]
    assert colours.panel_scopes(by_panel, f, 1.0) == ["panel"] * 3
    steps = colours.panel_clims(by_panel, f, 1.0)
    assert steps[2] == colours.shared_clim(by_panel[2], f, 1.0) and steps[2] != steps[0]
    for mode in colours.CLIM_MODES:
        p, set_step = rendering.interactive_plotter(series, "strain", off_screen=True, window_size=(300, 540),
                                                    clim_mode=mode, start=0)
        set_step(3)
        expected = steps if mode == "panel" else [colours.shared_clim(by_panel[0] + by_panel[1] + by_panel[2],
                                                                        f, 1.0)] * 3
        np.testing.assert_allclose([tuple(p.renderers[i].actors[f"s:{i}:outer"].mapper.scalar_range)
                                    for i in range(3)], expected)
        p.close()
    with pytest.raises(guard.ViewerError, match="clim mode='both'"):
        colours.panel_clims(panels, f, 1.0, "both")


def test_cli_clim_option(tmp_path, box, monkeypatch):
    run = tmp_path / "sim"
    _write_triple(run, box)
    assert _args(run).clim_mode == "panel"
    assert _args(run, "--clim", "shared").clim_mode == "shared"
    with pytest.raises(SystemExit):
        _args(run, "--clim", "both")
    seen = []
    real = command.render
    monkeypatch.setattr(command, "render", lambda *a, **k: seen.append(k["clim_mode"]) or real(*a, **k))
    shots = {}
    for mode in ("panel", "shared"):
        out = tmp_path / f"{mode}.png"
        assert command.VIEW_COMMAND[2](_args(run, "--clim", mode, "--screenshot", out, "--window-size", 300, 540)) == 0
        shots[mode] = _image(out)[..., :3]
    assert seen == ["panel", "shared"]
    # the vented panel (bottom third) is coloured differently by its own range than by the shared one
    assert np.abs(shots["panel"][360:] - shots["shared"][360:]).mean() > 1e-3


def test_picture_states_units_ranges_zero_points_and_markers(tmp_path, box, monkeypatch):
    # units on every scalar bar title; no '|' (VTK's text renderer drops it and garbles the line)
    assert all(lbl.endswith("]") and "|" not in lbl for lbl in fields.FIELD_LABELS.values())
    assert fields.FIELD_LABELS[fields.STRAIN_FIELD].endswith("[-]")
    assert fields.FIELD_LABELS[fields.MISES_FIELD] == "von Mises stress [MPa]"
    assert fields.field_label("pressure") == "pressure [MPa]" and fields.field_label("foo") == "foo [unit unknown]"
    sv = vstate.prepare_state(write_vtu(tmp_path / "s.vtu", box, point_data={"displacement": _bend(box.points, 0.01)}))
    assert fields.resolve_field(sv.grid, "displacement")[1] == "displacement magnitude [mm]"
    assert fields.resolve_field(sv.grid, "|u|")[1] == "displacement magnitude [mm]"
    # the colour range in words, not as a strain-like per cent
    assert [vlabels.ordinal(x) for x in (1, 2, 3, 11, 12, 22, 99, 2.5)] == [
        "1st", "2nd", "3rd", "11th", "12th", "22nd", "99th", "2.5th"]
    f = (fields.STRAIN_FIELD, fields.FIELD_LABELS[fields.STRAIN_FIELD], None)
    note = vlabels.colour_note(f, "panel", 1.0)
    assert "colour range: each panel its own, 1st–99th percentile" in note and "%" not in note
    assert "total axial log strain from the unloaded state" in note and "contact onset" in note
    assert "one for all panels" in vlabels.colour_note(f, "shared", 0.0)
    assert "full range" in vlabels.colour_note(f, "shared", 0.0)
    assert vlabels.colour_note((None, "", None)) == ""
    assert vlabels.bar_title("von Mises stress [MPa]", "panel").split("\n") == [
        "von Mises stress", "[MPa]", "range of this panel"]
    line = "Trimmed, uncompensated: tip cut off by Δ = 5 mm, chamber pressure still Q = 0.166 MPa"
    assert vlabels.wrap(line, 90) == line
    wrapped = vlabels.wrap(line, 40).split("\n")
    assert max(map(len, wrapped)) <= 40 and "chamber pressure still Q = 0.166 MPa" in wrapped
    # panel headings in words; the gauge reading says where it is counted from
    _write_triple(tmp_path / "sim", box)
    c = rundir.discover(tmp_path / "sim")
    views = vstate.load_views(c, ".")
    heads = [overlays.panel_heading(v).split("\n") for v in views]
    assert heads[0] == ["Intact: full length, not trimmed, chamber pressure Q = 0.03 MPa",
                        "deflected: contact pushed sideways by δ = 3 mm",
                        "fidelity preset not recorded"]  # these files carry no preset, and no config.yaml is there
    assert heads[1][0] == "Trimmed, uncompensated: tip cut off by Δ = 2 mm, chamber pressure still Q = 0.03 MPa"
    assert heads[2][0] == "Trimmed, vented: tip cut off by Δ = 2 mm, chamber vented (Q = 0 MPa)"
    rest = vstate.load_views(c, ".", files=c.delta_steps(".")[0][1])
    assert [overlays.panel_heading(v).split("\n")[1] for v in rest] == [
        "pressurised, not yet pushed (δ = 0)", "pressurised, not yet pushed (δ = 0)",
        "at rest: not pressurised, not pushed (δ = 0)"]
    assert all(overlays.text_lines(v)[1].split("\n")[1] == overlays.GAUGE_ZERO_NOTE for v in views)
    # the legend names the markers that are drawn
    pair = vstate.load_views(rundir.discover(_pair_dir(tmp_path, box)), ".")
    labels = [lbl for lbl, _ in vlabels.legend_entries(pair)]
    assert labels == ["strain gauge (where ε is read)", "contact point, push direction",
                      "undeformed outline (section z = 0)"]
    assert [lbl for lbl, _ in vlabels.legend_entries(pair, show_gauge=False, show_outline=False)] == [
        "contact point, push direction"]
    p = rendering.make_plotter(pair, off_screen=True, window_size=(320, 360))
    rendering.draw(p, pair, f, colours.panel_clims([[v] for v in pair], f, 1.0), clim_mode="panel")
    rendering.annotate(p, pair, f, "panel", 1.0)
    assert "legend" in p.renderers[0].actors and "colour_note" in p.renderers[1].actors
    assert p.renderers[0].actors["legend"].GetNumberOfEntries() == 3
    p.close()
    # text is drawn in a font with '[' and Greek letters; without it, they are spelt out
    assert vlabels.text_font() is not None
    monkeypatch.setattr(vlabels, "text_font", lambda: None)
    assert vlabels.shown_text("gauge ε at δ = 2 mm") == "gauge eps at delta = 2 mm"


# ------------------------------------------------------------------ the push's strain, fidelity in titles, the mesh view
def test_deflected_panels_default_to_the_strain_the_push_added(tmp_path, box):
    run = tmp_path / "sim"
    _write_triple(run, box)
    c = rundir.discover(run)
    views = vstate.load_views(c, ".")  # every scene deflected
    assert vstate.default_field(views) == fields.STRAIN_CHANGE_FIELD
    for v in views:
        onset = vstate.prepare_state(c.select(".", [v.info.name], "pressurised")[0].path)
        want = v.grid.point_data[fields.STRAIN_FIELD] - onset.grid.point_data[fields.STRAIN_FIELD]
        np.testing.assert_allclose(v.grid.point_data[fields.STRAIN_CHANGE_FIELD], want, atol=1e-15)
        assert np.abs(want).max() > 1e-4
    # pressurised panels: the pressure's own strain is taken off; vented: the change is the total
    pre = np.asarray(vstate.load_views(c, ".", state="pressurised")[0].grid.point_data[fields.STRAIN_FIELD])
    assert np.abs(pre).max() > 1e-5
    vented = views[2].grid.point_data
    np.testing.assert_allclose(vented[fields.STRAIN_CHANGE_FIELD], vented[fields.STRAIN_FIELD], atol=1e-15)
    # at contact onset only: the change is zero everywhere, the default stays the total strain
    at_onset = vstate.load_views(c, ".", state="pressurised")
    assert vstate.default_field(at_onset) is None
    assert all(np.abs(v.grid.point_data[fields.STRAIN_CHANGE_FIELD]).max() == 0.0 for v in at_onset)
    assert fields.resolve_field(views[0].grid, "change")[0] == fields.STRAIN_CHANGE_FIELD
    f = fields.resolve_field(views[0].grid, fields.STRAIN_CHANGE_FIELD)
    assert "deflected − pressurised" in f[1] and "zeroed at contact onset" in vlabels.colour_note(f)
    out = tmp_path / "push.png"
    assert command.VIEW_COMMAND[2](_args(run, "--screenshot", out, "--window-size", 300, 540)) == 0
    assert out.is_file()


def test_titles_name_the_preset_and_the_mesh_view_its_elements_and_layers(tmp_path):
    from whisker_opt import workflows
    from whisker_opt.config.model import load_config

    cfg_path = tmp_path / "c.yaml"
    cfg_path.write_text("fidelity: {preset: coarse}\n")
    workflows.mesh(load_config(cfg_path), tmp_path / "m", progress=False)
    c = rundir.discover(tmp_path / "m")
    [sv] = vstate.load_views(c, ".")
    heading = overlays.panel_heading(sv)
    n = sv.grid.n_cells
    assert f"{n} elements (10-node tets), 1 wall layer (a radial line through the wall crosses" in heading
    assert heading.splitlines()[-1] == "preset coarse, f1 resolution ~2e-3"
    cut = rendering.section_edges(sv)
    assert cut is not None and cut.n_lines > 50  # the elements' edges on the cut
    # a scene file carries its preset; a file that does not, the run's config.yaml names it
    plain = vstate.prepare_state(sv.path, config={"fidelity": {"preset": "fine"}, "scene": {"calibration": 7.8}})
    assert plain.fidelity == "preset coarse, f1 resolution ~2e-3"  # the file's own field data wins
    assert vstate.fidelity_text(box_mesh_grid(), {"fidelity": {"preset": "fine"}, "scene": {"calibration": 7.8}}) \
        == "preset fine, f1 resolution ~1.4e-3"
    assert vstate.fidelity_text(box_mesh_grid(), {}) is None
    assert "fidelity preset not recorded" in overlays.panel_heading(vstate.prepare_state(box_mesh_grid()))
    out = tmp_path / "mesh.png"
    assert command.VIEW_COMMAND[2](_args(tmp_path / "m", "--screenshot", out, "--window-size", 400, 300)) == 0
    assert out.is_file()


def box_mesh_grid():
    """A small quadratic-tet grid without field data."""
    import pyvista as pv

    m = box_mesh(4.0, 1.0, 1.0, 2, 1, 1)
    return pv.UnstructuredGrid({pv.CellType.QUADRATIC_TETRA: m.cells}, np.asarray(m.points, dtype=float))
