"""The gauge patches (whisker_opt.experiment.gauge_patches): the registry, the footprint and the scene.

The ``bonded`` sheet (Y t = 52.5 N/mm by default) sits on a wall of membrane stiffness of order E_r t_wall
(E_r = 3μ = 6 C10 = 0.84 MPa, t_wall = 3 mm: 2.5 N/mm). A local estimate of what it does to the strain under it
is the rule of mixtures of the sheet and the wall strip under it carrying the force the bare strip carried:

    ε_sheet / ε_bare ≈ E_r t_wall / (E_r t_wall + Y t)

(0.046 for the defaults, 0.32 and 0.83 for Y/10 and Y/100). The scene is bending, not a strip in tension, and
on the coarse preset the sheet acts on whole faces, so the estimate is a guide within 0.1 (measured on the
coarse preset at Q = 0, δ = 1 mm: 0.096, 0.32, 0.80), not an identity; the tests hold the limits exactly (a
vanishing sheet reads as the bare surface) and the trend (a stiffer sheet reads less).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from geometry.design import WhiskerDesign
from geometry.tagging import footprint_mask
from tests.folder_helpers import assert_run_file_refused
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.gauge_patches import GAUGE_PATCHES, PATCHES, listing, patch_membranes
from whisker_opt.experiment.patches import bonded
from whisker_opt.experiment.scene import SceneRunner
from whisker_opt.experiment.spec import SceneSpec

SIZING = PRESETS["coarse"].sizing


@pytest.fixture(scope="module")
def runner():
    return SceneRunner()


def spec(**kw) -> SceneSpec:
    kw.setdefault("deflection", 1.0)
    return SceneSpec(WhiskerDesign(), sizing=SIZING, n_deflection_steps=2, **kw)


def test_registry_is_the_list_of_names():
    """The choices are the modules of whisker_opt/experiment/patches/, 'none' first and the scene's default."""
    import pkgutil

    import whisker_opt.experiment.patches as pkg

    assert GAUGE_PATCHES == ("none", "bonded")
    assert set(GAUGE_PATCHES) == {m.name for m in pkgutil.iter_modules(pkg.__path__)}
    assert SceneSpec(WhiskerDesign()).gauge_patch == "none"
    assert PATCHES["bonded"].parameters == ("patch_length", "patch_width", "patch_thickness", "patch_modulus",
                                            "patch_poisson")
    assert "bonded: " in listing() and "(reads patch_length" in listing()


def test_footprint_mask_is_the_arc_rectangle():
    """Points at radius 8 on the +y side: inside when |x − 5| ≤ 3 and the arc 8|φ| ≤ 1.5 (width 3)."""
    r, phi = 8.0, np.array([0.0, 1.49 / 8.0, -1.49 / 8.0, 1.51 / 8.0, 0.0, 0.0, np.pi])
    x = np.array([5.0, 5.0, 7.99, 5.0, 1.99, 8.01, 5.0])
    pts = np.stack([x, r * np.cos(phi), r * np.sin(phi)], axis=1)
    assert footprint_mask(pts, 2.0, 8.0, 3.0).tolist() == [True, True, True, False, False, False, False]


def test_bonded_sheet_covers_the_footprint(runner):
    """The sheet's thickness is t at the outer faces' quadrature points inside the footprint and 0 elsewhere; the
    area it covers, Σ w dA0 over those points, tends to patch_length × patch_width (19.5 mm² on the cone, to
    1e-3): 23.5 mm² on the coarse preset, 21.1 on the default, 20.5 on the fine one; checked within 25 %."""
    from fem.membrane import MembraneKernel

    s = spec(gauge_patch="bonded")
    wm = runner.mesh_for(s)
    assert patch_membranes(wm, replace(s, gauge_patch="none")) == ()
    (m,) = patch_membranes(wm, s)
    mk = MembraneKernel(wm.mesh.points, m.faces, bonded.FACE_DEGREE)
    x_lo, x_hi = bonded.footprint(s.design, s.patch_length)
    inside = footprint_mask(mk.points, x_lo, x_hi, s.patch_width)
    np.testing.assert_array_equal(m.thickness, np.where(inside, s.patch_thickness, 0.0))
    covered = float((inside * mk.wdA).sum())
    assert covered == pytest.approx(s.patch_length * s.patch_width, rel=0.25)
    with pytest.raises(ValueError, match=r"^scene\.patch_length=6\.5, scene\.patch_width=0\.001: no point"):
        patch_membranes(wm, replace(s, patch_width=0.001))


