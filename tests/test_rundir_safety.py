"""A run directory that is safe to share and to upgrade, with one writer at a time and its config as part of its state.

* The checkpoint is JSON data of a versioned format: it reads back bit for bit (GA and NSGA-II
  states, RNG states included), and a crafted pickle in place of the state is refused by every
  command without being loaded (it would create a file).
* A run directory of the previous format (a pickled ``checkpoint.pkl``, built here as the
  previous version wrote it) is refused with a message naming the format and what to do, and,
  once converted on the user's word (``--trust-pickle``), resumes to the uninterrupted result.
* One writer per run directory: two concurrent ``run``s or ``resume``s into one folder, the
  second refuses in one line naming the holder and the first completes; a second ``run`` into a
  finished run's folder refuses and leaves it as it was unless ``--overwrite`` is given.
* ``resume`` refuses a run whose ``config.yaml`` was edited, unless ``--allow-config-change``,
  which the report, ``best.json`` and ``run.log`` then record.

The commands run on the analytic fitness (:mod:`tests.analytic_fitness`) in place of the FE
evaluator, and without re-solving the best design's meshes, so that every run takes seconds.
"""

from __future__ import annotations

import dataclasses
import json
import os
import pickle
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.analytic_fitness import AnalyticFitness, FailureRegion, Hold
from tests.folder_helpers import folder_hash as _digest, one_line_refusal as _one_line, use_analytic_fitness
from whisker_opt import wiring, workflows
from whisker_opt.cli import main as cli
from whisker_opt.config.optimiser import OptimiserConfig
from whisker_opt.optimise.checkpoint import (
    CHECKPOINT_NAME,
    OLDER_NAME,
    PREVIOUS_NAME,
    OlderFormatError,
    convert_older_checkpoint,
    load_checkpoint,
)
from whisker_opt.optimise.runner import resume_optimisation, run_optimisation
from whisker_opt.optimise.statefile import decode, encode
from whisker_opt.output import storage
from whisker_opt.output.lock import LOCK_NAME, RunDirectoryBusy, RunDirLock, read_holder

REPO = Path(__file__).resolve().parents[1]

RUN_FILE = """\
fidelity:
  preset: coarse
scene:
  Q_i: 0.1
  trim: 5.0
optimiser:
  trim: 2.0
  ga:
    population: 6
    n_elite: 1
  stopping:
    max_generations: {generations}
    target_fp: 0.0
    stall_generations: 100
  executor:
    kind: serial
seed: 5
output:
  results_dir: {results}
"""

#: A child ``whisker-opt`` on the analytic fitness; with ``HOLD`` set (the JSON of a :class:`Hold`), its
#: evaluations stop at that barrier, where the test finds it and releases or kills it.
CHILD = """
import json, os, sys
from whisker_opt import wiring, workflows
from tests.analytic_fitness import AnalyticFitness, Hold
hold = Hold(**json.loads(os.environ["HOLD"])) if os.environ.get("HOLD") else None
wiring.evaluator = lambda cfg, *a, **k: AnalyticFitness(hold=hold)
workflows.finish_best = lambda *a, **k: None
from whisker_opt.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.fixture
def analytic(monkeypatch):
    """In this process: the commands evaluate the analytic fitness and do not re-solve the best design."""
    use_analytic_fitness(monkeypatch)


def _run_file(tmp_path: Path, generations: int = 3) -> Path:
    path = tmp_path / "run.yaml"
    path.write_text(RUN_FILE.format(generations=generations, results=tmp_path / "results"))
    return path


def _evaluations(run_dir: Path) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "time_s"} for r in storage.read_csv(run_dir / storage.EVALUATIONS_CSV)]


def _complete(run_dir: Path, reference: Path) -> None:
    """``run_dir`` holds every result of a finished run, identical to ``reference``'s."""
    for name in ("config.yaml", storage.OPTIMISER_JSON, storage.ENVIRONMENT_JSON, CHECKPOINT_NAME,
                 storage.EVALUATIONS_CSV, storage.GENERATIONS_CSV, storage.BEST_JSON, "convergence.png"):
        assert (run_dir / name).is_file(), name
    assert not (run_dir / LOCK_NAME).exists()
    assert not [p.name for p in run_dir.iterdir() if storage.is_temporary(p.name)]
    assert _evaluations(run_dir) == _evaluations(reference)
    best, ref = (json.loads((d / storage.BEST_JSON).read_text()) for d in (run_dir, reference))
    assert (best["genes"], best["F_p"], best["stop_reason"]) == (ref["genes"], ref["F_p"], ref["stop_reason"])


