"""Conveniences of the command line: ``--version``, ``init``, ``--set``/``--preset``/``--defaults``,
``resume --max-generations``, ``-v``/``--no-progress`` before or after the command, quiet
third-party loggers, and run files YAML cannot read refused in one line.

Runs ``whisker_opt.cli.main.main`` in-process, and a subprocess where the console's log
output is checked. One tiny GA run (the ``init`` demo file on the coarse preset, 2
individuals, generation 0, serial) is shared by the module.
"""

from __future__ import annotations

import contextlib
import logging
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import whisker_opt
from whisker_opt.cli import main as cli
from whisker_opt.config.model import load_config
from whisker_opt.config.template import CASES, render_template

TINY_RUN = ["--set", "optimiser.ga.population=2", "--set", "optimiser.stopping.max_generations=0",
            "--set", "optimiser.executor.kind=serial"]


@contextlib.contextmanager
def _kept_logging():
    """``main`` sets logger levels as a console script does; put them back afterwards."""
    names = ["", "whisker_opt", *cli.QUIET_LOGGERS]
    levels = {n: logging.getLogger(n).level for n in names}
    try:
        yield
    finally:
        for n, level in levels.items():
            logging.getLogger(n).setLevel(level)


@pytest.fixture(autouse=True)
def _restore_logging():
    with _kept_logging():
        yield


def _one_line(capsys, rc: int, command: str, expect: int = 2) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == expect, err
    assert "Traceback" not in err, err
    assert len(lines) == 1 and lines[0].startswith(f"whisker-opt {command}: error: "), err
    return lines[0]


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory) -> Path:
    """The ``init`` demo file run end to end (``-v`` after the command, ``--no-progress`` before it)."""
    root = tmp_path_factory.mktemp("conveniences")
    cfg = root / "whisker.yaml"
    assert cli.main(["init", str(cfg)]) == 0
    out = root / "run"
    with _kept_logging():
        assert cli.main(["--no-progress", "run", str(cfg), *TINY_RUN, "--out", str(out), "-v"]) == 0
    return out


def test_version(capsys):
    assert cli.main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"whisker-opt {whisker_opt.__version__}"


@pytest.mark.parametrize("case", sorted(CASES))
def test_init_writes_a_template_that_validates(tmp_path, monkeypatch, capsys, case):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["init", "--case", case]) == 0
    path = tmp_path / "whisker.yaml"
    assert "whisker.yaml" in capsys.readouterr().out
    assert path.read_text() == render_template(case)
    load_config(path)  # validates as written
    # nested folders are created
    assert cli.main(["init", "--case", case, "sub/dir/x.yaml"]) == 0
    load_config(tmp_path / "sub" / "dir" / "x.yaml")


def _resolved(cfg) -> dict:
    """A config's values with every optional section that is absent (null) at its defaults: a section
    the template writes out at its defaults and one a shipped file leaves out mean the same."""
    data = cfg.model_dump(mode="json")
    for name, info in type(cfg).model_fields.items():
        if data[name] is None:
            from whisker_opt.config.fields import strip_optional

            data[name] = strip_optional(info.annotation)[0]().model_dump(mode="json")
    return data


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_init_case_writes_the_values_of_its_shipped_config(tmp_path, case):
    from whisker_opt.config.template import SHIPPED
    from whisker_opt.optimise.rundir import config_differences

    assert set(SHIPPED) == set(CASES)
    path = tmp_path / "init.yaml"
    assert cli.main(["init", "--case", case, str(path)]) == 0
    shipped = Path(__file__).resolve().parents[1] / "configs" / SHIPPED[case]
    diffs = config_differences(_resolved(load_config(shipped)), _resolved(load_config(path)))
    assert diffs == [], f"init --case {case} differs from configs/{SHIPPED[case]}: {diffs}"


def test_init_refuses_to_overwrite_unless_forced(tmp_path, capsys):
    path = tmp_path / "mine.yaml"
    path.write_text("fidelity: {preset: fine}\n")
    line = _one_line(capsys, cli.main(["init", str(path)]), "init")
    assert "mine.yaml" in line and "--force" in line, line
    assert path.read_text() == "fidelity: {preset: fine}\n"
    assert cli.main(["init", "--case", "case1", str(path), "--force"]) == 0
    assert path.read_text() == render_template("case1")
    line = _one_line(capsys, cli.main(["init", str(tmp_path)]), "init")
    assert "is a folder" in line, line
    _one_line(capsys, cli.main(["init", "--case", "nope", str(tmp_path / "n.yaml")]), "init")
    assert not (tmp_path / "n.yaml").exists()


def test_demo_template_runs_end_to_end_with_settings(demo_run):
    stored = yaml.safe_load((demo_run / "config.yaml").read_text())
    assert stored["optimiser"]["ga"]["population"] == 2
    assert stored["optimiser"]["stopping"]["max_generations"] == 0
    assert stored["optimiser"]["executor"]["kind"] == "serial"
    assert stored["fidelity"]["preset"] == "coarse"
    assert (demo_run / "checkpoint.json").is_file()


