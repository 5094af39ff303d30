"""`whisker-opt verify`: re-evaluating a run's best designs at another fidelity preset.

A tiny GA run on the coarse preset (serial, 3 individuals, 1 generation), then:
* verified at the run's own preset, every f1 and F_p is reproduced (to 1e-9: the
  evaluation is deterministic), which checks the wiring of genes, evaluator and penalty;
* verified at the default preset, f1 differs by the mesh error (non-zero, bounded), the CSV
  is written and the order of the run is reported;
* bad arguments and a non-run directory are user errors naming the field.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path

import pytest

from whisker_opt.cli import main as cli
from whisker_opt.output import storage
from whisker_opt.analysis.verify import format_rows, verify_run

CONFIG = """\
fidelity:
  preset: coarse
optimiser:
  trim: 5.0
  ga:
    population: 3
    n_elite: 1
    tournament: 2
  stopping:
    max_generations: 1
  executor:
    kind: serial
seed: 3
"""


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("verify")
    cfg = d / "tiny.yaml"
    cfg.write_text(CONFIG)
    out = d / "run"
    assert cli.main(["run", str(cfg), "--out", str(out), "--no-progress", "--verify", "coarse", "--verify-top", "1"]) == 0
    assert (out / "verify_coarse.csv").is_file()  # written by `run --verify`
    return out


def test_same_preset_reproduces_the_run(run_dir):
    rows = verify_run(run_dir, "coarse", top=2)
    assert len(rows) == 2
    for r in rows:
        assert r["status"] == "ok"
        assert math.isclose(r["f1_verify"], r["f1_run"], rel_tol=1e-9)
        assert math.isclose(r["F_p_verify"], r["F_p_run"], rel_tol=1e-9)
    assert [r["rank_verify"] for r in rows] == [1, 2]


def test_same_preset_is_warned(run_dir, caplog):
    with caplog.at_level(logging.INFO, logger="whisker_opt"):
        rows = verify_run(run_dir, "coarse", top=1, progress=False)
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any("coarse is the run's own preset" in m for m in warned), warned
    assert any(r.getMessage().startswith("verify: design 1/1 done") for r in caplog.records)  # a line per design
    scenes = [r.getMessage() for r in caplog.records if r.name == "whisker_opt.progress"]  # and per scene
    assert [m.split(" solved")[0] for m in scenes] == ["verify at coarse: scene 1/2 (design 1/1: intact scene",
                                                       "verify at coarse: scene 2/2 (design 1/1: trimmed scene"]
    assert all("; elapsed " in m and ", ETA " in m for m in scenes)
    text = format_rows(rows, "coarse")
    assert "WARNING: preset coarse is the run's own preset" in text and "--preset level4" in text  # the finest preset with a measured resolution
    assert "f1 resolution ~2e-3 at preset coarse" in text


def test_the_run_wrote_its_log(run_dir):
    text = (run_dir / "run.log").read_text()
    assert "at preset coarse (f1 resolution 0.002)" in text and "generation 0, evaluation 1/" in text


def test_finer_preset_writes_the_table(run_dir, capsys):
    assert cli.main(["verify", str(run_dir), "--preset", "default", "--top", "1"]) == 0
    out = capsys.readouterr().out
    assert "the run's order holds at preset default" in out
    assert "run's own preset" not in out and "~2e-3 at the run's preset coarse" in out
    rows = storage.read_csv(run_dir / "verify_default.csv")
    assert len(rows) == 1 and rows[0]["status"] == "ok"
    change = float(rows[0]["f1_change"])
    print("f1 default vs coarse:", change)
    assert 1e-6 < abs(change) < 0.5  # a different mesh, the same physics


def test_bad_arguments_are_user_errors(run_dir, tmp_path, capsys):
    assert cli.main(["verify", str(run_dir), "--top", "0"]) == 2
    assert "top=0" in capsys.readouterr().err
    assert cli.main(["verify", str(tmp_path)]) == 2
    assert "config.yaml" in capsys.readouterr().err
    assert cli.main(["run", str(Path(__file__).resolve().parents[1] / "configs" / "demo.yaml"), "--out", str(tmp_path / "r"), "--verify", "fine",
                     "--verify-top", "0"]) == 2  # refused before the run starts
    assert "top=0" in capsys.readouterr().err and not (tmp_path / "r").exists()
