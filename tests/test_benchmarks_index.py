"""The benchmark suite as a package: every script is in the index with its command and results file,
answers ``--help`` from a clean checkout, imports no other script and patches no ``sys.path``; every
relative link of the docs resolves, and no doc holds a control character."""

from __future__ import annotations

import ast
import re
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.subprocess_run import run_module

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"
KINDS = ("performance", "accuracy", "studies", "reliability")
INDEX = (BENCH / "README.md").read_text()


def _scripts() -> list[str]:
    """Dotted module names of the scripts, ``benchmarks.<kind>.<script>``."""
    return sorted(f"benchmarks.{p.parent.name}.{p.stem}" for kind in KINDS
                  for p in (BENCH / kind).glob("*.py") if p.stem != "__init__")


def _index_rows() -> dict[str, str]:
    """Index row of each script, keyed by its module name."""
    rows = {}
    for line in INDEX.splitlines():
        m = re.search(r"python3 -m (benchmarks\.\w+\.\w+)", line)
        if m and line.startswith("| `"):
            rows[m.group(1)] = line
    return rows


def test_only_kind_folders_hold_scripts():
    """benchmarks/ holds the four kinds, the shared modules, README.md and results/, nothing else."""
    loose = [p.name for p in BENCH.iterdir() if p.is_dir() and p.name not in (*KINDS, "results", "__pycache__", "out")]
    assert loose == [], loose
    assert len(_scripts()) >= 20


def test_every_script_is_in_the_index_with_its_command_and_results_file():
    rows = _index_rows()
    missing = [s for s in _scripts() if s not in rows]
    assert missing == [], f"not in benchmarks/README.md: {missing}"
    assert sorted(rows) == _scripts(), "the index names a script that does not exist"
    for name, row in rows.items():
        links = re.findall(r"\]\((results/[\w.]+\.md)\)", row)
        assert links, f"{name}: no results file in its index row"
        assert all((BENCH / link).is_file() for link in links), (name, links)


def test_every_results_file_is_reached_from_the_index():
    linked = set(re.findall(r"\]\(results/([\w.]+\.md)\)", INDEX))
    assert linked == {p.name for p in (BENCH / "results").glob("*.md")}


def _imports(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            out += [node.module] + [f"{node.module}.{a.name}" for a in node.names]
    return out


def test_no_script_imports_a_script_or_patches_sys_path():
    """Scripts share code through the modules beside them; nothing in benchmarks/ edits sys.path."""
    scripts = set(_scripts())
    stems = {s.rsplit(".", 1)[1] for s in scripts}
    for path in BENCH.rglob("*.py"):
        bad = [m for m in _imports(path) if m in scripts or m in stems]
        assert bad == [], f"{path.relative_to(ROOT)} imports scripts {bad}"
        code = ast.parse(path.read_text())
        patches = [n.lineno for n in ast.walk(code) if isinstance(n, ast.Attribute) and n.attr == "path"
                   and isinstance(n.value, ast.Name) and n.value.id == "sys"]
        assert patches == [], f"{path.relative_to(ROOT)}: sys.path used at lines {patches}"


def test_every_script_answers_help():
    """``python3 -m benchmarks.<kind>.<script> --help`` exits 0 (imports resolve from the checkout)."""
    def run(name):
        return name, run_module(name, "--help", timeout=120)

    with ThreadPoolExecutor(4) as ex:
        results = list(ex.map(run, _scripts()))
    failed = {name: proc.stderr.strip().splitlines()[-1:] for name, proc in results if proc.returncode != 0}
    assert failed == {}, failed
    assert all("usage:" in proc.stdout for _, proc in results)


def _markdown_files() -> list[Path]:
    names = subprocess.run(["git", "ls-files", "*.md"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    files = {ROOT / n for n in names} | set(BENCH.glob("**/*.md"))
    return sorted(p for p in files if p.is_file())


@pytest.mark.parametrize("path", _markdown_files(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_of_the_docs_resolve(path):
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    broken = [t for t in re.findall(r"\]\(([^)\s]+)\)", text)
              if not re.match(r"[a-z]+:|#", t) and not (path.parent / t.split("#")[0]).exists()]
    assert broken == [], f"{path.relative_to(ROOT)}: broken links {broken}"


#: Control characters other than the newline: a backspace or a tab where ``\bar`` or ``\tfrac`` was meant
#: (a formula written through a string that read its backslashes as escapes).
CONTROL = re.compile(r"[\x00-\x09\x0b-\x1f\x7f]")


def test_no_doc_holds_a_control_character():
    """README, CONTRIBUTING, docs/ and benchmarks/: every markdown file, line by line (a tab is refused too)."""
    bad = [f"{p.relative_to(ROOT)}:{k}: {CONTROL.search(line).group()!r}"
           for p in _markdown_files() for k, line in enumerate(p.read_text().splitlines(), start=1)
           if CONTROL.search(line)]
    assert bad == [], f"control characters in the docs: {bad}"
    assert CONTROL.search("c\\,\x08ar W") and not CONTROL.search("c\\,\\bar W")


def test_the_readme_names_every_fidelity_preset_in_order_of_cost():
    """``--preset a|b|...`` and the fidelity section list :data:`PRESET_NAMES`, cheapest first."""
    from whisker_opt.experiment.fidelity import PRESET_NAMES

    readme = (ROOT / "README.md").read_text()
    assert f"`--preset {'|'.join(PRESET_NAMES)}`" in readme
    section = readme.split("## Fidelity and how far to trust f1", 1)[1].split("\n## ", 1)[0]
    named = re.findall(r"`(\w+)`", section.split("One evaluation", 1)[0])
    assert [n for n in named if n in PRESET_NAMES][:len(PRESET_NAMES)] == list(PRESET_NAMES)
