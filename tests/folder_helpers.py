"""Helpers the command-line safety tests share: what a folder holds, a command's or a run file's one-line refusal,
and the analytic fitness in place of the finite-element one."""

from __future__ import annotations

import hashlib
from pathlib import Path


def folder_hash(folder: Path) -> str:
    """One SHA-256 over every path under ``folder`` and every file's bytes (a refused command leaves it equal)."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        h.update(str(p).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def folder_contents(folder: Path) -> dict[str, bytes]:
    """Every path under ``folder`` (relative) and its bytes (b"" for a folder or a link), for a diff that names
    the file that changed."""
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() and not p.is_symlink() else b"")
            for p in sorted(folder.rglob("*"))}


def one_line_refusal(capsys, rc: int, command: str) -> str:
    """The single stderr line of a command refused with exit 2, without a traceback, and that line."""
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and "Traceback" not in err and len(lines) == 1, (rc, err)
    assert lines[0].startswith(f"whisker-opt {command}: error: "), err
    return lines[0]


def use_analytic_fitness(monkeypatch, **fitness) -> None:
    """In this process: the commands evaluate :class:`tests.analytic_fitness.AnalyticFitness` (its keywords
    ``fitness``) and do not re-solve the best design."""
    from tests.analytic_fitness import AnalyticFitness
    from whisker_opt import wiring, workflows

    monkeypatch.setattr(wiring, "evaluator", lambda cfg, *a, **k: AnalyticFitness(**fitness))
    monkeypatch.setattr(workflows, "finish_best", lambda *a, **k: None)


def assert_run_file_refused(folder: Path, text: str, message: str) -> str:
    """Loading a run file of ``text`` (written in ``folder``) raises one line of ConfigError matching ``message``."""
    import pytest

    from whisker_opt.config.base import ConfigError
    from whisker_opt.config.model import load_config

    path = folder / "run.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message) as info:
        load_config(path)
    assert "\n" not in str(info.value)
    return str(info.value)
