"""Calibration: what the data determined, and a fit that does not depend on its start.

* A parameter is calibrated only when its uncertainty (scaled by √(χ²/ν) when that is above 1) is at
  most a quarter of its range; ``calibrated.yaml`` names the ones that are not, and flags χ²/ν.
* The wall law's slope fitted to the thesis' restore and sensitivity-ratio data with the beam model
  stand-in ends at the same value from the documented start 0 and from −2, the minimum of the cost
  over the box; from 0 the local fit alone stays in another basin, which is reported.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from whisker_opt.calibration.fit import DETERMINED_FRACTION, Problem, determined
from whisker_opt.calibration.forward import BeamSimulator, RestoreSearch
from whisker_opt.calibration.job import calibrate, prepare
from whisker_opt.calibration.parameters import ModelParameter
from whisker_opt.calibration.starts import LocalFit, disagree, scan_points
from whisker_opt.config.model import load_config

DATA = Path(__file__).resolve().parents[1] / "configs" / "data"


def _param(lower: float, upper: float) -> ModelParameter:
    return ModelParameter(path="material.C10", lower=lower, upper=upper, start=lower, unit="MPa", description="")


def test_a_parameter_is_determined_when_its_uncertainty_is_a_quarter_of_its_range_at_most():
    """The rule on the numbers of the thesis' FE fit: C10 ± 0.039 (0.29 scaled) on [0.1, 0.6] and
    fibre_radius_frac ± 0.42 (3.1 scaled) on [0.05, 0.95] are not determined; a scaled std below the
    unscaled one (χ²/ν < 1) does not count; ν ≤ 0 (no scaled std) uses std."""
    assert DETERMINED_FRACTION == 0.25
    got = determined([0.039, 0.42, 0.1, 0.1, math.inf, 0.2], [0.29, 3.1, 0.05, math.nan, math.inf, 0.26],
                     [_param(0.1, 0.6), _param(0.05, 0.95), _param(0.0, 0.4), _param(0.0, 0.4), _param(0.0, 1.0),
                      _param(0.0, 1.0)])
    assert got == (False, False, True, True, False, False)
    assert determined([0.125], [0.125], [_param(0.1, 0.6)]) == (True,)  # a quarter of 0.5: the limit itself


def test_the_scan_is_a_centred_latin_hypercube_the_same_on_every_call():
    one = scan_points(1)
    np.testing.assert_allclose(one[:, 0], (np.arange(6) + 0.5) / 6)
    two = scan_points(2)
    assert two.shape == (10, 2)
    for col in two.T:  # each parameter's ten cell centres, once each
        np.testing.assert_allclose(np.sort(col), (np.arange(10) + 0.5) / 10)
    np.testing.assert_array_equal(two, scan_points(2))


def test_two_fits_disagree_in_cost_or_in_a_determined_parameter():
    """1 % of the cost (and chi2 by more than 1) or of a determined parameter's range (10 x the tolerance
    1e-3) apart."""
    def local(values, cost):
        return LocalFit("-", np.zeros(2), np.array(values, dtype=float), cost, cost, 1, "", 1)

    widths = [6.0, 0.9]
    assert not disagree([local([-2.88, 0.5], 95.6)], widths, 1e-3)
    assert not disagree([local([-2.88, 0.5], 95.6), local([-2.91, 0.5], 95.8)], widths, 1e-3)
    assert disagree([local([-2.88, 0.5], 95.6), local([-2.95, 0.5], 95.6)], widths, 1e-3)
    assert disagree([local([-2.88, 0.5], 95.6), local([-2.88, 0.5], 97.0)], widths, 1e-3)
    # costs of an exact fit, both below chi2 = 1: the same
    assert not disagree([local([-2.88, 0.5], 1e-8), local([-2.88, 0.5], 2e-8)], widths, 1e-3)
    assert disagree([local([-2.88, 0.5], 0.1), local([-2.88, 0.5], 0.7)], widths, 1e-3)
    # apart only in a parameter the data do not determine: the same result
    assert disagree([local([-2.88, 0.5], 95.6), local([-2.88, 0.7], 95.6)], widths, 1e-3)
    assert not disagree([local([-2.88, 0.5], 95.6), local([-2.88, 0.7], 95.6)], widths, 1e-3, (True, False))


def _sensitivity_config(folder: Path, *, sigma: float, parameters: list) -> Path:
    """The thesis' sensitivity ratios (configs/data) with every σ set to ``sigma``, fitted with the beam model."""
    text = (DATA / "thesis_sensitivity.csv").read_text().splitlines()
    rows = [ln for ln in text if not ln.startswith("#")]
    col = rows[0].split(",").index("sigma")
    out = [rows[0]] + [",".join(r.split(",")[:col] + [repr(sigma)] + r.split(",")[col + 1:]) for r in rows[1:]]
    (folder / "ratios.csv").write_text("\n".join(out) + "\n")
    cal = {"source": "the thesis' softening law read as sensitivity ratios", "model": "beam",
           "parameters": parameters, "measurements": [{"file": "ratios.csv", "kind": "response"}]}
    path = folder / "cal.yaml"
    path.write_text(yaml.safe_dump({"material": {"wall_law": "calibrated"}, "calibration": cal}))
    return path


