"""Checkpoints that parse but cannot be bred on: one line naming the file, exit status 2, nothing written.

A tiny run of the analytic fitness (:mod:`tests.analytic_fitness`) is made once; each case edits a copy
of its ``checkpoint.json`` by hand and runs ``report``, ``verify`` or ``resume`` in-process:

* an integer of more than Python's 4300 digits read from text (was: a ``ValueError`` traceback);
* an individual whose gene vector is shorter or longer than the run's genome, or whose gene is NaN,
  1e300 or outside its bounds (was: an ``IndexError`` traceback after ``best.json`` was rewritten, or
  1e300 bred on silently), in the population or the hall of fame;
* ``resume --allow-config-change`` after a gene was added to ``optimiser.genes`` (was: ``IndexError``).

A gene outside the current bounds after an allowed change of them is legal (it was bred under the old
bounds) and is read.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml

from tests.analytic_fitness import AnalyticFitness
from tests.folder_helpers import folder_contents as _digest, use_analytic_fitness
from whisker_opt import wiring
from whisker_opt.cli import main as cli
from whisker_opt.config.model import dump_config, load_config
from whisker_opt.optimise.checkpoint import CHECKPOINT_NAME, load_checkpoint
from whisker_opt.optimise.runner import run_optimisation

RUN_FILE = """\
fidelity:
  preset: coarse
optimiser:
  trim: 2.0
  ga:
    population: 4
    n_elite: 1
  stopping:
    max_generations: 1
    target_fp: 0.0
    stall_generations: 100
seed: 5
output:
  results_dir: {results}
