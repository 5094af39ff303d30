"""The gauge readings registered by name (whisker_opt/experiment/gauge_variants.py, one module each in
whisker_opt/experiment/readings/): each one against its closed form under a homogeneous deformation of a
coarse whisker mesh, zero at onset, and the registry behind ``scene.gauge_variant`` and the measures."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import logm

from geometry.design import WhiskerDesign
from geometry.mesh import build_mesh
from whisker_opt.experiment.fidelity import PRESETS
from whisker_opt.experiment.gauge import GaugeReader, gauge_points, locate_gauge
from whisker_opt.experiment.gauge_variants import GAUGE_READINGS, GAUGE_VARIANTS

XI = 3.9
#: A homogeneous deformation with stretch, shear and rotation (det > 0).
F = np.array([[1.03, 0.02, -0.01], [-0.015, 0.98, 0.03], [0.01, -0.02, 1.01]])


@pytest.fixture(scope="module")
def gauged():
    design = WhiskerDesign()
    wm = build_mesh(design, PRESETS["coarse"].sizing)
    return wm.mesh, locate_gauge(wm, design)


def _homogeneous(mesh, f: np.ndarray) -> np.ndarray:
    return mesh.points @ (f - np.eye(3)).T  # (n_nodes, 3): u = (F − I) X


def test_the_registry_holds_every_reading_module_the_default_first():
    import pkgutil

    import whisker_opt.experiment.readings as pkg

    modules = {m.name for m in pkgutil.iter_modules(pkg.__path__)}
    assert tuple(GAUGE_READINGS) == tuple(GAUGE_VARIANTS) and set(GAUGE_READINGS) == modules
    assert tuple(GAUGE_READINGS)[:3] == ("line", "centroid", "section")
    assert all(r.name == n and r.description == GAUGE_VARIANTS[n] for n, r in GAUGE_READINGS.items())
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.experiment.measures import MEASURE_NAMES

    assert {"eps_i_line", "eps_c_line", "eps_i_centroid", "eps_c_centroid"} <= set(MEASURE_NAMES)
    assert WhiskerConfig.model_validate({"scene": {"gauge_variant": "centroid"}}).scene.gauge_variant == "centroid"
    names = [repr(n) for n in GAUGE_READINGS]
    with pytest.raises(Exception, match="allowed words: " + ", ".join(names)):  # every registered name
        WhiskerConfig.model_validate({"scene": {"gauge_variant": "rosette"}})


def test_every_reading_is_zero_at_onset(gauged):
    mesh, gauge = gauged
    reader = GaugeReader(mesh, gauge, XI)
    u = _homogeneous(mesh, F)
    reader.zero(u)
    assert reader.read(u) == dict.fromkeys(GAUGE_READINGS, 0.0)


def test_line_reading_is_the_log_stretch_of_the_gauge_tangent(gauged):
    """Under u = (F − I) X from an undeformed onset: ε = ξ ln |F T| at every gauge point, so their mean too."""
    mesh, gauge = gauged
    reader = GaugeReader(mesh, gauge, XI)
    reader.zero(np.zeros_like(mesh.points))
    assert reader.read(_homogeneous(mesh, F))["line"] == pytest.approx(XI * np.log(np.linalg.norm(F @ gauge.tangent)),
                                                                       rel=1e-12)


def test_centroid_reading_is_the_axial_eulerian_log_strain(gauged):
    """ε = ξ (½ ln F Fᵀ)_xx (the matrix logarithm, scipy), relative to an onset already stretched axially."""
    mesh, gauge = gauged
    onset = np.diag([1.01, 1.0, 1.0])
    reader = GaugeReader(mesh, gauge, XI)
    reader.zero(_homogeneous(mesh, onset))
    want = XI * (0.5 * logm(F @ F.T).real[0, 0] - np.log(1.01))
    assert reader.read(_homogeneous(mesh, F))["centroid"] == pytest.approx(want, rel=1e-10)


def _pure_bending(mesh, kappa: float) -> np.ndarray:
    """u of plane sections bent about z, towards −y, to curvature κ: X ↦ ((R + y) sin(x/R), (R + y) cos(x/R) − R, z),
    R = 1/κ: a line at height y stretches by 1 + κ y, every section stays plane, rotated by x/R."""
    R = 1.0 / kappa
    x, y, z = mesh.points.T
    new = np.stack([(R + y) * np.sin(x / R), (R + y) * np.cos(x / R) - R, z], axis=1)
    return new - mesh.points  # (n_nodes, 3)


@pytest.mark.parametrize("transfer", [1.0, 0.83])
def test_section_reading_under_pure_bending_is_the_log_of_one_plus_transfer_r_kappa(gauged, transfer):
    """From an undeformed onset to pure bending of curvature κ (sections plane, the gauge's generator at
    r_o stretched by 1 + κ r_o): the section reading is ξ ln(1 + G r_o κ) for any transfer G of the context, and
    the line reading's closed form is the mean of ln |F T| over its points, T = (1, −tan α, 0)/√(1 + tan² α)."""
    from whisker_opt.experiment.gauge import ReadingContext

    mesh, gauge = gauged
    kappa = 2e-3
    reader = GaugeReader(mesh, gauge, XI, ReadingContext(transfer))
    reader.zero(np.zeros_like(mesh.points))
    got = reader.read(_pure_bending(mesh, kappa))
    assert got["section"] == pytest.approx(XI * np.log1p(transfer * gauge.radius * kappa), rel=1e-7)
    design = WhiskerDesign()
    pts, w, _ = gauge_points(design.x_ss, design.e, design.r_outer, design.alpha, 16)
    ta2 = np.tan(np.radians(design.alpha)) ** 2
    stretch = np.sqrt(((1.0 + kappa * pts[:, 1]) ** 2 + ta2) / (1.0 + ta2))
    assert got["line"] == pytest.approx(XI * float(w @ np.log(stretch)), rel=1e-6)


def test_section_reading_ignores_rigid_motion_and_uniform_stretch(gauged):
    """A rotated and stretched whisker has plane sections that do not tilt relative to each other: κ = 0."""
    mesh, gauge = gauged
    c, s_ = np.cos(0.3), np.sin(0.3)
    rot = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([1.05, 0.97, 0.97])
    reader = GaugeReader(mesh, gauge, XI)
    reader.zero(np.zeros_like(mesh.points))
    assert abs(reader.read(_homogeneous(mesh, rot))["section"]) < 1e-12
