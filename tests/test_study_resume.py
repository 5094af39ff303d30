"""Long studies killed with SIGKILL part-way continue to the uninterrupted result.

``compensate --map``, ``robustness`` and ``calibrate`` keep their finished cells, deviated
designs and model evaluations in a journal in the output folder
(:class:`whisker_opt.output.journal.StudyJournal`). Each command runs here as a child process
on cheap stand-ins (the beam model in place of the FE scenes, slowed down so that the kill
lands mid-study); the child is killed once its journal holds some of the work, then the same
command runs again into the same folder in this process and must (a) reuse the journal, (b)
write the same outputs as an uninterrupted run (times excepted) and (c) leave no journal.
A journal made with other inputs is not mixed in.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.kill_harness import kill_when

REPO = Path(__file__).resolve().parents[1]

#: Per kind: the journal's name and the output compared (JSON).
STUDIES = {
    "compensate": ("compensation_map.partial.json", "compensation_map.json"),
    "robustness": ("robustness.partial.json", "robustness.json"),
    "calibrate": ("calibration.partial.json", "calibration.json"),
}

#: A study in a child process on the beam model: argv KIND ROOT SLEEP_S JOURNAL HOLD_AT; with HOLD_AT > 0 it
#: blocks (until signalled or killed) at its first model call once JOURNAL holds that many finished pieces.
CHILD = """
import json, sys
sys.path.insert(0, {repo!r})
from tests.test_study_resume import patch, argv
from whisker_opt.cli.main import main
journal, hold_at = sys.argv[4], int(sys.argv[5])

def hold():
    if hold_at <= 0:
        return False
    try:
        with open(journal) as f:
            return len(json.load(f)["done"]) >= hold_at
    except (OSError, ValueError, KeyError, TypeError):
        return False

