"""Older bad inputs, each refused in one line naming the field, the value and what is allowed (or, for ``~`` in
``output.results_dir`` and ``init DIR/``, read as a user means them)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tests.test_rundir_safety import _analytic_run_dir
from whisker_opt.cli.main import main
from whisker_opt.config.model import ConfigError, WhiskerConfig, load_config


def _one_line(capsys, rc: int, command: str, *words: str) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.startswith("whisker-opt ")]
    assert rc == 2 and "Traceback" not in err and len(lines) == 1, (rc, err)
    assert lines[0].startswith(f"whisker-opt {command}: error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def _config(tmp_path: Path, text: str):
    path = tmp_path / "c.yaml"
    path.write_text(text)
    return load_config(path)


@pytest.mark.parametrize("column, value, words", [
    ("delta", "1_5", ["column delta", "'1_5' is not a number", "no '_' between digits"]),
    ("eps", "1e308", ["column eps", "1e308 is outside the allowed range [-1, 1]"]),
])
def test_a_measurement_file_refuses_underscores_and_an_impossible_strain(tmp_path, capsys, column, value, words):
    from tests.test_calibration import _config as calibration_config, _write_data

    _write_data(tmp_path)
    resp = tmp_path / "data" / "resp.csv"
    lines = resp.read_text().splitlines()
    header, row = lines[0].split(","), lines[1].split(",")
    row[header.index(column)] = value
    resp.write_text("\n".join([lines[0], ",".join(row), *lines[2:]]) + "\n")
    out = tmp_path / "out"
    _one_line(capsys, main(["calibrate", str(calibration_config(tmp_path)), "--out", str(out)]), "calibrate",
              "resp.csv: row 1 (line 2)", *words)
    assert not out.exists()


@pytest.mark.parametrize("text, words", [
    ('output:\n  name: "run\\nrm -rf"\n', ["output.name", "line break", "one line"]),
    ("output:\n  name: !!binary aGVsbG8=\n", ["output.name", "!!binary", "binary data"]),
    ("seed: !!binary aGVsbG8=\n", ["seed", "0..4294967295", "binary data"]),
    ('output:\n  results_dir: "~nosuchuser9/res"\n', ["output.results_dir", "'~nosuchuser9' names no home folder"]),
    ("calibration:\n  source: x\n  parameters:\n    - {path: seed, lower: 1, upper: 2}\n",
     ["calibration.parameters.0.path", "'seed' is not the dotted path", "material.C10"]),
])
def test_run_file_values_refused_in_one_line(tmp_path, text, words):
    with pytest.raises(ConfigError) as exc:
        _config(tmp_path, text)
    msg = str(exc.value)
    assert "\n" not in msg and "Input should" not in msg and "String should" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_a_home_folder_in_results_dir_is_expanded(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert _config(tmp_path, 'output:\n  results_dir: "~/res"\n').output.results_dir == tmp_path / "home" / "res"
    assert _config(tmp_path, "output:\n  results_dir: res~\n").output.results_dir == Path("res~")


def test_an_empty_config_path_is_named():
    with pytest.raises(ConfigError, match=r"^config path: '' is empty; give the path of a YAML run file$"):
        load_config("")


@pytest.mark.parametrize("genes", [{"alpha": "3", "l": 12.0, "t": 3.0, "Q_i": 0.1}, [3.0, 12.0, True, 0.1]])
def test_the_api_refuses_a_gene_that_is_not_a_number(genes):
    from whisker_opt import api

    name, value = ("alpha", "'3'") if isinstance(genes, dict) else ("t", "True")
    with pytest.raises(ValueError, match=rf"genes\['{name}'\] is {value} .*a gene is a real number"):
        api.evaluate(WhiskerConfig(), genes)


def test_init_into_a_folder_given_with_a_slash(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["init", "new/"]) == 0
    assert (tmp_path / "new" / "whisker.yaml").is_file() and load_config(tmp_path / "new" / "whisker.yaml")
    assert main(["init", "new/"]) == 2  # there now: refused without --force
    capsys.readouterr()
    _one_line(capsys, main(["init", "new"]), "init", "new: is a folder", "new/whisker.yaml")


def test_resume_from_previous_refuses_to_roll_back_a_good_checkpoint(tmp_path, capsys):
    run_dir = _analytic_run_dir(tmp_path)
    assert (run_dir / "checkpoint.prev.json").is_file()
    before = {p.name: p.read_bytes() for p in run_dir.iterdir()}
    _one_line(capsys, main(["resume", str(run_dir), "--from-previous", "--no-progress"]), "resume",
              "--from-previous", "checkpoint.json is not damaged", "generation 3", f"`whisker-opt resume {run_dir}`")
    assert {p.name: p.read_bytes() for p in run_dir.iterdir()} == before


@pytest.mark.parametrize("column, value, words", [
    ("length", "0.0001", ["column length: 0.0001 is outside the allowed range [20, 70] mm", "design.l = 15"]),
    ("length", "19.5", ["column length: 19.5 is outside the allowed range [20, 70] mm"]),
    ("trim", "60", ["column trim: 60 is outside the allowed range [0, 50] mm", "design.L = 70"]),
])
def test_a_measured_length_that_leaves_no_whisker_names_its_row(tmp_path, capsys, column, value, words):
    from tests.test_calibration import _config as calibration_config, _write_data

    _write_data(tmp_path)
    resp = tmp_path / "data" / "resp.csv"
    lines = resp.read_text().splitlines()
    header, row = lines[0].split(","), lines[2].split(",")
    header[header.index("length")] = column
    row[header.index(column)] = value
    resp.write_text("\n".join([",".join(header), lines[1] if column == "length" else lines[1].rsplit(",", 1)[0] + ",0",
                               ",".join(row), *lines[3:]]) + "\n")
    out = tmp_path / "out"
    _one_line(capsys, main(["calibrate", str(calibration_config(tmp_path)), "--out", str(out)]), "calibrate",
              "resp.csv: row 2 (line 3)", *words)
    assert not out.exists()


@pytest.mark.parametrize("genes, words", [
    ({"alpha": 3.0, "l": 12.0, "t": 3.0, "Q_i": -0.1}, ["genes['Q_i'] = -0.1", "[0, 1] MPa", "scene.Q_i"]),
    ([3.0, 12.0, 3.0, 1.5], ["genes['Q_i'] = 1.5", "[0, 1] MPa"]),
    ([3.0, 12.0, 3.0, float("nan")], ["genes['Q_i'] = nan", "[0, 1] MPa"]),
    ({"alpha": -3.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}, ["genes['alpha'] = -3.0", "[0, 45) deg", "design.alpha"]),
])
def test_the_api_refuses_a_gene_outside_its_keys_range(genes, words):
    from whisker_opt import api

    with pytest.raises(ValueError) as exc:
        api.evaluate(WhiskerConfig(), genes)
    msg = str(exc.value)
    assert "\n" not in msg and "SceneSpec" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


@pytest.mark.parametrize("Q", [-0.1, 1.5, float("nan")])
def test_a_scene_refuses_a_pressure_outside_the_range_of_scene_q_i(Q):
    import whisker_opt.wiring as wiring
    from whisker_opt.experiment.spec import SceneSpec

    with pytest.raises(ValueError, match=r"^SceneSpec\.Q=.*: must be in the allowed range \[0, 1\] MPa"):
        SceneSpec(wiring.design_from_config(WhiskerConfig()), Q=Q)


def _direct(build):
    """The message of a config model validated directly from Python."""
    from pydantic import ValidationError

    with pytest.raises(ConfigError) as exc:
        build()
    assert isinstance(exc.value, ValidationError)  # still pydantic's error for code that catches it
    return str(exc.value)


@pytest.mark.parametrize("build, words", [
    (lambda g: g.GenesConfig.model_validate({"alpha": "x"}), ["optimiser.genes.alpha: expected [lo, hi]", "'x'"]),
    (lambda g: g.GenesConfig(alpha=3), ["optimiser.genes.alpha: expected [lo, hi]", "got 3"]),
    (lambda g: g.GenesConfig(alpha=g.AlphaBounds(), l=g.AlphaBounds()),
     ["optimiser.genes.l", "got a section {'hi': 6.0, 'lo': 2.5}"]),
    (lambda g: g.GenesConfig.model_validate({"fibre_pitch": "abc"}), ["gene fibre_pitch: expected [lo, hi]"]),
    (lambda g: g.GenesConfig.model_validate({"fibre_pitch": [1, "a"]}), ["gene fibre_pitch: hi: expected a number"]),
    (lambda g: g.OptimiserConfig(genes=3), ["optimiser.genes: expected a mapping", "got 3"]),
    (lambda g: g.OptimiserConfig(wall_laws={"laws": "x"}), ["optimiser.wall_laws.laws: expected a list"]),
    (lambda g: WhiskerConfig(scene={"Q_i": -0.1}), ["scene.Q_i: -0.1 is outside the allowed range [0, 1] (MPa)"]),
    (lambda g: WhiskerConfig(optimiser=g.GenesConfig()), ["optimiser: expected a mapping", "got a section"]),
])
def test_config_models_validated_from_python_name_key_paths_not_classes(build, words):
    import whisker_opt.config.optimiser as g

    msg = _direct(lambda: build(g))
    assert "\n" not in msg and "Bounds" not in msg and "Config" not in msg and "instance of" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_a_run_file_shows_a_section_given_in_python_by_its_keys():
    from whisker_opt import api
    from whisker_opt.config.optimiser import AlphaBounds

    with pytest.raises(ConfigError) as exc:
        api.load_config({"optimiser": {"genes": {"fibre_pitch": "abc", "l": AlphaBounds()}}})
    assert "GeneBounds" not in str(exc.value) and "AlphaBounds" not in str(exc.value), str(exc.value)


def test_a_ratio_of_readings_may_exceed_one_but_not_a_thousand(tmp_path):
    from whisker_opt.calibration.measurements import MeasurementError, read_measurements

    path = tmp_path / "ratio.csv"
    path.write_text("a,Q,ref_Q,delta,eps,sigma\n1,0.2,0,1,1.367,0.03\n")
    (ob,) = read_measurements(path, "response", length_L=70.0)
    assert ob.eps == 1.367 and ob.unit == "-"
    path.write_text("a,Q,ref_Q,delta,eps,sigma\n1,0.2,0,1,1e5,0.03\n")
    with pytest.raises(MeasurementError, match=r"row 1 \(line 2\), column eps: 1e5 is outside the allowed range "
                                               r"\[-1000, 1000\] \(a ratio of two readings, with ref_Q\)"):
        read_measurements(path, "response", length_L=70.0)
