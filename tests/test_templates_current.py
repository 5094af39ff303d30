"""The shipped template meshes are what their presets' sizings make today, and every preset but ``reference``
(swept for each design) has them.

A template is the linear swept mesh of one reference design (:func:`geometry.template.make_template`); the GA
maps the nearest one to each design. A sizing changed without regenerating its templates
(``python3 -m whisker_opt.experiment.fidelity``) would leave the presets meshing with the old sizing: each
shipped file must equal, point for point, a template made now from its preset's sizing.
"""

from __future__ import annotations

import numpy as np
import pytest

from geometry.template import TEMPLATE_DIR, load_template, make_template, select_template, template_designs
from whisker_opt.experiment.fidelity import LADDER_SECTORS, PRESETS, ladder_sizing


@pytest.mark.parametrize("preset", [name for name, p in PRESETS.items() if p.template])
def test_shipped_templates_are_current(preset):
    sizing = PRESETS[preset].sizing
    designs = template_designs()
    made = make_template(designs[-1], sizing)
    shipped = load_template(TEMPLATE_DIR / f"{made.name}.npz")
    assert shipped.sizing_key == sizing.template_key()
    assert np.array_equal(shipped.tets, made.tets)
    assert np.array_equal(shipped.points, made.points)
    for d in designs:  # every reference design of the grid has its template
        assert select_template(d, sizing).design == d


def test_the_ladder_refines_every_direction():
    sizes = [ladder_sizing(k) for k in LADDER_SECTORS]
    assert sizes[0] == PRESETS["default"].sizing
    for a, b in zip(sizes, sizes[1:]):
        assert b.wall_layers > a.wall_layers and b.n_theta > a.n_theta
        assert b.axial_pitch_fraction < a.axial_pitch_fraction and b.h_body < a.h_body
    assert sizes[-1] == PRESETS["reference"].sizing  # the finest level is the reference preset
    with pytest.raises(ValueError, match="mesh ladder level 6"):
        ladder_sizing(6)
