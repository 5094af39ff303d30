"""Every command that writes into an ``--out`` folder takes the folder's lock and refuses one that holds a GA run
or another command's results.

A command records itself in the first line of the ``config.yaml`` it writes into its folder
(:func:`whisker_opt.config.model.dump_config`); ``export``, ``compensate`` (table and map), ``mesh``, ``simulate``,
``calibrate``, ``robustness`` and ``run`` refuse, in one line and without writing anything, a finished GA run
directory, a folder whose lock another process holds and a folder of another command's results, and accept a
new folder or one they wrote before.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.folder_helpers import folder_hash as _digest, one_line_refusal as _refused
from tests.subprocess_run import CLI_MODULE, run_command
from tests.test_rundir_safety import _analytic_run_dir
from whisker_opt.cli.main import main
from whisker_opt.config.model import load_config, recorded_command
from whisker_opt.output.lock import LOCK_NAME, RunDirLock

CONFIG = "fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.2\n  trim: 2.0\noptimiser:\n  trim: 2.0\n"
#: Per command: its arguments after CONFIG (``compensate --map`` on three trims and two contact ratios).
COMMANDS = {
    "export": ["export"],
    "compensate": ["compensate", "--no-compare"],
    "compensate --map": ["compensate", "--a", "0.7", "1", "--step", "1"],
    "mesh": ["mesh"],
    "simulate": ["simulate"],
    "robustness": ["robustness"],
    "calibrate": ["calibrate"],
}


def _argv(tmp_path: Path, command: str, out: Path) -> list[str]:
    args = COMMANDS[command]
    if command == "calibrate":
        from tests.test_calibration import _config, _write_data

        _write_data(tmp_path)
        cfg = _config(tmp_path)
    else:
        cfg = tmp_path / "c.yaml"
        cfg.write_text(CONFIG)
    return [args[0], str(cfg), *args[1:], "--out", str(out), "--no-progress"]


@pytest.fixture
def beam(monkeypatch):
    """The beam model in place of the FE scenes (``compensate --map``, ``calibrate``)."""
    from tests.test_study_resume import patch

    patch(monkeypatch.setattr)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_finished_ga_run_directory_is_refused(tmp_path, capsys, command):
    run_dir = _analytic_run_dir(tmp_path)
    before = _digest(run_dir)
    line = _refused(capsys, main(_argv(tmp_path, command, run_dir)), command.split()[0])
    assert f"--out {run_dir}: holds a GA run (optimiser.json)" in line, line
    assert "new or empty folder" in line, line
    assert _digest(run_dir) == before


@pytest.mark.parametrize("command", ["export", "compensate --map"])
def test_a_folder_whose_lock_another_process_holds_is_refused(tmp_path, command):
    """The lock is held by this process, the command runs in a child (a process may take its own lock again)."""
    out = tmp_path / "live"
    out.mkdir()
    argv = _argv(tmp_path, command, out)
    with RunDirLock(out, "run"):
        done = run_command([__import__("sys").executable, "-m", CLI_MODULE, *argv], timeout=120)
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]  # nothing written beside the lock
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert f"{out}: in use by `whisker-opt run`" in lines[0], lines[0]
    assert list(out.iterdir()) == []


def test_a_folder_of_another_command_is_refused_its_own_accepted(tmp_path, capsys, beam):
    ex, cmap = tmp_path / "ex", tmp_path / "map"
    assert main(_argv(tmp_path, "compensate --map", cmap)) == 0
    assert recorded_command(cmap / "config.yaml") == "compensate"
    assert load_config(cmap / "config.yaml").scene.Q_i == 0.2  # the record is a comment of the run file
    capsys.readouterr()
    assert main(_argv(tmp_path, "compensate --map", cmap)) == 0  # its own folder: written again
    before = _digest(cmap)
    for command in ("export", "mesh", "simulate", "robustness", "calibrate"):
        line = _refused(capsys, main(_argv(tmp_path, command, cmap)), command)
        assert f"--out {cmap}: holds the results of `whisker-opt compensate`" in line, line
        assert _digest(cmap) == before
    for extra in ([], ["--overwrite"]):  # a folder holding no run is never emptied
        line = _refused(capsys, main(["run", str(tmp_path / "c.yaml"), "--out", str(cmap), *extra]), "run")
        assert "holds the results of `whisker-opt compensate`" in line, line
        assert _digest(cmap) == before
    ex.mkdir()  # an empty folder is a new one
    assert main(_argv(tmp_path, "export", ex)) == 0
    assert recorded_command(ex / "config.yaml") == "export" and (ex / "intact.inp").is_file()
    assert main(_argv(tmp_path, "export", ex)) == 0
    before = _digest(ex)
    capsys.readouterr()
    for command in ("compensate", "compensate --map"):
        line = _refused(capsys, main(_argv(tmp_path, command, ex)), "compensate")
        assert f"--out {ex}: holds the results of `whisker-opt export`" in line, line
    assert _digest(ex) == before and not (ex / LOCK_NAME).exists()


def test_a_folder_of_an_earlier_version_or_of_other_files_is_accepted(tmp_path, beam):
    """A ``config.yaml`` naming no command (an earlier version's folder) names no other command's results."""
    out = tmp_path / "old"
    out.mkdir()
    (out / "config.yaml").write_text(CONFIG)
    (out / "notes.txt").write_text("mine\n")
    assert main(_argv(tmp_path, "compensate --map", out)) == 0
    assert (out / "notes.txt").read_text() == "mine\n" and (out / "compensation_map.json").is_file()