patch(setattr, sleep_s=float(sys.argv[3]), hold=hold)
sys.exit(main(argv(sys.argv[1], sys.argv[2])))
"""


def _pause(sleep_s: float, hold) -> None:
    """Sleep ``sleep_s``; then, while ``hold()`` says so, sleep without end (until a signal ends the process)."""
    time.sleep(sleep_s)
    while hold is not None and hold():
        time.sleep(3600.0)


def _slow(fn, sleep_s, hold=None):
    def wrapped(*args, **kwargs):
        _pause(sleep_s, hold)
        return fn(*args, **kwargs)

    return wrapped


def patch(set_attr, sleep_s: float = 0.0, hold=None) -> None:
    """Replace the FE scenes by the beam model (``set_attr``: ``setattr`` or ``monkeypatch.setattr``); each model
    call first sleeps ``sleep_s`` and, when ``hold()`` is true, blocks until the process is signalled (a study
    held at a known point instead of raced)."""
    from tests.test_compensation_map import _BeamRunner
    from whisker_opt.calibration import forward
    from whisker_opt.experiment import scene

    class SlowBeamRunner(_BeamRunner):
        def run(self, spec, keep_states=False):
            _pause(sleep_s, hold)
            return super().run(spec, keep_states)

    set_attr(scene, "SceneRunner", SlowBeamRunner)
    for name in ("reading", "extension"):
        set_attr(forward.BeamSimulator, name, _slow(getattr(forward.BeamSimulator, name), sleep_s, hold))


def _inputs(root: Path, kind: str) -> Path:
    """The run file of ``kind`` in ``root`` (written once)."""
    root.mkdir(parents=True, exist_ok=True)
    path = root / f"{kind}.yaml"
    if path.exists():
        return path
    if kind == "compensate":
        path.write_text("fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.2\noptimiser:\n  trim: 3.0\n")
    elif kind == "robustness":
        path.write_text("fidelity: {preset: coarse}\nscene: {Q_i: 0.2}\noptimiser: {trim: 5.0}\n"
                        "robustness:\n  method: both\n  sample: {n: 12}\n")
    else:
        from tests.test_calibration import _config, _write_data

        _write_data(root)
        return _config(root)
    return path


def argv(kind: str, root: str) -> list[str]:
    """The command line of ``kind`` writing into ``root/out``."""
    root = Path(root)
    cfg, out = str(_inputs(root, kind)), str(root / "out")
    extra = {"compensate": ["--a", "0.6", "0.8", "1", "--step", "1"], "robustness": [], "calibrate": []}[kind]
    return [kind, cfg, *extra, "--out", out, "--no-progress"]


def _journal_entries(path: Path) -> int:
    try:
        return len(json.loads(path.read_text())["done"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0


def kill_part_way(kind: str, root: Path, at_least: int, sleep_s: float = 0.0, timeout: float = 60.0) -> int:
    """Run ``kind`` in a child and SIGKILL it once its journal holds ``at_least`` pieces (the child is held there,
    so the kill cannot come after the study ended); returns that count."""
    journal = root / "out" / STUDIES[kind][0]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-c", CHILD.format(repo=str(REPO)), kind, str(root), str(sleep_s),
                             str(journal), str(at_least)],
                            cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    err = kill_when(proc, lambda: _journal_entries(journal) >= at_least, timeout, 0.01)
    assert proc.returncode == -signal.SIGKILL, f"the child was not killed mid-study ({proc.returncode}): {err}"
    return _journal_entries(journal)


def _without_times(x):
    if isinstance(x, dict):
        return {k: _without_times(v) for k, v in x.items() if "seconds" not in k and k not in ("date", "written")}
    if isinstance(x, list):
        return [_without_times(v) for v in x]
    return x


def _result(kind: str, root: Path):
    """The study's JSON output, times left out and its folder's path replaced by ``ROOT``."""
    text = (root / "out" / STUDIES[kind][1]).read_text().replace(str(root), "ROOT")
    return _without_times(json.loads(text))


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """The uninterrupted result of each study (in this process)."""
    from whisker_opt.cli.main import main

    out = {}
    mp = pytest.MonkeyPatch()
    try:
        patch(mp.setattr)
        for kind in STUDIES:
            root = tmp_path_factory.mktemp(f"ref_{kind}")
            assert main(argv(kind, str(root))) in (0, 4)
            out[kind] = _result(kind, root)
    finally:
        mp.undo()
    return out


@pytest.mark.parametrize("kind, at_least", [("compensate", 4), ("robustness", 5), ("calibrate", 4)])
def test_a_killed_study_continues_to_the_uninterrupted_result(tmp_path, monkeypatch, caplog, references, kind,
                                                              at_least):
    from whisker_opt.cli.main import main

    kept = kill_part_way(kind, tmp_path, at_least)
    assert kept >= at_least
    patch(monkeypatch.setattr)
    with caplog.at_level(logging.WARNING, logger="whisker_opt.output.journal"):
        assert main(argv(kind, str(tmp_path))) in (0, 4)
    assert any("continuing" in r.getMessage() and "read back" in r.getMessage() for r in caplog.records)
    assert _result(kind, tmp_path) == references[kind]
    assert not (tmp_path / "out" / STUDIES[kind][0]).exists()
    assert not (tmp_path / "out" / "run.lock").exists()


def test_a_journal_of_other_inputs_is_not_mixed_in(tmp_path, monkeypatch, caplog, references):
    """A map stopped part-way, then its config edited: the new map starts afresh and says why."""
    from whisker_opt.cli.main import main

    kill_part_way("compensate", tmp_path, 3)
    cfg = tmp_path / "compensate.yaml"
    cfg.write_text(cfg.read_text().replace("Q_i: 0.2", "Q_i: 0.25"))
    patch(monkeypatch.setattr)
    with caplog.at_level(logging.WARNING, logger="whisker_opt.output.journal"):
        assert main(argv("compensate", str(tmp_path))) == 0
    assert any("made with other inputs" in r.getMessage() for r in caplog.records)
    got = _result("compensate", tmp_path)
    assert got["Q_i_MPa"] == 0.25 and got != references["compensate"]


def test_a_study_into_a_locked_folder_is_refused_in_one_line(tmp_path):
    """``robustness`` writing where a run writes (its lock held) refuses, naming the holder."""
    from whisker_opt.output.lock import RunDirLock

    args = argv("robustness", str(tmp_path))
    (tmp_path / "out").mkdir()
    with RunDirLock(tmp_path / "out", "run"):
        code = subprocess.run([sys.executable, "-m", "whisker_opt.cli", *args], cwd=REPO, capture_output=True,
                              text=True, timeout=120)
    assert code.returncode == 2, code.stderr
    assert code.stderr.count("\n") == 1 and "in use by `whisker-opt run`" in code.stderr
