"""The compensation map Q(Δ, a) and its lookup: the beam model as the response stand-in, and the
warm pressurise step on the coarse FE mesh."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from geometry.design import WhiskerDesign
from whisker_opt.analysis import beam
from whisker_opt.analysis import compensation as comp
from whisker_opt.analysis import compensation_map as cmod
from whisker_opt.analysis.beam import BeamModel, BeamResponse
from whisker_opt.compensation import CompensationMap, MapRangeError, vent_pressure

Q_I = 0.2
TRIMS = [0.0, 1.0, 2.0, 3.0]
A = [0.7, 0.85, 1.0]
XATOL = 1e-7


def beam_response(design, Q, a, deltas):
    return BeamResponse(a=a)(design, Q, deltas)


@pytest.fixture(scope="module")
def bmap():
    """A 4 × 3 map on the beam model, every cell inside (0, Q_i) for Δ > 0."""
    return cmod.solve_map(WhiskerDesign(), Q_I, TRIMS, A, beam_response, xatol=XATOL)


def test_every_cell_is_the_table_compensation_at_its_contact_ratio(bmap):
    d = WhiskerDesign()
    for j, a in enumerate(A):
        table = comp.compensation_table(d, Q_I, TRIMS[-1], BeamResponse(a=a), step=1.0, method="root", xatol=XATOL)
        np.testing.assert_array_equal(bmap.Q[:, j], table.pressures)
        np.testing.assert_array_equal(bmap.recovery_rate[1:, j], table.column("recovery_rate")[1:])
    assert np.all(bmap.at_bound[1:] == "") and np.all((bmap.Q[1:] > 0) & (bmap.Q[1:] < Q_I))
    # the beam model is linear in δ: the compensated ε/δ equals the intact one at the same a
    for j, a in enumerate(A):
        s_o = beam.sensitivity(d, a, Q_I)
        for k, t in enumerate(TRIMS[1:], 1):
            assert beam.sensitivity(d.trimmed(t), a, bmap.Q[k, j]) == pytest.approx(s_o, rel=1e-6)


def test_trim_order_and_contact_ratio_order_give_the_same_map(bmap):
    by_a = cmod.solve_map(WhiskerDesign(), Q_I, TRIMS, A, beam_response, xatol=XATOL, by="a")
    np.testing.assert_array_equal(bmap.Q, by_a.Q)
    np.testing.assert_array_equal(bmap.n_responses, by_a.n_responses)


def test_lookup_is_exact_at_nodes_and_bilinear_between(bmap):
    for k, t in enumerate(TRIMS):
        for j, a in enumerate(A):
            assert vent_pressure(t, a, bmap) == bmap.Q[k, j]
    ref = RegularGridInterpolator((np.array(TRIMS), np.array(A)), bmap.Q, method="linear")
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(0, 3, 40), rng.uniform(0.7, 1.0, 40)])
    got = np.array([vent_pressure(t, a, bmap) for t, a in pts])
    np.testing.assert_allclose(got, ref(pts), rtol=0, atol=1e-14)
    # along an edge the interpolant is linear in one variable
    q = vent_pressure(1.25, 0.85, bmap)
    assert q == pytest.approx(0.75 * bmap.Q[1, 1] + 0.25 * bmap.Q[2, 1], abs=1e-15)


def test_lookup_against_a_directly_solved_off_grid_cell(bmap):
    """Off the grid (Δ = 1.4 mm, a = 0.78) the lookup lies within the bilinear error bound
    (h_Δ²/8)·max|∂²Q/∂Δ²| + (h_a²/8)·max|∂²Q/∂a²|, the curvatures measured by second differences
    of a finer map over the cell."""
    t, a = 1.4, 0.78
    direct = comp.fe_compensation(WhiskerDesign(), Q_I, t, BeamResponse(a=a), method="root", xatol=XATOL).Q
    fine = cmod.solve_map(WhiskerDesign(), Q_I, [0.0, 0.5, 1.0, 1.5, 2.0, 2.5], [0.7, 0.775, 0.85], beam_response,
                          xatol=XATOL)
    q = fine.Q[2:5]  # Δ = 1, 1.5, 2
    d2t = np.abs(q[2] - 2 * q[1] + q[0]).max() / 0.5**2
    d2a = np.abs(q[:, 2] - 2 * q[:, 1] + q[:, 0]).max() / 0.075**2
    bound = 1.0**2 / 8 * d2t + 0.15**2 / 8 * d2a
    err = abs(vent_pressure(t, a, bmap) - direct)
    assert err <= 1.5 * bound + 2 * XATOL
    assert bound < 0.01  # a useful bound: a hundredth of an MPa
    # and the interpolation beats the nearest node
    assert err < abs(bmap.Q[1, 1] - direct)


def test_map_written_and_read_back(tmp_path, bmap):
    from whisker_opt.output.compensation import write_map

    paths = write_map(tmp_path, bmap)
    assert {p.name for p in paths.values()} == {"compensation_map.csv", "compensation_map.json",
                                               "compensation_map.png"}
    rows = list(csv.DictReader(paths["csv"].open()))
    assert len(rows) == len(TRIMS) * len(A)
    r = rows[len(A) + 1]  # Δ = 1, a = 0.85
    assert (float(r["trim_mm"]), float(r["a"])) == (1.0, 0.85)
    assert float(r["Q_MPa"]) == pytest.approx(bmap.Q[1, 1], rel=1e-9)
    back = CompensationMap.load(tmp_path)
    np.testing.assert_array_equal(back.Q, bmap.Q)
    np.testing.assert_array_equal(back.at_bound, bmap.at_bound)
    assert np.isnan(back.recovery_rate[0]).all() and back.Q_i == Q_I
    assert vent_pressure(2.3, 0.9, tmp_path / "compensation_map.json") == vent_pressure(2.3, 0.9, bmap)


def test_bound_cells_are_marked_and_interpolated_as_clipped():
    # beam model, a = 0.55: the trimmed whisker still reads high at Q = 0 (vent fully) from Δ ≈ 1.5 mm on
    m = cmod.solve_map(WhiskerDesign(), Q_I, [0.0, 2.0, 3.0], [0.55, 1.0], beam_response, xatol=1e-6)
    assert list(m.at_bound[1:, 0]) == ["lower", "lower"] and np.all(m.Q[1:, 0] == 0.0)
    assert np.all(m.at_bound[1:, 1] == "") and np.all(m.recovery_rate[1:, 0] < 100.0)
    assert m.near_bound(2.5, 0.6) and not m.near_bound(2.5, 1.0) and not m.near_bound(0.0, 0.55)
    assert vent_pressure(2.5, 0.775, m) == pytest.approx(0.25 * (m.Q[1, 1] + m.Q[2, 1]), abs=1e-15)


@pytest.mark.parametrize("trim, a, words", [
    (5.5, 0.8, ["trim = 5.5", "[0, 3] mm"]),
    (-0.1, 0.8, ["trim = -0.1", "[0, 3] mm"]),
    (1.0, 0.5, ["a = 0.5", "[0.7, 1]"]),
    (1.0, float("nan"), ["a = nan", "[0.7, 1]"]),
    ("x", 0.8, ["trim = 'x'", "not a number", "[0, 3]"]),
])
def test_lookup_refuses_out_of_range_in_one_line(bmap, trim, a, words):
    with pytest.raises(MapRangeError) as exc:
        vent_pressure(trim, a, bmap)
    msg = str(exc.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_load_refuses_what_is_not_a_map(tmp_path):
    with pytest.raises(FileNotFoundError, match="compensation_map.json"):
        CompensationMap.load(tmp_path)
    (tmp_path / "compensation_map.json").write_text(json.dumps({"kind": "table"}))
    with pytest.raises(MapRangeError, match="not a readable compensation map"):
        vent_pressure(1.0, 0.8, tmp_path)


def test_map_arguments_are_checked():
    d = WhiskerDesign()
    with pytest.raises(ValueError, match="at least two distinct"):
        cmod.solve_map(d, Q_I, TRIMS, [1.0, 1.0], beam_response)
    with pytest.raises(ValueError, match=r"\(0, 1\]"):
        cmod.solve_map(d, Q_I, TRIMS, [0.5, 1.2], beam_response)
    with pytest.raises(ValueError, match="starting at 0"):
        cmod.solve_map(d, Q_I, [1.0, 2.0], A, beam_response)
    assert cmod.map_trims(5.0, 0.5) == [0.5 * i for i in range(11)]
    assert cmod.map_trims(1.2, 0.5) == [0.0, 0.5, 1.0, 1.2]


# ----------------------------------------------------------------------------- the command
class _BeamResult:
    def __init__(self, spec):
        self.spec = spec

    def curve(self, deltas, variant="line"):
        s = beam.sensitivity(self.spec.design, self.spec.contact_ratio, self.spec.Q, BeamModel(calibration=3.9))
        return s * np.asarray(deltas, dtype=float)


class _BeamRunner:
    """SceneRunner stand-in: the beam model (ξ = 3.9) at the spec's contact ratio."""

    def __init__(self, *args, **kwargs):
        self.memo_hits = 0

    def run(self, spec, keep_states=False):
        return _BeamResult(spec)