"""


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    """A finished run directory of the analytic fitness (generations 0 and 1), with its config.yaml."""
    root = tmp_path_factory.mktemp("state_validation")
    path = root / "run.yaml"
    path.write_text(RUN_FILE.format(results=root / "results"))
    cfg = load_config(path)
    d = root / "run"
    d.mkdir()
    (d / "config.yaml").write_text(dump_config(cfg))
    run_optimisation(wiring.optimiser_of(cfg), d, AnalyticFitness(), seed=5, progress=False,
                     run_config=cfg.model_dump(mode="json"))
    return d


@pytest.fixture
def analytic(monkeypatch):
    """In this process: the commands evaluate the analytic fitness and do not re-solve the best design."""
    use_analytic_fitness(monkeypatch)


def _copy(run: Path, tmp_path: Path, edit=None) -> Path:
    """A copy of the run whose checkpoint document went through ``edit(doc)`` (no previous checkpoint kept)."""
    d = tmp_path / "copy"
    shutil.copytree(run, d)
    (d / "checkpoint.prev.json").unlink(missing_ok=True)
    if edit is not None:
        doc = json.loads((d / CHECKPOINT_NAME).read_text())
        edit(doc)
        (d / CHECKPOINT_NAME).write_text(json.dumps(doc))
    return d


def _refused(capsys, command: str, d: Path, *words: str) -> str:
    before = _digest(d)
    extra = {"resume": ["--no-progress", "--max-generations", "3"], "verify": ["--preset", "coarse", "--top", "1"]}
    code = cli.main([command, str(d), *extra.get(command, [])])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert code == 2, (code, err)
    assert len(err) == 1 and "Traceback" not in err[0], err
    assert err[0].startswith(f"whisker-opt {command}: error: ") and f"{CHECKPOINT_NAME}" in err[0], err
    for w in words:
        assert w in err[0], (w, err[0])
    assert _digest(d) == before  # nothing written
    return err[0]


def _genes(doc: dict, group: str = "population", i: int = 0) -> list:
    s = doc["state"]
    return (s["population"] if group == "population" else s["hof"]["items"])[i]["genes"]


def _huge_int(doc: dict) -> None:
    doc["state"]["n_evaluations"] = "@HUGE@"


@pytest.mark.parametrize("command", ["report", "verify", "resume"])
def test_an_integer_of_over_4300_digits_is_refused(run, tmp_path, capsys, analytic, command):
    d = _copy(run, tmp_path, _huge_int)
    path = d / CHECKPOINT_NAME
    path.write_text(path.read_text().replace('"@HUGE@"', "9" * 5000))
    _refused(capsys, command, d, "not a whisker-opt checkpoint", "too long to read", "4300 digits")


GENE_CASES = {
    "short": (lambda doc: _genes(doc).pop(), ["population[0] has 3 genes", "genome has 4 (alpha, l, t, Q_i)"]),
    "long": (lambda doc: _genes(doc, "hof").append(3.0), ["hof[0] has 5 genes", "genome has 4"]),
    "nan": (lambda doc: _genes(doc).__setitem__(1, {"$": "float", "v": "nan"}), ["population[0] gene 1 (l)", "nan"]),
    "1e300": (lambda doc: _genes(doc, "population", 2).__setitem__(2, 1e300),
              ["population[2] gene 2 (t) is 1e+300", "outside its bounds [2, 6]", "optimiser.genes.t"]),
    "above": (lambda doc: _genes(doc, "hof").__setitem__(3, 0.25),
              ["hof[0] gene 3 (Q_i) is 0.25", "outside its bounds [0.01, 0.2]"]),
}


@pytest.mark.parametrize("case", sorted(GENE_CASES))
@pytest.mark.parametrize("command", ["report", "resume"])
def test_individuals_off_the_genome_are_refused(run, tmp_path, capsys, analytic, command, case):
    edit, words = GENE_CASES[case]
    _refused(capsys, command, _copy(run, tmp_path, edit), *words)


def test_a_gene_outside_bounds_changed_since_it_was_bred_is_read(run, tmp_path):
    def edit(doc):
        _genes(doc, "hof").__setitem__(3, 0.25)  # inside Q_i's range [0, 1] MPa
        doc["state"]["extra"]["config_changes"] = [{"after_generation": 0, "differences": ["..."]}]

    state, _ = load_checkpoint(_copy(run, tmp_path, edit))
    assert state.hof[0][3] == 0.25

    def beyond(doc):
        edit(doc)
        _genes(doc, "hof").__setitem__(3, 2.0)

    with pytest.raises(ValueError, match=r"hof\[0\] gene 3 \(Q_i\) is 2, outside the allowed range \[0, 1\]"):
        load_checkpoint(_copy(run, tmp_path / "beyond", beyond))


def test_resume_refuses_a_genome_changed_by_an_allowed_config_change(run, tmp_path, capsys, analytic):
    d = _copy(run, tmp_path)
    cfg = yaml.safe_load((d / "config.yaml").read_text())
    cfg["optimiser"]["genes"]["fibre_pitch"] = [2.0, 4.0]
    (d / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    before = _digest(d)
    code = cli.main(["resume", str(d), "--no-progress", "--max-generations", "3", "--allow-config-change"])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0], (code, err)
    for w in ("config.yaml", "optimiser.genes", "(alpha, l, t, Q_i, fibre_pitch)", "another genome"):
        assert w in err[0], (w, err[0])
    assert _digest(d) == before


# ----------------------------------------------------------------------------- the checkpoint's config
def test_report_refuses_the_checkpoint_of_another_config(run, tmp_path, capsys):
    """A checkpoint copied in from a run of another seed, or a config.yaml edited since: one line, nothing written."""
    other = tmp_path / "other"
    other.mkdir()
    cfg = load_config(run / "config.yaml", settings=("seed=6",))
    run_optimisation(wiring.optimiser_of(cfg), other, AnalyticFitness(), seed=6, progress=False,
                     run_config=cfg.model_dump(mode="json"))
    d = _copy(run, tmp_path)
    shutil.copy(other / CHECKPOINT_NAME, d / CHECKPOINT_NAME)
    line = _refused(capsys, "report", d, "written under another config than", "seed: 6 -> 5", "another run's")
    assert "config.yaml" in line
    edited = _copy(run, tmp_path / "edited")
    (edited / "config.yaml").write_text((edited / "config.yaml").read_text().replace("seed: 5", "seed: 7"))
    _refused(capsys, "report", edited, "seed: 5 -> 7", "whisker-opt resume", "--allow-config-change")


def test_report_reads_a_checkpoint_of_the_same_config_in_another_layout(run, tmp_path, capsys):
    d = _copy(run, tmp_path)
    doc = yaml.safe_load((d / "config.yaml").read_text())
    (d / "config.yaml").write_text(yaml.safe_dump(dict(reversed(list(doc.items()))), sort_keys=False))
    assert cli.main(["report", str(d)]) == 0
    assert "best design" in capsys.readouterr().out