def test_resume_max_generations(demo_run, capsys):
    assert cli.main(["resume", str(demo_run), "--max-generations", "1", "--no-progress"]) == 0
    assert "generations    1 " in capsys.readouterr().out
    line = _one_line(capsys, cli.main(["resume", str(demo_run), "--max-generations", "0"]), "resume")
    assert "--max-generations 0" in line and "already bred 1" in line, line
    for bad in ("-1", "abc", "2.5"):
        line = _one_line(capsys, cli.main(["resume", str(demo_run), "--max-generations", bad]), "resume")
        assert "--max-generations" in line, line


def test_defaults_preset_and_set_on_an_empty_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    empty = tmp_path / "empty.yaml"
    empty.write_text("# nothing yet\n")
    for cmd in ("mesh", "simulate", "run", "compensate"):
        line = _one_line(capsys, cli.main([cmd, str(empty)]), cmd)
        assert "empty" in line and "--defaults" in line, line
    argv = ["mesh", str(empty), "--defaults", "--preset", "fine", "--set", "scene.trim=2", "--preset", "coarse"]
    assert cli.main(argv) == 0
    (run_dir,) = (tmp_path / "results").iterdir()
    stored = load_config(run_dir / "config.yaml")
    assert stored.fidelity.preset == "coarse" and stored.scene.trim == 2.0  # in the order given
    assert (run_dir / "mesh.vtu").is_file()


@pytest.mark.parametrize(("argv", "words"), [
    (["--set", "design.alpah=3"], ["alpah", "alpha"]),
    (["--set", "optimiser.ga.population=x"], ["optimiser.ga.population"]),
    (["--set", "seed.x=1"], ["--set", "seed"]),
    (["--set", "nokey"], ["--set", "KEY=VALUE"]),
    (["--set", "a..b=1"], ["--set", "KEY=VALUE"]),
    (["--preset", "medium"], ["--preset", "coarse, default, level2, fine, level3, level4"]),
])
def test_bad_settings_are_one_line(tmp_path, capsys, argv, words):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("seed: 1\n")
    for cmd in ("mesh", "run"):
        line = _one_line(capsys, cli.main([cmd, str(cfg), *argv, "--out", str(tmp_path / "out")]), cmd)
        for w in words:
            assert w in line, line
    assert not (tmp_path / "out").exists()


UNREADABLE = {
    "digits.yaml": "seed: " + "9" * 5000 + "\n",
    "deep.yaml": "design: " + "[" * 600 + "]" * 600 + "\n",
    "date.yaml": "seed: 2024-13-45\n",
    "tag.yaml": "seed: !!int abc\n",
    "empty.yaml": "",
}


@pytest.mark.parametrize("name", sorted(UNREADABLE))
def test_yaml_that_cannot_be_read_is_one_line(tmp_path, capsys, name):
    cfg = tmp_path / name
    cfg.write_text(UNREADABLE[name])
    for cmd in ("mesh", "simulate", "run", "compensate"):
        line = _one_line(capsys, cli.main([cmd, str(cfg), "--out", str(tmp_path / "out")]), cmd)
        assert name in line, line
    assert not (tmp_path / "out").exists()


def test_options_before_or_after_the_command():
    p = cli._parser()
    for argv, verbose, no_progress in [
        (["run", "c.yaml"], 0, False),
        (["-v", "run", "c.yaml"], 1, False),
        (["run", "c.yaml", "-v"], 1, False),
        (["-v", "run", "c.yaml", "-vv", "--no-progress"], 3, True),
        (["--no-progress", "resume", "r"], 0, True),
        (["resume", "r", "--no-progress", "--verbose"], 1, True),
        (["compensate", "c.yaml", "--no-progress"], 0, True),
        (["report", "r", "-vv"], 2, False),
    ]:
        args = p.parse_args(argv)
        assert args.verbose + getattr(args, "verbose_after", 0) == verbose, argv
        assert args.no_progress is no_progress, argv
    for name in ("mesh", "simulate", "run", "compensate"):  # every command taking a CONFIG
        args = p.parse_args([name, "c.yaml", "--set", "a.b=1", "--preset", "fine", "--defaults", "-v"])
        assert args.settings == ["a.b=1", "fidelity.preset=fine"] and args.defaults


def test_verbose_keeps_third_party_loggers_quiet(tmp_path):
    assert cli.main(["-vv", "init", str(tmp_path / "a.yaml")]) == 0
    assert logging.getLogger().level == logging.DEBUG
    assert all(logging.getLogger(n).level == logging.WARNING for n in cli.QUIET_LOGGERS)
    assert cli.main(["init", str(tmp_path / "b.yaml"), "-vvv"]) == 0
    assert all(logging.getLogger(n).getEffectiveLevel() == logging.DEBUG for n in cli.QUIET_LOGGERS)


def _stderr(*args) -> str:
    proc = subprocess.run([sys.executable, "-m", "whisker_opt.cli.main", *map(str, args)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    return proc.stderr


def test_debug_output_has_no_matplotlib_lines(demo_run):
    # `report` imports matplotlib and rebuilds the plots: matplotlib and PIL log at DEBUG
    err = _stderr("report", demo_run, "-vv")
    assert not [ln for ln in err.splitlines() if "matplotlib" in ln or " PIL" in ln], err
    assert any("matplotlib" in ln for ln in _stderr("-vvv", "report", demo_run).splitlines())