def test_compensate_map_command(tmp_path, monkeypatch, capsys):
    from whisker_opt.cli.main import main
    from whisker_opt.experiment import scene

    monkeypatch.setattr(scene, "SceneRunner", _BeamRunner)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.2\noptimiser:\n  trim: 2.0\n")
    out = tmp_path / "out"
    assert main(["compensate", str(cfg), "--a", "0.7", "1", "--step", "1", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "3 trims x 2 contact ratios" in printed
    m = CompensationMap.load(out)
    assert m.trims.tolist() == [0.0, 1.0, 2.0] and m.a.tolist() == [0.7, 1.0] and m.fidelity["preset"] == "coarse"
    s_o = beam.sensitivity(WhiskerDesign(), 0.7, 0.2)  # ξ cancels: both sides carry it
    assert beam.sensitivity(WhiskerDesign().trimmed(2.0), 0.7, m.Q[2, 0]) == pytest.approx(s_o, rel=1e-3)
    assert (out / "compensation_map.png").stat().st_size > 1000
    from whisker_opt.config.model import load_config

    recorded = load_config(out / "config.yaml")  # the --out folder records the resolved config it ran
    assert recorded.fidelity.preset == "coarse" and recorded.scene.Q_i == 0.2 and recorded.material.wall_law == "embedded"


@pytest.mark.parametrize("args, words", [
    (["--a", "0.5", "1.5"], ["--a", "1.5", "(0, 1]"]),
    (["--a", "0.7"], ["--a", "0.7", "at least two distinct"]),
    (["--map", "--step", "0"], ["--step", "(0, 100] mm"]),
])
def test_compensate_map_bad_options_one_line(tmp_path, capsys, args, words):
    from whisker_opt.cli.main import main

    cfg = tmp_path / "c.yaml"
    cfg.write_text("fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.2\noptimiser:\n  trim: 2.0\n")
    code = main(["compensate", str(cfg), *args, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------- warm pressurise (coarse FE)
def test_warm_pressurise_shares_across_contact_ratios_and_starts_newton_nearby():
    import dataclasses

    from whisker_opt.compensation import WarmPressurise
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt import wiring
    from whisker_opt.experiment.scene import SceneRunner, pressurise

    cfg = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}})
    spec = wiring.scene_spec(cfg, WhiskerDesign().trimmed(2.0), 0.12)
    wm = SceneRunner().mesh_for(spec)
    hook = WarmPressurise()
    first = hook(spec, wm)
    # another contact ratio on the same mesh: the same pressurised state, nothing solved
    assert hook(dataclasses.replace(spec, contact_ratio=0.6), wm) is first
    # a nearby pressure starts from the stored state: the cold answer within Newton's tolerance, fewer iterations
    near = dataclasses.replace(spec, Q=0.1)
    warm, cold = hook(near, wm), pressurise(near, wm)
    assert hook.counts == {"shared": 1, "newton_start": 1, "cold": 1, "fallback": 0}
    scale = np.abs(cold.state.u).max()
    assert np.abs(warm.state.u - cold.state.u).max() <= 1e-6 * scale
    assert sum(r.iterations for r in warm.reports) < sum(r.iterations for r in cold.reports)
    # the cold path of the hook-less step is unchanged by the hook's existence: the same solve, equal up to
    # the linear solver's round-off (PARDISO's threaded factorisation is not bit-reproducible under load),
    # 100x below the Newton tolerance used above
    np.testing.assert_allclose(first.state.u, pressurise(spec, wm).state.u, rtol=0, atol=1e-8 * scale)
