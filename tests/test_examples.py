"""The scripts in ``examples/`` run as a user runs them and print the numbers they promise.

Each runs as ``python examples/NAME.py OUTDIR`` in an empty working directory, which must
stay empty: the examples write under OUTDIR only.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
NUMBER = r"([-+0-9.eE]+|nan|inf)"


def _run(name: str, arg: Path, cwd: Path) -> str:
    cwd.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py"), str(arg)], cwd=cwd,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"{name} failed:\n{proc.stdout}\n{proc.stderr}"
    assert list(cwd.iterdir()) == [], f"{name} wrote into its working directory"
    return proc.stdout


def _value(out: str, label: str) -> float:
    m = re.search(rf"^\s*{re.escape(label)}\s*=?\s+{NUMBER}", out, re.MULTILINE) or \
        re.search(rf"{re.escape(label)} = {NUMBER}", out)
    assert m, f"no {label!r} in the output:\n{out}"
    return float(m.group(1))


@pytest.fixture(scope="module")
def small_ga(tmp_path_factory):
    """Output of ``small_ga.py`` and the run directory it created (shared with ``read_a_run``)."""
    tmp = tmp_path_factory.mktemp("small_ga")
    out = _run("small_ga", tmp / "out", tmp / "cwd")
    run_dir = Path(re.search(r"^run directory (.+)$", out, re.MULTILINE).group(1))
    return out, run_dir


def test_every_example_is_listed_and_short():
    scripts = sorted(p.name for p in EXAMPLES.glob("*.py"))
    assert scripts == ["one_evaluation.py", "one_scene.py", "read_a_run.py", "small_ga.py"]
    readme = (EXAMPLES / "README.md").read_text()
    for name in scripts:
        assert f"`{name}`" in readme
        assert len((EXAMPLES / name).read_text().splitlines()) <= 40, name


def test_one_scene(tmp_path):
    out = _run("one_scene", tmp_path / "out", tmp_path / "cwd")
    assert 0.0 < _value(out, "f1") < _value(out, "f1_uncompensated")
    intact = re.search(rf"^intact\s+{NUMBER}\s+{NUMBER}\s+{NUMBER}", out, re.MULTILINE)
    q, dl, eps = map(float, intact.groups())
    assert q == pytest.approx(0.2) and dl > 0.0 and eps > 0.0  # the pressurised whisker grew
    assert (tmp_path / "out" / "one_scene" / "curve.csv").is_file()


def test_one_evaluation(tmp_path):
    out = _run("one_evaluation", tmp_path / "out", tmp_path / "cwd")
    assert "status = ok" in out
    assert _value(out, "f1") > 0.0
    assert _value(out, "total") > 0.0


def test_small_ga(small_ga, tmp_path):
    out, run_dir = small_ga
    assert "stopped by max_generations after generation 1" in out
    assert _value(out, "f1") > 0.0
    for gene, (lo, hi) in {"alpha": (2.5, 6.0), "l": (10.0, 15.0), "t": (2.0, 6.0), "Q_i": (0.01, 0.2)}.items():
        assert lo <= _value(out, gene) <= hi, gene
    assert run_dir.name.startswith("small_ga-run-") and (run_dir / "best.json").is_file()


def test_read_a_run(small_ga, tmp_path):
    _, run_dir = small_ga
    out = _run("read_a_run", run_dir, tmp_path / "cwd")
    assert _value(out, "f1") > 0.0
    gens = re.findall(rf"^\s+(\d+)\s+(\d+)\s+(\d+)\s+{NUMBER}", out, re.MULTILINE)
    assert [int(g[0]) for g in gens] == [0, 1]
    assert int(gens[0][1]) == 4  # the initial population was evaluated
