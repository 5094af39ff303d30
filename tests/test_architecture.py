"""The code's structure: layering, no import cycles, no oversized module, one home per idea.

The import graph is read from the source (every ``import`` statement, including the lazy
ones inside functions), so a cycle hidden behind a function-level import is found too.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("fem", "geometry", "whisker_opt", "peers")
#: Largest module, in lines.
MAX_LINES = 700


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            mods[name] = path
    return mods


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """Project modules that ``name`` imports (resolved to the longest known module name)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([base] if base else []))
            targets = [f"{base}.{a.name}" for a in node.names] + [base]
        for t in targets:
            while t and t not in MODULES:
                t = t.rpartition(".")[0]
            if t and t != name:
                out.add(t)
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    colour: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        colour[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if m not in graph:
                continue
            if colour.get(m) == 1:
                return stack[stack.index(m):] + [m]
            if m not in colour:
                cyc = visit(m)
                if cyc:
                    return cyc
        stack.pop()
        colour[n] = 2
        return None

    for n in sorted(graph):
        if n not in colour:
            cyc = visit(n)
            if cyc:
                return cyc
    return None


def test_the_import_graph_is_read():
    assert "whisker_opt.wiring" in GRAPH["whisker_opt.workflows"]
    assert "fem.mesh" in GRAPH["geometry.sizing"]


def test_no_import_cycle():
    assert _find_cycle(GRAPH) is None, " -> ".join(_find_cycle(GRAPH) or [])


def test_a_cycle_would_be_found():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_no_module_imports_the_face_of_its_own_package():
    """``from whisker_opt import wiring`` inside ``whisker_opt`` runs the package's face
    (``whisker_opt/__init__.py``, which lazily imports the API) and is an edge to it in any import
    graph, closing a cycle through the API: modules import each other by their full names
    (``import whisker_opt.wiring as wiring``). Faces that import nothing (``fem``, ``geometry``, the
    subpackages) close no cycle."""
    faces = {n for n, p in MODULES.items() if p.name == "__init__.py" and GRAPH[n]}  # faces that load modules
    assert "whisker_opt" in faces
    bad = sorted(f"{n} -> {m}" for n, deps in GRAPH.items() for m in deps if m in faces and n.startswith(m + ".")
                 and not n.startswith("whisker_opt.cli"))  # the CLI, imported by nothing, reads the version there
    assert not bad


def test_a_module_importing_its_package_face_closes_a_cycle():
    graph = {"pkg": {"pkg.api"}, "pkg.api": {"pkg.mod"}, "pkg.mod": {"pkg"}}
    assert _find_cycle(graph) == ["pkg", "pkg.api", "pkg.mod", "pkg"]


@pytest.mark.parametrize("lower, higher", [("fem", "geometry"), ("fem", "whisker_opt"), ("geometry", "whisker_opt"),
                                           ("fem", "peers"), ("geometry", "peers"), ("whisker_opt", "peers")])
def test_imports_run_one_way(lower, higher):
    bad = sorted(f"{n} -> {m}" for n, deps in GRAPH.items() if n.split(".")[0] == lower
                 for m in deps if m.split(".")[0] == higher)
    assert not bad


def test_nothing_imports_the_cli():
    bad = sorted(f"{n} -> {m}" for n, deps in GRAPH.items() if not n.startswith("whisker_opt.cli")
                 for m in deps if m.startswith("whisker_opt.cli"))
    assert not bad


def test_no_module_is_oversized():
    sizes = {n: len(p.read_text().splitlines()) for n, p in MODULES.items()}
    assert {n: s for n, s in sizes.items() if s > MAX_LINES} == {}


#: Longest function, in lines (tests and their case tables excepted).
MAX_FUNCTION_LINES = 100


def test_no_function_is_oversized():
    long = {}
    for path in [*MODULES.values(), *sorted((ROOT / "benchmarks").rglob("*.py"))]:
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long[f"{path.relative_to(ROOT)}:{node.name}"] = n
    assert long == {}


def _sources(pkg: str = "whisker_opt") -> dict[str, str]:
    return {n: p.read_text() for n, p in MODULES.items() if n.split(".")[0] == pkg}


def test_f1_is_computed_in_one_place():
    # the mean absolute gap of two curves: experiment/objective.py alone
    pattern = re.compile(r"mean\(\s*np\.abs\(")
    homes = sorted(n for n, s in _sources().items() if pattern.search(s))
    assert homes == ["whisker_opt.experiment.objective"]


def test_genes_and_their_design_fields_are_listed_in_one_place():
    pattern = re.compile(r"""["']alpha["'],\s*["']l["'],\s*["']t["']""")
    homes = sorted(n for n, s in _sources().items() if pattern.search(s))
    assert homes == ["whisker_opt.genes"]
    # no other module maps genes onto design fields itself
    mapping = re.compile(r"""alpha=float\(genes""")
    assert sorted(n for n, s in _sources().items() if mapping.search(s)) == []


def test_preset_names_are_listed_in_one_place():
    pattern = re.compile(r"""["']coarse["'],\s*["']default["'],\s*["']fine["']""")
    homes = sorted(n for pkg in ("whisker_opt", "geometry") for n, s in _sources(pkg).items() if pattern.search(s))
    assert homes == []  # PRESETS is a dict literal; its names are PRESET_NAMES = tuple(PRESETS)
    from whisker_opt.experiment.fidelity import PRESET_NAMES, PRESETS

    assert PRESET_NAMES == tuple(PRESETS) == ("coarse", "default", "level2", "fine", "level3", "level4")


def test_the_project_speaks_of_itself_only():
    """No pointer to documents outside the repository or to a tracker's numbering."""
    import subprocess

    files = subprocess.run(["git", "ls-files", "*.py", "*.md", "*.yaml"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    pattern = re.compile("S" + "PEC|" + "shared" + "/|" + "(?i:issue)" + r"s? #?[0-9]")
    hits = [f"{f}:{i}" for f in files if (ROOT / f).is_file()
            for i, line in enumerate((ROOT / f).read_text(errors="replace").splitlines(), 1) if pattern.search(line)]
    assert hits == []


def _reached(name: str) -> set[str]:
    """Every project module ``name`` imports, directly or through others (lazy imports included)."""
    seen, todo = set(), [name]
    while todo:
        for m in GRAPH.get(todo.pop(), ()):
            if m not in seen:
                seen.add(m)
                todo.append(m)
    return seen


@pytest.mark.parametrize("algorithm", ["whisker_opt.optimise.ga", "whisker_opt.optimise.nsga2"])
def test_the_algorithms_write_no_files(algorithm):
    # the algorithms hand each generation to a recorder (optimise/recorder.py); files and plots are output/'s
    assert sorted(m for m in _reached(algorithm) if m.split(".")[:2] == ["whisker_opt", "output"]) == []


def test_a_forbidden_import_would_be_found():
    assert "whisker_opt.output.storage" in _reached("whisker_opt.optimise.runner")


def test_output_imports_nothing_of_optimise():
    bad = sorted(f"{n} -> {m}" for n, deps in GRAPH.items() if n.startswith("whisker_opt.output")
                 for m in deps if m.startswith("whisker_opt.optimise"))
    assert not bad
