"""The viewer shows the fields the solver stored, and computes what an older file lacks with the
run's own law (whisker_opt.viewer.fields, whisker_opt.viewer.rubber).

Two real runs, one scene each on the coarse preset's mesh (Q = 0.02 MPa, deflected 1 mm in one
increment), written as a run directory (state VTUs, ``scenes.json``, the resolved
``config.yaml``): a Yeoh rubber (``material.rubber: yeoh_dragon_skin_10``), and a neo-Hookean
body with a Yeoh cap (``material.cap_rubber: yeoh_dragon_skin_30``). Closed forms on a box check
the computed von Mises stress of each law: incompressible uniaxial stretch λ gives
σ_vM = 2 W'(Ī1) (λ² − 1/λ), Ī1 = λ² + 2/λ.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from fem.io import write_vtu  # noqa: E402
from fem.meshgen import box_mesh  # noqa: E402
from geometry.design import WhiskerDesign  # noqa: E402
from whisker_opt.config.model import WhiskerConfig, dump_config  # noqa: E402
from whisker_opt.experiment.fidelity import PRESETS  # noqa: E402
from whisker_opt.experiment.rubber_laws import RUBBER_LAWS  # noqa: E402
from whisker_opt.experiment.spec import SceneSpec  # noqa: E402
from whisker_opt.output import scenes as out_scenes  # noqa: E402
from whisker_opt.viewer import fields, rundir  # noqa: E402
from whisker_opt.viewer import state as vstate  # noqa: E402

COARSE = PRESETS["coarse"]
RUNS = {
    "yeoh": {"rubber": "yeoh_dragon_skin_10"},
    "two_rubbers": {"rubber": "neo_hookean", "cap_rubber": "yeoh_dragon_skin_30"},
}
#: The array each field the viewer derives is to equal, when the file stores it.
STORED_AS = {fields.STRAIN_FIELD: "log_strain_axial", fields.MAGNITUDE_FIELD: "displacement_magnitude",
             fields.MISES_FIELD: "von_mises"}


@pytest.fixture(scope="module", params=sorted(RUNS))
def run(request, tmp_path_factory):
    """A run directory of one solved scene with the rubber of ``RUNS[param]``."""
    material = RUNS[request.param]
    out = tmp_path_factory.mktemp(request.param)
    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}, "material": material})
    spec = SceneSpec(WhiskerDesign(), Q=0.02, deflection=1.0, n_deflection_steps=1, n_pressure_steps=1,
                     sizing=COARSE.sizing, c10=cfg.material.C10, d1=cfg.material.D1, rubber=cfg.material.rubber,
                     cap_rubber=cfg.material.cap_rubber)
    _, entries = out_scenes.solve_scenes(out, {"intact": spec})
    (out / "scenes.json").write_text(json.dumps(entries, default=float))
    (out / "config.yaml").write_text(dump_config(cfg))
    return out


def _stored(path) -> dict[str, np.ndarray]:
    grid = pv.read(path)
    return {**{k: np.asarray(grid.cell_data[k]) for k in grid.cell_data.keys()},
            **{k: np.asarray(grid.point_data[k]) for k in grid.point_data.keys()}}


def test_every_field_shown_is_the_stored_one(run):
    contents = rundir.discover(run)
    files = contents.states(".", "intact")
    assert [f.state for f in files] == ["pressurised", "deflected"]
    views = vstate.load_views(contents, ".", files=files)
    for f, view in zip(files, views):
        stored = _stored(f.path)
        shown = fields.field_names(view.grid)
        assert fields.MISES_FIELD in shown and fields.STRAIN_FIELD in shown
        onset = _stored(files[0].path)[STORED_AS[fields.STRAIN_FIELD]]
        for name in shown:
            if name == fields.STRAIN_CHANGE_FIELD:  # the strain the push added: two stored strains' difference
                np.testing.assert_array_equal(view.grid.point_data[name],
                                              stored[STORED_AS[fields.STRAIN_FIELD]] - onset)
                continue
            ref = stored[STORED_AS.get(name, name)]
            got = view.grid.point_data.get(name)
            got = view.grid.cell_data[name] if got is None else got
            np.testing.assert_array_equal(np.asarray(got), ref, err_msg=f"{f.path.name}: {name}")
    assert np.ptp(stored["von_mises"]) > 0  # the deflected state is stressed


def test_an_older_file_gets_its_stress_from_the_run_s_own_law(run, tmp_path):
    """The stored von Mises stress, the strain and |u| removed: the viewer computes them again, the stress
    with the run's law (a Yeoh law, or a cap of another law than the body), to round-off."""
    src = rundir.discover(run).states(".", "intact")[-1].path
    stored = _stored(src)
    old = pv.read(src)
    for name in ("von_mises", "cauchy_stress", "log_strain", "log_strain_axial", "displacement_magnitude"):
        old.point_data.remove(name)
    folder = tmp_path / "older"
    folder.mkdir()
    old.save(folder / src.name)
    (folder / "config.yaml").write_text((run / "config.yaml").read_text())
    view = vstate.load_views(rundir.discover(folder), ".")[0]
    scale = np.abs(stored["von_mises"]).max()
    np.testing.assert_allclose(view.grid.point_data[fields.MISES_FIELD], stored["von_mises"], rtol=1e-9,
                               atol=1e-12 * scale)
    np.testing.assert_allclose(view.grid.point_data[fields.STRAIN_FIELD], stored["log_strain_axial"], rtol=1e-12,
                               atol=1e-15)
    np.testing.assert_allclose(view.grid.point_data[fields.MAGNITUDE_FIELD], stored["displacement_magnitude"],
                               rtol=1e-14)
    # without the run's config there is no law, and no stress is made up
    (folder / "config.yaml").unlink()
    assert fields.MISES_FIELD not in fields.field_names(vstate.load_views(rundir.discover(folder), ".")[0].grid)


def _yeoh_slope(c: tuple[float, ...], i1: float) -> float:
    return sum(k * ck * (i1 - 3.0) ** (k - 1) for k, ck in enumerate(c, start=1))


@pytest.mark.parametrize("material, slope", [
    ({"C10": 0.14}, lambda i1: 0.14),
    ({"C10": 0.14, "rubber": "yeoh_dragon_skin_10"}, lambda i1: _yeoh_slope(RUBBER_LAWS["yeoh_dragon_skin_10"].constants, i1)),
])
def test_computed_von_mises_closed_form(tmp_path, material, slope):
    """A file with a displacement only: σ_vM = 2 W'(Ī1) (λ² − 1/λ) of the config's law under an incompressible
    uniaxial stretch λ (for the neo-Hookean law the value the viewer has always shown)."""
    lam = 1.5
    box = box_mesh(4.0, 1.0, 1.0, 2, 1, 1)
    u = box.points @ np.diag([lam, lam**-0.5, lam**-0.5]).T - box.points
    write_vtu(tmp_path / "box_deflected.vtu", box, point_data={"displacement": u})
    (tmp_path / "config.yaml").write_text(json.dumps({"material": material}))
    view = vstate.load_views(rundir.discover(tmp_path), ".")[0]
    i1 = lam**2 + 2 / lam
    np.testing.assert_allclose(view.grid.point_data[fields.MISES_FIELD], 2 * slope(i1) * (lam**2 - 1 / lam),
                               rtol=1e-12)
