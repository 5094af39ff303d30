"""The quick subset's list (tests/conftest.py) names tests that exist."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.conftest import QUICK

HERE = Path(__file__).resolve().parent


def test_every_quick_name_is_a_test_of_its_module():
    missing = []
    for module, names in QUICK.items():
        path = HERE / module
        if not path.exists():
            missing.append(module)
            continue
        tests = {n.name for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.FunctionDef)}
        missing += [f"{module}::{n}" for n in names if n != "*" and n not in tests]
    assert not missing

