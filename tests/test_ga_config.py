"""The optimiser config: the thesis' defaults, and malformed sections give one error naming the key."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from whisker_opt.config.model import ConfigError, format_validation_error, load_config
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.genes import GENE_NAMES


def _error_text(data: dict) -> str:
    with pytest.raises(ValidationError) as info:
        OptimiserConfig.model_validate(data)
    return format_validation_error(info.value, "optimiser")


def test_defaults_reproduce_spec_section_6():
    cfg = OptimiserConfig()
    assert cfg.genes.bounds() == ((2.5, 6.0), (10.0, 15.0), (2.0, 6.0), (0.01, 0.2))
    assert [(p.gene, p.prefer, p.weight) for p in cfg.penalties] == [
        ("Q_i", "low", 0.5), ("t", "high", 0.2), ("alpha", "low", 0.2)
    ]
    assert cfg.ga.population == 50 and cfg.ga.tournament == 2 and 0 < cfg.ga.n_elite < 50
    st = cfg.stopping
    assert (st.max_generations, st.target_fp, st.stall_generations, st.stall_tol) == (50, 1e-3, 20, 1e-9)
    assert cfg.trim == 5.0
    assert cfg.executor.kind == "serial"
    assert GENE_NAMES == ("alpha", "l", "t", "Q_i")


def test_bounds_accept_pairs_and_mappings():
    cfg = OptimiserConfig.model_validate({"genes": {"alpha": [3, 5], "Q_i": {"lo": 0.02, "hi": 0.1}}})
    assert cfg.genes.alpha.lo == 3 and cfg.genes.alpha.hi == 5
    assert cfg.genes.Q_i.hi == 0.1


@pytest.mark.parametrize(
    "data, key, words",
    [
        ({"ga": {"populaton": 10}}, "ga.populaton", "unknown key"),
        ({"stoping": {}}, "stoping", "unknown key"),
        ({"genes": {"alpha": {"lo": 6.0, "hi": 2.5}}}, "genes.alpha", "inverted"),
        ({"genes": {"t": [4, 4]}}, "genes.t", "inverted"),
        ({"genes": {"Q_i": [0.01, 2.0]}}, "genes.Q_i.hi", "2.0 is outside the allowed range (0, 1] (MPa)"),
        ({"ga": {"population": -5}}, "ga.population", "-5 is outside 2..10000"),
        ({"ga": {"population": 4, "n_elite": 4}}, "ga", "n_elite=4"),
        ({"stopping": {"max_generations": "many"}}, "stopping.max_generations", "expected an integer in 0..100000"),
        ({"penalties": [{"gene": "t", "prefer": "high", "weight": 0.2}] * 2}, "penalties", "repeated"),
        ({"penalties": [{"gene": "E", "prefer": "low", "weight": 0.2}]}, "penalties.0.gene", "alpha"),
        ({"executor": {"kind": "mpi"}}, "executor.kind", "serial"),
        ({"executor": {"scheduler_address": "tcp://h:8786"}}, "executor", "only used with kind 'dask'"),
        ({"executor": {"timeout_s": -1}}, "executor.timeout_s", "-1 is outside the allowed range (0, 604800] (s)"),
    ],
)
def test_malformed_sections_name_the_key(data, key, words):
    text = _error_text(data)
    assert f"optimiser: {key}:" in text, text
    assert words in text, text


def test_yaml_run_file_with_bad_optimiser_section_is_refused(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("optimiser:\n  ga:\n    population: -3\n")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert "population" in str(info.value)
    ok = tmp_path / "ok.yaml"
    ok.write_text("seed: 4\noptimiser:\n  ga: {population: 8}\n  stopping: {max_generations: 3}\n")
    cfg = load_config(ok)
    opt = OptimiserConfig.model_validate(cfg.optimiser)
    assert opt.ga.population == 8 and opt.resolve_seed(cfg.seed) == 4
    assert OptimiserConfig(seed=11).resolve_seed(4) == 11


def test_config_is_frozen_and_roundtrips():
    cfg = OptimiserConfig.model_validate({"ga": {"population": 12}, "executor": {"kind": "dask", "n_workers": 2}})
    with pytest.raises(ValidationError):
        cfg.ga.population = 3  # type: ignore[misc]
    again = OptimiserConfig.model_validate(cfg.model_dump(mode="json"))
    assert again == cfg


def test_renamed_keys_are_read_with_a_deprecation_warning_and_both_forms_refused():
    import pytest as _pytest

    from whisker_opt.config.model import WhiskerConfig

    old = {"optimiser": {"delta_max": 4.0}, "scene": {"Q": 0.1, "delta_max": 3.0}, "design": {"alpha_deg": 3.5}}
    with _pytest.warns(DeprecationWarning, match=r"optimiser\.delta_max.*optimiser\.trim"):
        cfg = WhiskerConfig.model_validate(old)
    assert (cfg.optimiser.trim, cfg.scene.Q_i, cfg.scene.deflection, cfg.design.alpha) == (4.0, 0.1, 3.0, 3.5)
    new = WhiskerConfig.model_validate({"optimiser": {"trim": 4.0}, "scene": {"Q_i": 0.1, "deflection": 3.0},
                                        "design": {"alpha": 3.5}})
    assert new == cfg
    with _pytest.raises(ValueError, match="old name of 'trim'"):
        WhiskerConfig.model_validate({"optimiser": {"delta_max": 4.0, "trim": 4.0}})