def _child(argv: list[str], hold: Hold | None = None) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "HOLD": json.dumps(dataclasses.asdict(hold)) if hold else "", "OMP_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-c", CHILD, *argv], cwd=REPO, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _hold(tmp_path: Path, name: str, **kw) -> Hold:
    folder = tmp_path / name
    folder.mkdir()
    return Hold(str(folder), **kw)


# ----------------------------------------------------------------------------- the state as data
@pytest.mark.parametrize("algorithm", ["ga", "nsga2"])
def test_the_checkpoint_is_json_that_reads_back_bit_for_bit(tmp_path, algorithm):
    data = {"ga": {"population": 8}, "stopping": {"max_generations": 3, "target_fp": 0.0, "stall_generations": 100}}
    if algorithm == "nsga2":
        data.update(algorithm="nsga2", objectives=[{"name": "f1"}, {"name": "Q_i", "prefer": "low"}])
    run_optimisation(OptimiserConfig.model_validate(data), tmp_path, AnalyticFitness(
        failures=(FailureRegion("alpha", 5.5, "invalid_geometry"),)), seed=3, progress=False)
    raw = (tmp_path / CHECKPOINT_NAME).read_bytes()
    doc = json.loads(raw)  # plain JSON, versioned
    assert (doc["format"], doc["version"]) == ("whisker-opt GA state", 2)
    state, config = load_checkpoint(tmp_path)
    assert encode(state, config) == raw  # nothing lost or changed on the way back
    again, _ = decode(json.loads(encode(state, config)))
    assert again.rng_py == state.rng_py
    assert [again.rng_np[0], *again.rng_np[2:]] == [state.rng_np[0], *state.rng_np[2:]]
    assert (again.rng_np[1] == state.rng_np[1]).all() and again.rng_np[1].dtype == state.rng_np[1].dtype
    assert [(type(i).__name__, list(i), i.fitness.wvalues, i.info) for i in again.population] == \
        [(type(i).__name__, list(i), i.fitness.wvalues, i.info) for i in state.population]
    assert [i.fitness for i in again.hof.items][::-1] == again.hof.keys  # the hall of fame's own invariant
    assert again.cache.entries == state.cache.entries and again.records == state.records


# ----------------------------------------------------------------------------- hostile and older states
def _analytic_run_dir(tmp_path: Path, name: str = "run", interrupt_at: int | None = None) -> Path:
    """A run directory of the analytic fitness with a config.yaml (as ``whisker-opt run`` writes one)."""
    from whisker_opt.config.model import dump_config, load_config

    cfg = load_config(_run_file(tmp_path))
    run_dir = tmp_path / name
    run_dir.mkdir()
    (run_dir / "config.yaml").write_text(dump_config(cfg))

    def interrupt(state, row):
        if state.generation == interrupt_at:
            raise KeyboardInterrupt

    try:
        run_optimisation(wiring.optimiser_of(cfg), run_dir, AnalyticFitness(), seed=5, progress=False,
                         callbacks=[interrupt], run_config=cfg.model_dump(mode="json"))
    except KeyboardInterrupt:
        pass
    return run_dir


