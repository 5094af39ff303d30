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


def _modules(root: Path = ROOT) -> dict[str, Path]:
    mods = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            mods[name] = path
    return mods


MODULES = _modules()


def _imports(name: str, path: Path, modules: dict[str, Path] = MODULES) -> set[str]:
    """Project modules that ``name`` imports (resolved to the longest known module name of ``modules``)."""
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
            while t and t not in modules:
                t = t.rpartition(".")[0]
            if t and t != name:
                out.add(t)
    return out


def _graph(root: Path = ROOT) -> dict[str, set[str]]:
    """The import graph of the tree at ``root``: module -> the project modules it imports (lazy ones too)."""
    modules = MODULES if root == ROOT else _modules(root)
    return {name: _imports(name, path, modules) for name, path in modules.items()}


GRAPH = _graph()


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

    assert PRESET_NAMES == tuple(PRESETS) == ("coarse", "default", "level2", "fine", "level3", "level4",
                                                  "reference")


def _numbers(source: str) -> set[float]:
    """The numeric literals of a module's code (comments and docstrings left out)."""
    import io
    import tokenize

    return {float(ast.literal_eval(t.string)) for t in tokenize.generate_tokens(io.StringIO(source).readline)
            if t.type == tokenize.NUMBER and not t.string.endswith(("j", "J"))}


def test_the_materials_are_held_in_one_place():
    # C10 of the rubber (and μ = 2 C10), the fibre's modulus, Poisson ratio and diameter: geometry/materials.py alone
    constants = {0.14, 0.28, 31067.0, 0.36, 0.38}
    homes = sorted(n for pkg in ("whisker_opt", "geometry") for n, s in _sources(pkg).items()
                   if _numbers(s) & constants)
    assert homes == ["geometry.materials"]


def test_mid_chamber_is_computed_in_one_place():
    pattern = re.compile(r"\(\s*\w+\.c\s*\+\s*\w+\.l\s*\)")
    homes = sorted(n for pkg in ("whisker_opt", "geometry") for n, s in _sources(pkg).items() if pattern.search(s))
    assert homes == ["whisker_opt.wall.law"]

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


# --------------------------------------------------------------------------- the layers inside whisker_opt/

#: The layers inside ``whisker_opt/``, lowest first, declared once (CONTRIBUTING.md draws them from here). A unit
#: is a sub-package (``wall``) or a top-level module (``genes``; ``__init__`` is the package's face). A module
#: imports its own unit and the units of lower layers only, lazy imports inside functions included; the units
#: of one layer import nothing of each other.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("numfmt", "wall"),
    ("experiment",),
    ("genes",),
    ("config", "output"),
    ("optimise",),
    ("wiring",),
    ("analysis",),
    ("calibration", "wallcell", "report"),
    ("workflows", "robustness"),
    ("compensation", "export"),
    ("viewer", "api"),
    ("__init__",),
    ("cli",),
)


def _unit(module: str) -> str | None:
    """The unit of ``whisker_opt`` that holds ``module`` (None outside the package)."""
    parts = module.split(".")
    if parts[0] != "whisker_opt":
        return None
    return parts[1] if len(parts) > 1 else "__init__"


def unplaced_units(graph: dict[str, set[str]], layers=LAYERS) -> list[str]:
    """Units of ``whisker_opt`` in ``graph`` that stand in no layer, or in more than one."""
    placed = [u for layer in layers for u in layer]
    units = {_unit(n) for n in graph} - {None}
    return sorted(u for u in units if placed.count(u) != 1)


def upward_imports(graph: dict[str, set[str]], layers=LAYERS) -> list[str]:
    """The imports inside ``whisker_opt`` that break ``layers``: into a higher layer, or into another unit of
    the importer's own layer, one line per edge ``importer -> imported`` (lazy imports included)."""
    level = {u: i for i, layer in enumerate(layers) for u in layer}
    bad = []
    for n, deps in graph.items():
        a = _unit(n)
        for m in deps:
            b = _unit(m)
            if a is None or b is None or a == b or a not in level or b not in level:
                continue
            if level[b] >= level[a]:
                bad.append(f"{n} -> {m}")
    return sorted(bad)


def unit_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The import graph between the units of ``whisker_opt`` (sub-packages and top-level modules)."""
    out: dict[str, set[str]] = {}
    for n, deps in graph.items():
        a = _unit(n)
        if a is not None:
            out.setdefault(a, set()).update(b for b in map(_unit, deps) if b not in (None, a))
    return out


def unit_knots(graph: dict[str, set[str]]) -> list[list[str]]:
    """The knots among the units of ``whisker_opt``: each a set of two or more units that all reach each
    other through imports (the strongly connected components of :func:`unit_graph`), sorted."""
    units = unit_graph(graph)
    reach = {u: set() for u in units}
    for u in units:
        todo = list(units[u])
        while todo:
            v = todo.pop()
            if v not in reach[u]:
                reach[u].add(v)
                todo.extend(units.get(v, ()))
    knots = {frozenset({u} | {v for v in reach[u] if u in reach.get(v, ())}) for u in units}
    return sorted(sorted(k) for k in knots if len(k) > 1)


def layer_diagram(layers=LAYERS, width: int = 112) -> str:
    """The layers as CONTRIBUTING.md draws them, lowest first: ``a/, b.py  ->  c/ ...``, wrapped."""
    names = [", ".join(f"{u}/" if (ROOT / "whisker_opt" / u).is_dir() else f"{u}.py" for u in layer)
             for layer in layers]
    lines = [names[0]]
    for name in names[1:]:
        if len(lines[-1]) + len(name) + 5 > width:
            lines.append("    ->  " + name)
        else:
            lines[-1] += "  ->  " + name
    return "\n".join(lines)


def test_every_unit_of_whisker_opt_stands_in_one_layer():
    assert unplaced_units(GRAPH) == []


def test_whisker_opt_imports_run_down_its_layers():
    assert upward_imports(GRAPH) == []


def test_no_knot_among_the_units_of_whisker_opt():
    assert unit_knots(GRAPH) == []


def test_a_broken_layer_and_a_knot_would_be_found():
    graph = {"whisker_opt.genes": {"whisker_opt.wall.law"}, "whisker_opt.wall.law": set(),
             "whisker_opt.wall.table": {"whisker_opt.genes"},  # a lazy import counts as any other
             "whisker_opt.numfmt": {"whisker_opt.wall.law"}}  # a sibling in the same layer
    layers = (("numfmt", "wall"), ("genes",))
    assert upward_imports(graph, layers) == ["whisker_opt.numfmt -> whisker_opt.wall.law",
                                             "whisker_opt.wall.table -> whisker_opt.genes"]
    assert unit_knots(graph) == [["genes", "wall"]]
    assert unplaced_units({**graph, "whisker_opt.api": set()}, layers) == ["api"]


def test_contributing_draws_the_layers():
    assert layer_diagram() in (ROOT / "CONTRIBUTING.md").read_text()


if __name__ == "__main__":  # the counts of a tree: python3 tests/test_architecture.py [ROOT]
    import sys

    graph = _graph(Path(sys.argv[1]).resolve()) if len(sys.argv) > 1 else GRAPH
    print(f"imports running up the layers of whisker_opt/: {len(upward_imports(graph))}")
    print("\n".join(f"  {line}" for line in upward_imports(graph)))
    print(f"units outside the layers: {unplaced_units(graph)}")
    print(f"knots among the units of whisker_opt/: {len(unit_knots(graph))} {unit_knots(graph)}")
