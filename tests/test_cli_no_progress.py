"""``--no-progress`` is accepted after every command, as the README says (and before it, as ever)."""

from __future__ import annotations

import argparse

import pytest

from whisker_opt.cli import commands
from whisker_opt.cli.main import _parser, main


def _subparser(name: str) -> argparse.ArgumentParser:
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


@pytest.mark.parametrize("name", sorted(commands.REGISTRY))
def test_no_progress_after_any_command(name):
    assert "--no-progress" in _subparser(name)._option_string_actions


def test_no_progress_after_the_command_reaches_the_command(tmp_path, capsys):
    assert main(["report", str(tmp_path / "no_run"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "unrecognized" not in err and "no_run" in err
