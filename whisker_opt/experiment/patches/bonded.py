"""``bonded``: the gauge as built, a stiff thin sheet (its backing, grid and adhesive) bonded on the outer surface.

The gauge is a sheet of thickness t = ``scene.patch_thickness``, Young's modulus Y = ``scene.patch_modulus`` and
Poisson ratio ν = ``scene.patch_poisson`` on the rectangle of the outer surface of axial length
``scene.patch_length`` centred on the grid (x_ss + e/2) and arc width ``scene.patch_width`` centred on the +y
generator (:func:`geometry.tagging.footprint_mask`), perfectly bonded (:class:`fem.problem.Membrane`, the
plane-stress Saint Venant–Kirchhoff sheet of :mod:`fem.membrane`, energy ∫ t W(E_s) dA0). The footprint is
resolved at the quadrature points of the outer faces: the thickness is t at the points inside, 0 outside, on
the faces with a point inside, so a footprint narrower than the mesh's faces is represented by the points that
fall in it (mesh-dependent on coarse meshes; it converges with refinement). The readings are unchanged: the line
reading's points lie on the outer surface, so under the sheet they read the sheet's strain, which is the strain
of the grid bonded to it.

Why it matters: the sheet's membrane stiffness Y t is of order 50 N/mm, the rubber wall's μ t_wall
(0.28 MPa × 3 mm) of order 1 N/mm, so where the sheet is bonded it strains much less than the bare rubber does.

The prototype's gauge is a Kyowa KFGS-2-120-C1-11 (2 mm grid, gauge factor 2.21) bonded with a Kyowa CC-series
cyanoacrylate and covered by a thin layer of silicone glue. Defaults and their sources:

- ``patch_length`` 6.5 mm, ``patch_width`` 3.0 mm: the gauge's base (backing) outline. **Estimate**: the KFGS
  catalogue page was not available; Kyowa bases for a 2 mm grid measure 6–7 mm × 2.5–3 mm.
- ``patch_thickness`` 0.025 mm: the polyimide base, about 15 µm (Kyowa's catalogue of the KFG series, whose
  polyimide base the KFGS shares, "approximately 15 µm"; the copy consulted is partly illegible, 13–15 µm),
  plus a cyanoacrylate layer of 10 µm (**estimate**, 5–20 µm for a thumb-pressed CC bond).
- ``patch_modulus`` 2100 MPa: the thickness-weighted modulus of the two layers, (15 × 2500 + 10 × 1500)/25:
  polyimide film 2.5 GPa (DuPont Kapton HN datasheet, 23 °C; other polyimide films 2.5–4 GPa) and cured
  cyanoacrylate 1.5 GPa (**estimate**, 1–2 GPa). So Y t = 52.5 N/mm (range about 25–120 N/mm).
- ``patch_poisson`` 0.34: polyimide film (DuPont Kapton HN datasheet).

Left out: the foil grid itself (a Cu–Ni alloy of E ≈ 160 GPa, some 5 µm thick over roughly half the grid area,
**estimate**), which would add of order 10² N/mm along the grid lines over the grid's 2 mm × 1.5 mm only, and
the silicone cover (E t of order 0.1 N/mm, negligible). The sheet's bending stiffness and its offset from the
surface (t/2 = 12 µm on a radius of 8 mm) are of relative order t/R (:mod:`fem.membrane`).
"""

from __future__ import annotations

NAME = "bonded"
ORDER = 1
DESCRIPTION = ("a sheet of patch_thickness, patch_modulus and patch_poisson bonded on the outer surface over "
               "patch_length × patch_width around the gauge")
PARAMETERS: tuple[str, ...] = ("patch_length", "patch_width", "patch_thickness", "patch_modulus", "patch_poisson")

LENGTH_DEFAULT = 6.5  # mm, estimate (docstring)
WIDTH_DEFAULT = 3.0  # mm, estimate (docstring)
THICKNESS_DEFAULT = 0.025  # mm: 15 µm polyimide (Kyowa) + 10 µm cyanoacrylate (estimate)
MODULUS_DEFAULT = (15.0 * 2500.0 + 10.0 * 1500.0) / 25.0  # MPa: thickness-weighted, 2100
POISSON_DEFAULT = 0.34  # polyimide (DuPont Kapton HN datasheet)
#: Triangle-rule degree of the footprint's points: the problem's face rule (fem.problem.Problem's default).
FACE_DEGREE = 4


def footprint(design, length: float) -> tuple[float, float]:
    """Axial extent (x_lo, x_hi) [mm] of a patch of ``length`` centred on the gauge grid of ``design``."""
    xc = design.x_ss + 0.5 * design.e
    return xc - 0.5 * length, xc + 0.5 * length


def membranes(wm, spec) -> tuple:
    """One :class:`fem.problem.Membrane` on the outer faces with a quadrature point in the footprint.

    Raises
    ------
    ValueError
        No quadrature point of the outer surface lies in the footprint (names the keys).
    """
    import numpy as np

    from fem.membrane import MembraneKernel
    from fem.problem import Membrane
    from geometry.tagging import footprint_mask

    outer = wm.face_sets["outer"]
    x_lo, x_hi = footprint(spec.design, spec.patch_length)
    inside = footprint_mask(MembraneKernel(wm.mesh.points, outer, FACE_DEGREE).points, x_lo, x_hi,
                            spec.patch_width)  # (n_outer, n_qp)
    faces = np.any(inside, axis=1)
    if not faces.any():
        raise ValueError(f"scene.patch_length={spec.patch_length:g}, scene.patch_width={spec.patch_width:g}: no "
                         f"point of the outer surface's faces lies in the footprint x in [{x_lo:g}, {x_hi:g}] mm; "
                         "widen it or refine the mesh")
    return (Membrane(outer[faces], spec.patch_thickness * inside[faces], spec.patch_modulus, spec.patch_poisson,
                     "gauge patch"),)