def test_vanishing_sheet_reads_as_the_bare_surface(runner):
    """patch_modulus = 1e-6 MPa (Y t = 2.5e-8 N/mm): every reading and the contact force equal 'none' to 1e-6."""
    bare = runner.run(spec())
    soft = runner.run(spec(gauge_patch="bonded", patch_modulus=1e-6))
    for name, eps in bare.eps.items():
        np.testing.assert_allclose(soft.eps[name], eps, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(soft.contact_force, bare.contact_force, rtol=1e-6, atol=1e-12)


def test_stiffer_sheet_reads_less_as_the_rule_of_mixtures(runner):
    """Q = 0, δ = 1 mm: the line reading falls as Y t grows (Y/100, Y/10, Y of the defaults), each within 0.1 of
    the rule-of-mixtures ratio (module docstring), and the contact force rises by less than 5 % (measured
    3.5 % for the default sheet)."""
    bare = runner.run(spec())
    E_r, t_wall = 6.0 * bare.spec.c10, bare.spec.design.t
    ratios = []
    for k in (100.0, 10.0, 1.0):
        s = spec(gauge_patch="bonded", patch_modulus=bonded.MODULUS_DEFAULT / k)
        res = runner.run(s)
        r = res.eps["line"][-1] / bare.eps["line"][-1]
        rom = E_r * t_wall / (E_r * t_wall + s.patch_modulus * s.patch_thickness)
        assert abs(r - rom) <= 0.1, (k, r, rom)
        ratios.append(r)
        assert 0.0 < (res.contact_force[-1] - bare.contact_force[-1]) / bare.contact_force[-1] < 0.05
    assert 1.0 > ratios[0] > ratios[1] > ratios[2] > 0.0


def test_sheet_holds_back_the_pressurised_extension_a_little(runner):
    """Q = 0.2 MPa: the sheet, axially stiffer (Y t w = 158 N) than the whole chamber wall (E_r A ≈ 110 N) over
    its 6.5 mm of the 13 mm chamber on one side, shortens Δl, by 8.5 % on the coarse preset (checked: between 2
    and 15 %), and the reading at onset-relative δ = 1 mm falls as at Q = 0 (below a fifth)."""
    bare, sheet = runner.run(spec(Q=0.2)), runner.run(spec(Q=0.2, gauge_patch="bonded"))
    drop = (bare.delta_l - sheet.delta_l) / bare.delta_l
    assert 0.02 < drop < 0.15
    assert 0.0 < sheet.eps["line"][-1] < 0.2 * bare.eps["line"][-1]


@pytest.mark.parametrize("key, value, message", [
    ("patch_thickness", 0.0, r"^SceneSpec\.patch_thickness=0\.0: must be > 0 and <= 1$"),
    ("patch_modulus", -1.0, r"^SceneSpec\.patch_modulus=-1\.0: must be > 0 and <= 1e\+06$"),
    ("patch_poisson", 0.5, r"^SceneSpec\.patch_poisson=0\.5: must be >= 0 and < 0\.5$"),
    ("patch_length", 60.0, r"^SceneSpec\.patch_length=60\.0: must be > 0 and <= 50$"),
    ("patch_width", 0.0, r"^SceneSpec\.patch_width=0\.0: must be > 0 and <= 50$"),
    ("gauge_patch", "glued", r"^SceneSpec\.gauge_patch='glued'"),
])
def test_scene_refuses_bad_patch_parameters(key, value, message):
    with pytest.raises(ValueError, match=message):
        SceneSpec(WhiskerDesign(), **{key: value})


@pytest.mark.parametrize("text, message", [
    ("scene: {gauge_patch: bonded, patch_thickness: -1}\n",
     r"scene\.patch_thickness: -1 is outside the allowed range \(0, 1\] \(mm\)$"),
    ("scene: {patch_modulus: 0}\n", r"scene\.patch_modulus: 0 is outside the allowed range \(0, 1e\+?0?6\]"),
    ("scene: {patch_poisson: 0.6}\n", r"scene\.patch_poisson: 0\.6 is outside the allowed range \[0, 0\.5\)"),
    ("scene: {patch_width: 80}\n", r"scene\.patch_width: 80 is outside the allowed range \(0, 50\]"),
    ("scene: {gauge_patch: glued}\n", r"scene\.gauge_patch: 'glued'"),
])
def test_run_file_refuses_bad_patch_parameters_in_one_line(tmp_path, text, message):
    assert_run_file_refused(tmp_path, text, message)


def test_deck_refuses_the_sheet():
    from whisker_opt.output.scene_deck import deck_refusal

    assert deck_refusal(SceneSpec(WhiskerDesign(), gauge_patch="bonded")).startswith("scene.gauge_patch: 'bonded';")
    assert deck_refusal(SceneSpec(WhiskerDesign())) is None
