"""A study interrupted (Ctrl-C) without ``--out`` continues in its folder when run again the same way.

``compensate --map``, ``calibrate`` and ``robustness`` without ``--out`` make a folder under
``output.results_dir``; interrupted, they keep their finished work in its journal and the interrupt line
names the folder and the command that continues there. Run again the same way, the study finds that folder
by its journal (the same inputs, the resolved config among them), continues there and ends with the result
of a study that was never interrupted, in one folder. The interrupt comes from a stand-in model evaluation
that raises KeyboardInterrupt at its k-th call (the beam model in place of the FE scenes, as in
:mod:`tests.test_study_resume`).
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest

from tests.test_study_resume import STUDIES, _inputs, _without_times, patch
from whisker_opt.cli.main import main

#: Per kind: the options after the run file, and the model call that is interrupted.
EXTRA = {"compensate": ["--a", "0.6", "0.8", "1", "--step", "1"], "calibrate": [], "robustness": []}


def _argv(kind: str, root: Path) -> list[str]:
    return [kind, str(_inputs(root, kind).relative_to(root)), *EXTRA[kind], "--no-progress"]


def _interrupt_at(monkeypatch, kind: str, k: int) -> None:
    """The k-th model evaluation of the study raises KeyboardInterrupt (as Ctrl-C does)."""
    from whisker_opt.calibration import forward
    from whisker_opt.experiment import scene

    owner, name = (forward.BeamSimulator, "reading") if kind == "calibrate" else (scene.SceneRunner, "run")
    original, calls = getattr(owner, name), [0]

    def stopping(*args, **kwargs):
        calls[0] += 1
        if calls[0] == k:
            raise KeyboardInterrupt
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, name, stopping)


def _folders(root: Path) -> list[Path]:
    return sorted((root / "results").iterdir())


def _result(kind: str, folder: Path):
    return _without_times(json.loads((folder / STUDIES[kind][1]).read_text().replace(str(folder), "OUT")))


@pytest.fixture
def reference(tmp_path_factory, monkeypatch):
    """The result of a study never interrupted, without ``--out``."""
    def run(kind: str):
        root = tmp_path_factory.mktemp(f"ref_{kind}")
        monkeypatch.chdir(root)
        assert main(_argv(kind, root)) in (0, 4)
        [folder] = _folders(root)
        return _result(kind, folder)

    return run


@pytest.mark.parametrize("kind, k", [("compensate", 40), ("calibrate", 25), ("robustness", 12)])
def test_an_interrupted_study_continues_in_its_folder_to_the_uninterrupted_result(tmp_path, monkeypatch, capsys,
                                                                                  reference, kind, k):
    patch(monkeypatch.setattr)
    want = reference(kind)
    monkeypatch.chdir(tmp_path)
    argv = _argv(kind, tmp_path)
    with monkeypatch.context() as m:
        _interrupt_at(m, kind, k)
        assert main(argv) == 130
    [folder] = _folders(tmp_path)
    journal = folder / STUDIES[kind][0]
    assert len(json.loads(journal.read_text())["done"]) >= 1  # some work was kept
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("whisker-opt ")]
    rel = folder.relative_to(tmp_path)
    assert err == [f"whisker-opt {kind}: interrupted by SIGINT; its finished work is kept in {rel}: continue with "
                   f"`whisker-opt {shlex.join(argv)} --out {rel}`"], err
    assert main(argv) in (0, 4)  # the same command again: it finds the folder
    assert _folders(tmp_path) == [folder] and not journal.exists()
    assert _result(kind, folder) == want


def test_the_command_the_interrupt_line_names_continues(tmp_path, monkeypatch, capsys):
    patch(monkeypatch.setattr)
    monkeypatch.chdir(tmp_path)
    with monkeypatch.context() as m:
        _interrupt_at(m, "calibrate", 25)
        assert main(_argv("calibrate", tmp_path)) == 130
    line = capsys.readouterr().err.strip().splitlines()[-1]
    command = shlex.split(line.split("continue with `")[1].rstrip("`"))
    assert command[0] == "whisker-opt"
    [folder] = _folders(tmp_path)
    (tmp_path / "results" / "elsewhere").mkdir()  # a newer folder of no study changes nothing
    assert main(command[1:]) in (0, 4)
    assert (folder / "calibration.json").is_file() and not (folder / STUDIES["calibrate"][0]).exists()


def test_a_stopped_study_of_other_inputs_is_left_alone(tmp_path, monkeypatch, capsys):
    """Another config (here another Q_i) makes a new folder; the stopped study's journal stays for later."""
    patch(monkeypatch.setattr)
    monkeypatch.chdir(tmp_path)
    argv = _argv("compensate", tmp_path)
    with monkeypatch.context() as m:
        _interrupt_at(m, "compensate", 40)
        assert main(argv) == 130
    [stopped] = _folders(tmp_path)
    kept = (stopped / STUDIES["compensate"][0]).read_bytes()
    cfg = tmp_path / argv[1]
    cfg.write_text(cfg.read_text().replace("Q_i: 0.2", "Q_i: 0.25"))
    assert main(argv) == 0
    assert len(_folders(tmp_path)) == 2 and (stopped / STUDIES["compensate"][0]).read_bytes() == kept


def _stopped_calibration(tmp_path: Path, monkeypatch) -> tuple[list[str], Path]:
    """A calibration into ``out`` interrupted part-way: (its command line, its journal)."""
    patch(monkeypatch.setattr)
    monkeypatch.chdir(tmp_path)
    argv = [*_argv("calibrate", tmp_path), "--out", "out"]
    with monkeypatch.context() as m:
        _interrupt_at(m, "calibrate", 25)
        assert main(argv) == 130
    return argv, tmp_path / "out" / STUDIES["calibrate"][0]


def _refused(capsys, argv: list[str], journal: Path, *words: str) -> None:
    capsys.readouterr()
    before = sorted(p.name for p in journal.parent.iterdir())
    assert main(argv) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    shown = f"out/{journal.name}"  # the folder as given: --out out
    assert len(err) == 1 and err[0].startswith("whisker-opt calibrate: error: ") and shown in err[0], err
    for w in words:
        assert w in err[0], (w, err[0])
    assert sorted(p.name for p in journal.parent.iterdir()) == before  # no outputs written


def test_a_doctored_calibration_journal_is_refused(tmp_path, monkeypatch, capsys):
    """A prediction changed by hand is not believed (its digest no longer matches); a piece forged with a matching
    digest but not the predictions of the observations asked for is refused too."""
    from whisker_opt.output.journal import piece_digest

    argv, journal = _stopped_calibration(tmp_path, monkeypatch)
    doc = json.loads(journal.read_text())
    key = sorted(doc["done"])[0]
    good = json.loads(json.dumps(doc))
    doc["done"][key]["predictions"][0]["value"] *= 1.01  # a plausible number, not the model's
    journal.write_text(json.dumps(doc))
    _refused(capsys, argv, journal, "does not match its digest", "none of it is believed", f"delete out/{journal.name}")
    forged = good["done"][key] = {"predictions": good["done"][key]["predictions"][:1], "scenes": 0}
    good["sha256"][key] = piece_digest(good["inputs"], key, forged)
    journal.write_text(json.dumps(good))
    _refused(capsys, argv, journal, "are not", "predictions of the observations asked for", "not believed")
