"""The console script on user errors: one line on stderr, exit code 2, no traceback.

Runs ``python -m whisker_opt.cli`` in a subprocess (:func:`tests.subprocess_run.run_cli`), as a user would
run ``whisker-opt``.
"""

import pytest

from tests.subprocess_run import REPO, run_cli


def _cli(*args, cwd=REPO):
    done = run_cli(*args, cwd=cwd, timeout=300)
    return done.returncode, done.stdout, done.stderr


def _one_line_error(rc, err, command):
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith(f"whisker-opt {command}: error: "), err
    return lines[0]


@pytest.mark.parametrize(("yaml", "words"), [
    ("design:\n  alpah: 3.0\n", "alpah"),  # unknown key, named
    ("design:\n  t: -1.0\n", "t"),  # out of range, field named
    ("scene: [1, 2\n", "YAML"),  # not YAML at all
])
def test_malformed_config_is_one_line(tmp_path, yaml, words):
    cfg = tmp_path / "bad.yaml"
    cfg.write_text(yaml)
    rc, _, err = _cli("mesh", cfg, "--out", tmp_path / "out")
    line = _one_line_error(rc, err, "mesh")
    assert words in line


def test_impossible_design_is_one_line(tmp_path):
    cfg = tmp_path / "d.yaml"
    cfg.write_text("design:\n  alpha: 9.0\n")  # the cone closes before the tip
    rc, _, err = _cli("mesh", cfg, "--out", tmp_path / "out")
    line = _one_line_error(rc, err, "mesh")
    assert "tip radius" in line and "design.alpha=9" in line  # named by its run-file key


def test_missing_config_and_occupied_run_directory(tmp_path):
    rc, _, err = _cli("run", tmp_path / "nope.yaml")
    assert "nope.yaml" in _one_line_error(rc, err, "run")
    run = tmp_path / "run"
    run.mkdir()
    (run / "checkpoint.pkl").write_bytes(b"")
    rc, _, err = _cli("run", REPO / "configs" / "demo.yaml", "--out", run)
    line = _one_line_error(rc, err, "run")
    assert "already holds a run" in line and "whisker-opt resume" in line
    assert sorted(p.name for p in run.iterdir()) == ["checkpoint.pkl"]  # nothing written
