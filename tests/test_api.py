"""The public Python API: config from a mapping, version, lazy import, reading a run back."""

from __future__ import annotations

import dataclasses
import doctest
import math
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest
import yaml

import whisker_opt
from whisker_opt import api
from whisker_opt.config.model import ConfigError, WhiskerConfig

REPO = Path(__file__).resolve().parents[1]

DATA = {
    "design": {"alpha": 4.0, "l": 12.0},
    "scene": {"Q_i": 0.1, "trim": 5.0, "deflection": 5.0},
    "fidelity": {"preset": "coarse"},
    "optimiser": {"ga": {"population": 4, "n_elite": 1}, "stopping": {"max_generations": 1},
                  "executor": {"kind": "serial"}},
    "seed": 3,
}


def test_load_config_from_a_mapping_equals_the_yaml_file(tmp_path):
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump(DATA))
    from_dict, from_yaml = api.load_config(DATA), api.load_config(path)
    assert isinstance(from_dict, WhiskerConfig)
    assert from_dict == from_yaml == api.load_config(str(path))
    assert api.load_config(from_dict) is from_dict
    assert api.load_config({}) == WhiskerConfig()


@pytest.mark.parametrize(("data", "words"), [
    ({"design": {"alpah": 3.0}}, "design.alpah: unknown key"),
    ({"design": {"t": -1.0}}, "design.t"),
    ({"optimiser": {"ga": {"population": 1}}}, "optimiser.ga.population"),
])
def test_load_config_from_a_bad_mapping_names_the_key(data, words):
    with pytest.raises(ConfigError, match=words):
        api.load_config(data)


def test_load_config_refuses_other_types():
    with pytest.raises(ConfigError, match="mapping"):
        api.load_config([("design", {})])


def test_version():
    try:
        expected = metadata.version("whisker-opt")
    except metadata.PackageNotFoundError:
        expected = "0+unknown"
    assert whisker_opt.__version__ == expected
    assert isinstance(expected, str) and expected


def test_import_is_lazy():
    code = ("import whisker_opt, sys; print('numpy' in sys.modules, 'whisker_opt.api' in sys.modules); "
            "whisker_opt.load_config; print('whisker_opt.api' in sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["False", "False", "True"]


def test_package_exposes_the_api():
    assert set(whisker_opt.__all__) == {*api.__all__, "__version__"}
    for name in api.__all__:
        assert getattr(whisker_opt, name) is getattr(api, name)
        assert getattr(api, name).__doc__, name
    assert set(whisker_opt.__all__) <= set(dir(whisker_opt))
    with pytest.raises(AttributeError, match="no_such_name"):
        whisker_opt.no_such_name  # noqa: B018


def test_docstring_examples():
    result = doctest.testmod(api, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0 and result.failed == 0


def test_evaluate_names_missing_genes():
    cfg = api.load_config(DATA)
    with pytest.raises(ValueError, match="missing"):
        api.evaluate(cfg, {"alpha": 4.0, "l": 12.0, "t": 3.0})
    with pytest.raises(ValueError, match="expected 4 genes"):
        api.evaluate(cfg, [4.0, 12.0])


def test_simulate_refuses_a_bad_pair_before_creating_a_directory(tmp_path):
    cfg = api.load_config({"scene": {"trim": 0.0}, "output": {"results_dir": str(tmp_path)}})
    with pytest.raises(ConfigError, match="scene.trim"):
        api.simulate(cfg)
    assert list(tmp_path.iterdir()) == []


def test_load_run_of_a_tiny_run(tmp_path):
    data = {**DATA, "optimiser": {"ga": {"population": 2, "n_elite": 1}, "stopping": {"max_generations": 0},
                                  "executor": {"kind": "serial"}},
            "output": {"results_dir": str(tmp_path), "name": "tiny"}}
    cfg = api.load_config(data)
    summary = api.run(cfg)  # no out: a new run directory under output.results_dir
    assert summary.run_dir.parent == tmp_path and summary.run_dir.name.startswith("tiny-run-")

    res = whisker_opt.load_run(summary.run_dir)
    assert isinstance(res, api.RunResults)
    assert res.run_dir == summary.run_dir
    assert res.config == cfg
    assert res.stop_reason == summary.stop_reason
    assert res.best["genes"] == res.best_genes == pytest.approx(summary.best["genes"])
    assert len(res.evaluations) == 2 and len(res.generations) == 1
    ev = res.evaluations[0]
    assert isinstance(ev["eval_id"], int) and isinstance(ev["generation"], int)
    assert isinstance(ev["alpha"], float) and isinstance(ev["time_s"], float)
    assert isinstance(ev["status"], str) and isinstance(ev["cache_hit"], bool)
    assert ev["status"] != "ok" or (isinstance(ev["f1"], float) and math.isfinite(ev["f1"]))
    gen = res.generations[0]
    assert gen["generation"] == 0 and gen["evals"] == 2
    assert gen["best_fp"] == pytest.approx(summary.best["F_p"])
    with pytest.raises(dataclasses.FrozenInstanceError):
        res.stop_reason = "other"  # type: ignore[misc]


def test_load_run_of_a_directory_that_is_not_a_run(tmp_path):
    with pytest.raises(FileNotFoundError, match="run directory"):
        api.load_run(tmp_path)


def test_cells_are_converted():
    cells = [api._cell(s) for s in ("3", "-1", "0.5", "1e-3", "True", "False", "", "ok")]
    assert cells == [3, -1, 0.5, 1e-3, True, False, None, "ok"]
    assert [type(c) for c in cells[:4]] == [int, int, float, float]
    assert math.isnan(api._cell("nan"))


@pytest.mark.parametrize("call, match", [
    (lambda wo, cfg: wo.evaluate({"fidelity": {}}, {"alpha": 4.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}),
     "evaluate: cfg is a dict, not a loaded config"),
    (lambda wo, cfg: wo.simulate({}), "simulate: cfg is a dict, not a loaded config"),
    (lambda wo, cfg: wo.run([1]), "run: cfg is a list, not a loaded config"),
])
def test_an_unloaded_config_is_the_projects_config_error(call, match):
    import whisker_opt as wo
    from whisker_opt.config.model import ConfigError

    with pytest.raises(ConfigError, match=match):
        call(wo, None)


@pytest.mark.parametrize("genes", [None, "alpha", 3.0])
def test_genes_of_no_shape_are_a_one_line_value_error(genes):
    import whisker_opt as wo

    cfg = wo.load_config({"fidelity": {"preset": "coarse"}})
    with pytest.raises(ValueError, match=r"evaluate: genes=.*: expected a mapping"):
        wo.evaluate(cfg, genes)