def test_the_header_calls_calibrated_only_what_the_data_determined(tmp_path):
    """Ratios do not depend on the gauge factor: the wall law's slope is calibrated, scene.calibration is
    named as not determined; with σ's a hundred times larger nothing is determined: NOT CALIBRATED."""
    params = [{"path": "material.wall_slope", "lower": -4.0, "upper": 2.0, "start": -1.0},
              {"path": "scene.calibration", "lower": 1.0, "upper": 10.0}]
    path = _sensitivity_config(tmp_path, sigma=0.03, parameters=params)
    run = calibrate(prepare(load_config(path), path), tmp_path)
    out = run.outcome
    assert out.determined == (True, False) and out.calibrated and out.state == "converged"
    assert math.isinf(out.std[1]) and out.uncertainty[0] <= 0.25 * 6.0
    text = (tmp_path / "calibrated.yaml").read_text()
    head = text.splitlines()
    assert head[0].startswith("# CALIBRATED MODEL in material.wall_slope only") and "NOT DETERMINED" in head[0]
    assert "scene.calibration." in head[0]
    assert any(ln.startswith("#   scene.calibration = ") and "NOT DETERMINED" in ln for ln in head)
    assert any(ln.startswith("#   material.wall_slope = ") and "(determined;" in ln for ln in head)
    assert head[1].startswith("# Written by") and out.chi2_high  # the model rises less than the law off the tip
    assert head[2].startswith(f"# MISFIT: chi2/dof = {out.chi2_per_dof:.4g} is above its limit")
    report = json.loads((tmp_path / "calibration.json").read_text())
    assert report["calibrated_parameters"] == ["material.wall_slope"]
    assert report["undetermined_parameters"] == ["scene.calibration"]
    assert [p["determined"] for p in report["parameters"]] == [True, False] and report["chi2_high"] is True

    loose = tmp_path / "loose"
    loose.mkdir()
    path = _sensitivity_config(loose, sigma=3.0, parameters=params[:1])
    out = calibrate(prepare(load_config(path), path), loose).outcome
    assert out.determined == (False,) and not out.calibrated and out.state == "no parameter determined"
    assert out.uncertainty[0] > 0.25 * 6.0 and math.isfinite(out.uncertainty[0])
    assert out.warnings()[0].startswith("not calibrated: the observations determine none of the parameters")
    text = (loose / "calibrated.yaml").read_text()
    assert text.startswith("# NOT CALIBRATED (no parameter determined)") and "CALIBRATED MODEL" not in text
    assert json.loads((loose / "calibration.json").read_text())["calibrated_model"] is False


def _wall_slope_config(folder: Path, start: float) -> Path:
    """docs/calibration.md's wall-law fit ([-4, 2] 1/MPa) on the thesis' restore and ratio data, beam model."""
    data = folder / "data"
    data.mkdir(exist_ok=True)
    for name in ("thesis_restore.csv", "thesis_sensitivity.csv"):
        shutil.copy(DATA / name, data / name)
    cal = {"source": "the thesis' prototype experiments", "model": "beam",
           "parameters": [{"path": "material.wall_slope", "lower": -4.0, "upper": 2.0, "start": start}],
           "measurements": [{"file": "data/thesis_restore.csv", "kind": "restore"},
                            {"file": "data/thesis_sensitivity.csv", "kind": "response"}],
           "holdout": ["pressurise_70_matches_65"], "restore_Q_max": 0.25, "restore_scan": 4,
           "max_evaluations": 60, "diff_step": 0.05}
    path = folder / f"cal_{start:g}.yaml"
    path.write_text(yaml.safe_dump({"material": {"wall_law": "calibrated"}, "calibration": cal}))
    return path


def test_the_wall_slope_fit_ends_at_the_same_value_from_0_and_from_minus_2(tmp_path):
    runs = {}
    for start in (0.0, -2.0):
        out_dir = tmp_path / f"out_{start:g}"
        out_dir.mkdir()
        path = _wall_slope_config(tmp_path, start)
        runs[start] = calibrate(prepare(load_config(path), path), out_dir).outcome
    a, b = runs[0.0], runs[-2.0]
    assert a.values[0] == pytest.approx(b.values[0], abs=a.tolerance * 6.0)
    assert a.cost == pytest.approx(b.cost, rel=a.tolerance)
    # the minimum of the cost over the box, on a grid of 0.05 /MPa where the beam model holds its pressures
    prepared = prepare(load_config(_wall_slope_config(tmp_path, 0.0)), _wall_slope_config(tmp_path, 0.0))
    problem = Problem(prepared.data, prepared.parameters, prepared.fitted, BeamSimulator(),
                      RestoreSearch(Q_max=0.25, scan=4), "grid")
    grid = np.arange(-3.9, 2.0 + 1e-9, 0.05)
    costs = np.array([0.5 * float(r @ r) for r in (problem.residuals_at([s]) for s in grid)])  # (n_grid,)
    k = int(np.argmin(costs))
    assert grid[k - 1] <= a.values[0] <= grid[k + 1] and a.cost <= costs[k] * (1 + a.tolerance)
    assert -2.7 < a.values[0] < -2.1 and a.determined == (True,) and a.calibrated  # with the files' σ (0.021, 0.03)
    # from 0 the fit from the start alone stays in another basin: reported, and the lower end taken
    assert [f.origin for f in a.starts] == ["the run file's start", "the scan's best point"]
    assert a.starts[0].cost > 2 * a.cost and abs(a.starts[0].values[0] - a.values[0]) > 2.0
    assert a.start_dependent and any(w.startswith("the result depends on where the fit starts") for w in a.warnings())
    text = (tmp_path / "out_0" / "calibrated.yaml").read_text()
    assert "# WARNING: the result depends on where the fit starts" in text
    # from -2 both local fits end in the same basin: no start-dependence
    assert not b.start_dependent and all(abs(f.values[0] - b.values[0]) < 0.06 for f in b.starts)