class _Payload:
    """Unpickling this creates a file (what a crafted checkpoint could do)."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return open, (str(self.marker), "w")


COMMANDS = [["report"], ["verify", "--preset", "coarse", "--top", "1"], ["resume", "--no-progress"],
            ["resume", "--no-progress", "--trust-pickle"], ["robustness", "--no-progress"]]


@pytest.mark.parametrize("name", [CHECKPOINT_NAME, OLDER_NAME])
@pytest.mark.parametrize("command", COMMANDS, ids=[" ".join(c) for c in COMMANDS])
def test_a_crafted_pickle_in_place_of_the_state_is_refused_unloaded(tmp_path, capsys, analytic, name, command):
    run_dir = _analytic_run_dir(tmp_path)
    marker = tmp_path / "pwned"
    payload = pickle.dumps({"format": 1, "config": _Payload(marker)}, protocol=pickle.HIGHEST_PROTOCOL)
    for p in (run_dir / CHECKPOINT_NAME, run_dir / PREVIOUS_NAME):
        p.unlink(missing_ok=True)
    (run_dir / name).write_bytes(payload)
    before = _digest(run_dir)
    line = _one_line(capsys, cli.main([command[0], str(run_dir), *command[1:]]), command[0])
    assert not marker.exists(), line
    assert _digest(run_dir) == before
    if "--trust-pickle" in command and name == OLDER_NAME:
        assert "cannot be converted" in line and "open is not part of a format-1 checkpoint" in line, line
    elif "--trust-pickle" in command:
        assert f"holds no {OLDER_NAME} of an earlier version" in line, line
    elif name == OLDER_NAME:
        assert "format 1" in line and "--trust-pickle" in line and "damaged" not in line, line
    else:
        assert "Python pickle" in line and "not loaded" in line, line


def _older_format(run_dir: Path) -> None:
    """Replace the checkpoint by a ``checkpoint.pkl`` as the previous version wrote it (format 1)."""
    state, config = load_checkpoint(run_dir)
    d = {"format": 1, "config": config, "seed": state.seed, "generation": state.generation,
         "population": state.population, "hof": state.hof, "logbook": state.logbook, "records": state.records,
         "cache": state.cache.to_state(), "rng_py": state.rng_py, "rng_np": state.rng_np,
         "n_evaluations": state.n_evaluations, "n_cache_hits": state.n_cache_hits, "n_failures": state.n_failures,
         "elapsed_s": state.elapsed_s, "stop_reason": state.stop_reason, "extra": state.extra}
    (run_dir / OLDER_NAME).write_bytes(pickle.dumps(d, protocol=pickle.HIGHEST_PROTOCOL))
    (run_dir / CHECKPOINT_NAME).unlink()
    (run_dir / PREVIOUS_NAME).unlink(missing_ok=True)


def test_a_run_directory_of_the_previous_format_is_refused_then_converted_on_trust(tmp_path, capsys, analytic):
    reference = _analytic_run_dir(tmp_path, "reference")
    run_dir = _analytic_run_dir(tmp_path, "older", interrupt_at=1)
    _older_format(run_dir)
    with pytest.raises(OlderFormatError, match="format 1"):
        load_checkpoint(run_dir)
    before = _digest(run_dir)
    for command in COMMANDS[:3] + COMMANDS[4:]:
        line = _one_line(capsys, cli.main([command[0], str(run_dir), *command[1:]]), command[0])
        assert "format 1" in line and "format 2" in line and "--trust-pickle" in line, line
        assert "damaged" not in line and "truncated" not in line, line
    assert _digest(run_dir) == before
    # `run` into it refuses too: it holds a run
    line = _one_line(capsys, cli.main(["run", str(_run_file(tmp_path)), "--out", str(run_dir)]), "run")
    assert "already holds a run" in line and OLDER_NAME in line, line
    # the user trusts it: converted, then resumed to the uninterrupted result
    assert convert_older_checkpoint(run_dir) == 1
    assert not (run_dir / OLDER_NAME).exists() and (run_dir / "checkpoint.format1.pkl").is_file()
    resumed = resume_optimisation(run_dir, AnalyticFitness(), progress=False)
    ref, _ = load_checkpoint(reference)
    assert resumed.generations == ref.generation and resumed.best["genes"] == json.loads(
        (reference / storage.BEST_JSON).read_text())["genes"]
    assert _evaluations(run_dir) == _evaluations(reference)


# ----------------------------------------------------------------------------- one writer
def test_the_lock_names_its_holder_and_is_gone_after_it(tmp_path):
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys; from whisker_opt.output.lock import RunDirLock\n"
                               "with RunDirLock(sys.argv[1], 'resume'):\n    print('locked', flush=True)\n"
                               "    sys.stdin.readline()\n", str(tmp_path)],  # holds it until killed
        cwd=REPO, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(RunDirectoryBusy, match=rf"`whisker-opt resume`, PID {holder.pid} on host "):
            RunDirLock(tmp_path, "run").acquire()
    finally:
        holder.send_signal(signal.SIGKILL)
        holder.wait(10)
    assert (tmp_path / LOCK_NAME).exists()  # a killed holder leaves its file, but not its lock
    with RunDirLock(tmp_path, "run"):
        with RunDirLock(tmp_path, "verify"):  # the same process may take it again
            pass
        assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    assert not (tmp_path / LOCK_NAME).exists()


def _second_refuses(argv: list[str], run_dir: Path, tmp_path: Path) -> tuple[subprocess.Popen, str]:
    """Start a writer, hold it in its first evaluation (it holds the lock then), start a second one and let
    the first go on once the second has ended.

    Returns the first (still running) and the second's one error line.
    """
    hold = _hold(tmp_path, "first")
    first = _child(argv, hold)
    try:
        hold.wait_held(first)
        assert read_holder(run_dir / LOCK_NAME).get("pid") == first.pid
        second = _child(argv)
        _, err = second.communicate(timeout=600)
    finally:
        hold.release()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert second.returncode == 2 and len(lines) == 1 and "Traceback" not in err, err
    return first, lines[0]


def test_two_concurrent_runs_into_one_folder(tmp_path, analytic):
    cfg = _run_file(tmp_path)
    assert cli.main(["run", str(cfg), "--out", str(tmp_path / "reference"), "--no-progress"]) == 0
    run_dir = tmp_path / "shared"
    first, line = _second_refuses(["run", str(cfg), "--out", str(run_dir), "--no-progress"], run_dir, tmp_path)
    assert f"{run_dir}: in use by `whisker-opt run`, PID {first.pid} on host" in line, line
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    _complete(run_dir, tmp_path / "reference")


def test_two_concurrent_resumes_of_one_run(tmp_path, analytic):
    cfg = _run_file(tmp_path)
    assert cli.main(["run", str(cfg), "--out", str(tmp_path / "reference"), "--no-progress"]) == 0
    run_dir = tmp_path / "killed"
    hold = _hold(tmp_path, "killed", run_dir=str(run_dir), generation=0)
    killed = _child(["run", str(cfg), "--out", str(run_dir), "--no-progress"], hold)
    hold.wait_held(killed)  # in generation 1, with generation 0 checkpointed and two to go
    killed.send_signal(signal.SIGKILL)
    killed.communicate(timeout=60)
    assert killed.returncode == -signal.SIGKILL and load_checkpoint(run_dir)[0].generation == 0
    first, line = _second_refuses(["resume", str(run_dir), "--no-progress"], run_dir, tmp_path)
    assert f"in use by `whisker-opt resume`, PID {first.pid} on host" in line, line
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err
    _complete(run_dir, tmp_path / "reference")


def test_a_second_run_into_a_finished_run_refuses_unless_overwrite(tmp_path, capsys, analytic):
    cfg = _run_file(tmp_path, generations=1)
    run_dir = tmp_path / "run"
    assert cli.main(["run", str(cfg), "--out", str(run_dir), "--no-progress"]) == 0
    capsys.readouterr()
    before = _digest(run_dir)
    line = _one_line(capsys, cli.main(["run", str(cfg), "--out", str(run_dir), "--no-progress"]), "run")
    assert "already holds a run" in line and "--overwrite" in line and "whisker-opt resume" in line, line
    assert _digest(run_dir) == before
    (run_dir / "verify_fine.csv").write_text("from the first run\n")
    assert cli.main(["run", str(cfg), "--out", str(run_dir), "--no-progress", "--overwrite"]) == 0
    assert not (run_dir / "verify_fine.csv").exists()  # the old run is gone, the new one complete
    assert (run_dir / CHECKPOINT_NAME).is_file() and (run_dir / storage.BEST_JSON).is_file()
    # a folder that holds no run is never emptied, --overwrite or not
    other = tmp_path / "documents"
    other.mkdir()
    (other / "thesis.tex").write_text("precious\n")
    for extra in ([], ["--overwrite"]):
        line = _one_line(capsys, cli.main(["run", str(cfg), "--out", str(other), "--no-progress", *extra]), "run")
        assert "not empty" in line and "thesis.tex" in line and "not a run directory" in line, line
    assert sorted(p.name for p in other.iterdir()) == ["thesis.tex"]


# ----------------------------------------------------------------------------- the config as state
def test_resume_refuses_an_edited_config_unless_the_change_is_allowed(tmp_path, capsys, analytic):
    cfg = _run_file(tmp_path, generations=1)
    run_dir = tmp_path / "run"
    assert cli.main(["run", str(cfg), "--out", str(run_dir), "--no-progress"]) == 0
    capsys.readouterr()
    text = (run_dir / "config.yaml").read_text()
    assert "preset: coarse" in text
    (run_dir / "config.yaml").write_text(text.replace("preset: coarse", "preset: default"))
    before = _digest(run_dir)
    line = _one_line(capsys, cli.main(["resume", str(run_dir), "--max-generations", "2", "--no-progress"]), "resume")
    assert "config.yaml: edited since the run started" in line and "fidelity.preset: 'coarse' -> 'default'" in line
    assert "--allow-config-change" in line
    assert _digest(run_dir) == before
    assert cli.main(["resume", str(run_dir), "--max-generations", "2", "--no-progress", "--allow-config-change"]) == 0
    out = capsys.readouterr().out
    assert "config changed after generation 1" in out and "fidelity.preset: 'coarse' -> 'default'" in out, out
    state, _ = load_checkpoint(run_dir)
    assert state.generation == 2 and state.extra["fidelity"]["preset"] == "default"
    best = json.loads((run_dir / storage.BEST_JSON).read_text())
    assert best["config_changes"][0]["after_generation"] == 1
    assert "config.yaml changed after generation 1" in (run_dir / "run.log").read_text()
    # the edited file is now the run's config; the seed cannot change under a running GA
    assert cli.main(["resume", str(run_dir), "--no-progress"]) == 0
    capsys.readouterr()
    (run_dir / "config.yaml").write_text((run_dir / "config.yaml").read_text().replace("seed: 5", "seed: 6"))
    line = _one_line(capsys, cli.main(["resume", str(run_dir), "--no-progress", "--allow-config-change"]), "resume")
    assert "seed: 5 -> 6" in line and "cannot continue" in line, line
