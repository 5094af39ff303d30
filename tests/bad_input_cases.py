"""The hand-made bad inputs of the bad-input harness (:mod:`tests.bad_input_harness`), by subcommand.

:func:`build_cases` writes the fixtures into a :class:`~tests.bad_input_harness.Workspace` (whose
fixture run must exist) and returns every case; the groups below add theirs through ``add``.
"""

from __future__ import annotations

import pickle
from dataclasses import dataclass
from pathlib import Path

from tests.bad_input_harness import (COMPENSATE_FAILS, GARBAGE, NON_UTF8, SOLVE_FAILS_LATE, Case, Workspace,
                                     _dead_display, _free_port, _listen)


#: Run files whose wall law or mesh size no evaluation could use, refused where the config is validated:
#: label -> (run-file text, the words of the one line). Each also reaches every command through --set.
MODEL_RANGES = {
    "wall_slope without the calibrated law": ("material:\n  wall_slope: 5\n",
                                              ("material.wall_slope=5", "'calibrated'", "'embedded'")),
    "wall_slope with the sliding law": ("material:\n  wall_law: sliding\n  wall_slope: 5\n",
                                        ("material.wall_slope=5", "'calibrated'", "'sliding'")),
    "wall_slope gene without the calibrated law": ("optimiser:\n  genes:\n    wall_slope: [-1, 2]\n",
                                                   ("optimiser.genes.wall_slope=[-1, 2]", "'calibrated'")),
    "wall_slope gene under a law set": ("material:\n  wall_law: calibrated\noptimiser:\n  genes:\n"
                                        "    wall_slope: [-1, 2]\n  wall_laws:\n    laws: [embedded, calibrated]\n",
                                        ("optimiser.genes.wall_slope=[-1, 2]", "optimiser.wall_laws", "'embedded'")),
    "calibrated slope without stiffness at scene.Q_i": ("material:\n  wall_law: calibrated\n  wall_slope: -4\n"
                                                        "scene:\n  Q_i: 0.5\n",
                                                        ("material.wall_slope=-4", "scene.Q_i=0.5", "below 0.05")),
    "sliding law at design.t 1.5": ("material:\n  wall_law: sliding\ndesign:\n  t: 1.5\n",
                                    ("design.t=1.5", "'sliding'", "t 2..6 mm", "r_i + t 7.42..8.91 mm")),
    "sliding law at scene.Q_i 0.5": ("material:\n  wall_law: sliding\nscene:\n  Q_i: 0.5\n",
                                     ("scene.Q_i=0.5", "'sliding'", "Q 0..0.2 MPa")),
    "sliding law, gene Q_i up to 1": ("material:\n  wall_law: sliding\noptimiser:\n  genes:\n    Q_i: [0.01, 1]\n",
                                      ("optimiser.genes", "Q_i=1", "'sliding'", "Q 0..0.2 MPa")),
    "sliding law, gene t from 1.5": ("material:\n  wall_law: sliding\noptimiser:\n  genes:\n    t: [1.5, 6]\n",
                                     ("optimiser.genes", "t=1.5", "'sliding'", "t 2..6 mm")),
    "sliding in a law set, gene l up to 40": ("optimiser:\n  genes:\n    l: [10, 40]\n  wall_laws:\n"
                                              "    laws: [embedded, sliding]\n",
                                              ("optimiser.genes", "l=40", "optimiser.wall_laws", "r_i + t 7.42")),
    "fidelity.h_wall below the mesher's": ("fidelity:\n  h_wall: 0.01\n", ("fidelity.h_wall", "0.01", "[0.05, 10]")),
    "fidelity.h_body below the mesher's": ("fidelity:\n  h_body: 0.01\n", ("fidelity.h_body", "0.01", "[0.05, 50]")),
}


def runnable(text: str) -> str:
    """A :data:`MODEL_RANGES` text with ``scene.trim: 5`` (``simulate`` needs a trim for its pair), so that the
    range it breaks is the one thing wrong with it, on the coarse preset (cheap if it were solved)."""
    import yaml

    data = yaml.safe_load(text)
    data.setdefault("scene", {})["trim"] = 5.0
    data.setdefault("fidelity", {}).setdefault("preset", "coarse")
    return yaml.safe_dump(data, sort_keys=False)


def model_range_settings(text: str) -> list[str]:
    """The ``--set KEY=VALUE`` arguments that make the same run file of a :data:`MODEL_RANGES` text."""
    import yaml

    def flat(node, prefix):
        for k, v in node.items():
            if isinstance(v, dict):
                yield from flat(v, f"{prefix}{k}.")
            else:
                yield f"{prefix}{k}={yaml.safe_dump(v, default_flow_style=True).strip().removesuffix('...').strip()}"

    return [a for item in flat(yaml.safe_load(text), "") for a in ("--set", item)]


@dataclass(frozen=True)
class Shared:
    """Fixtures that several groups of cases use: the output folder, the good config, the bad configs
    (name -> (path, the word the error must name)) and configs whose results folder cannot be written."""

    out: Path
    good: Path
    bad_cfgs: dict
    results_under_file: Path
    results_read_only: Path
    results_is_file: Path


def shared(w: Workspace) -> Shared:
    """Write the fixtures of :class:`Shared` into the workspace."""
    bad_cfgs = {
        "missing": (w.root / "configs" / "no_such.yaml", "no_such.yaml"),
        "directory": (w.root, str(w.root)),
        "empty": (w.config("empty.yaml", ""), "empty.yaml"),
        "non_utf8": (w.config("non_utf8.yaml", NON_UTF8), "non_utf8.yaml"),
        "binary": (w.config("binary.yaml", GARBAGE), "binary.yaml"),
        "list": (w.config("list.yaml", "- 1\n- 2\n"), "list.yaml"),
        "yaml_syntax": (w.config("syntax.yaml", "scene: [1, 2\n"), "syntax.yaml"),
        "unknown_key": (w.config("unknown.yaml", "design:\n  alpah: 3\n"), "alpah"),
        "out_of_range": (w.config("range.yaml", "design:\n  t: -1\n"), "design.t"),
        "nan_value": (w.config("nan.yaml", "scene:\n  deflection: .nan\n"), "deflection"),
        "impossible_design": (w.config("cone.yaml", "design:\n  alpha: 9.0\nscene:\n  trim: 5.0\n"), "alpha"),
    }
    trim = "scene:\n  trim: 5.0\n"  # simulate needs a trim for its pair
    results_under_file = w.config("results_under_file.yaml", f"{trim}output:\n  results_dir: {w.afile}/sub\n")
    results_read_only = w.config("results_read_only.yaml", f"{trim}output:\n  results_dir: {w.ro}\n")
    results_is_file = w.config("results_is_file.yaml", f"{trim}output:\n  results_dir: {w.afile}\n")

    return Shared(w.root / "outs", w.good, bad_cfgs, results_under_file, results_read_only, results_is_file)


def build_cases(w: Workspace) -> list[Case]:
    """Every case, in subcommand order (the fixtures are written on the way)."""
    cases: list[Case] = []

    def add(name, argv, expect=2, absent=(), frozen=(), words=(), slow=False, env=None, present=()):
        cases.append(Case(name, [str(a) for a in argv], expect, tuple(absent), tuple(frozen), tuple(words), slow,
                          dict(env or {}), tuple(present)))

    s = shared(w)
    for group in (commands_and_configs, damaged_run_directories, studies, view_and_file_system):
        group(w, add, s)
    faults(w, add, s.out)
    return cases


def commands_and_configs(w: Workspace, add, s: Shared) -> None:
    """The command line itself, then bad configs and options of mesh, simulate and run."""
    out, good, bad_cfgs = s.out, s.good, s.bad_cfgs
    results_under_file, results_read_only, results_is_file = s.results_under_file, s.results_read_only, s.results_is_file
    # ------------------------------------------------------------------ global
    add("no command", [], words=("COMMAND",))
    add("unknown command", ["frobnicate"], words=("frobnicate",))
    add("-v without a command", ["-v"], words=("COMMAND",))

    # ------------------------------------------------------------------ mesh
    for k, (cfg, word) in bad_cfgs.items():
        add(f"mesh config {k}", ["mesh", cfg, "--out", out / f"mesh_{k}"], absent=[out / f"mesh_{k}"], words=(word,))
    add("mesh no config", ["mesh"], words=("config",))
    for v in ("nan", "inf", "-inf", "1e309", "-1", "101", "abc", "", "0x10"):
        add(f"mesh --trim {v!r}", ["mesh", good, "--trim", v, "--out", out / "mesh_trim"], absent=[out / "mesh_trim"],
            words=("--trim",))
    add("mesh --trim past the chamber", ["mesh", good, "--trim", "60", "--out", out / "mesh_trim60"],
        absent=[out / "mesh_trim60"], words=("trim",))
    add("mesh --method bogus", ["mesh", good, "--method", "bogus"], words=("--method",))
    add("mesh --out under a file", ["mesh", good, "--out", w.afile / "sub"], words=("--out",))
    add("mesh --out is a file", ["mesh", good, "--out", w.afile], frozen=[w.afile], words=("--out",))
    add("mesh --out read-only", ["mesh", good, "--out", w.ro], absent=[w.ro], words=("--out",))
    add("mesh --out empty string", ["mesh", good, "--out", ""], words=("--out",))
    add("mesh results_dir under a file", ["mesh", results_under_file], words=("results_dir",))
    add("mesh results_dir read-only", ["mesh", results_read_only], words=("results_dir",))
    add("mesh results_dir is a file", ["mesh", results_is_file], frozen=[w.afile], words=("results_dir",))

    # ------------------------------------------------------------------ simulate
    for k in ("missing", "empty", "non_utf8", "binary", "list", "unknown_key", "nan_value", "impossible_design"):
        cfg, word = bad_cfgs[k]
        add(f"simulate config {k}", ["simulate", cfg, "--out", out / f"sim_{k}"], absent=[out / f"sim_{k}"],
            words=(word,))
    pair0 = w.config("pair_trim0.yaml", "scene:\n  pair: true\n  trim: 0\n")
    add("simulate pair with trim 0", ["simulate", pair0, "--out", out / "sim_pair0"], absent=[out / "sim_pair0"],
        words=("scene.trim",))
    add("simulate --out under a file", ["simulate", good, "--out", w.afile / "sub"], words=("--out",))
    add("simulate --out is a file", ["simulate", good, "--out", w.afile], frozen=[w.afile], words=("--out",))
    add("simulate --out read-only", ["simulate", good, "--out", w.ro], words=("--out",))
    add("simulate results_dir under a file", ["simulate", results_under_file], words=("results_dir",))
    add("simulate results_dir read-only", ["simulate", results_read_only], words=("results_dir",))
    add("simulate unknown option", ["simulate", good, "--trim", "1"], words=("--trim",))
    late = w.config("solve_fails_late.yaml", SOLVE_FAILS_LATE)
    add("simulate solve fails in the 2nd scene", ["simulate", late, "--out", out / "sim_fails"], expect=3,
        words=("trimmed_uncompensated", "intact"), slow=True)

    # ------------------------------------------------------------------ run
    for k in ("missing", "empty", "non_utf8", "binary", "list", "unknown_key", "impossible_design"):
        cfg, word = bad_cfgs[k]
        add(f"run config {k}", ["run", cfg, "--out", out / f"run_{k}", "--no-progress"], absent=[out / f"run_{k}"],
            words=(word,))
    pop1 = w.config("pop1.yaml", "optimiser:\n  ga:\n    population: 1\n")
    add("run optimiser.ga.population 1", ["run", pop1, "--out", out / "run_pop1"], absent=[out / "run_pop1"],
        words=("population",))
    for v in ("0", "-1", "1001", "abc", "nan", "1.5", ""):
        add(f"run --verify-top {v!r}", ["run", good, "--out", out / "run_vt", "--verify", "coarse", "--verify-top", v],
            absent=[out / "run_vt"], words=("--verify-top",))
    add("run --verify bogus", ["run", good, "--verify", "bogus"], words=("--verify",))
    add("run --out under a file", ["run", good, "--out", w.afile / "sub", "--no-progress"], words=("--out",))
    add("run --out is a file", ["run", good, "--out", w.afile, "--no-progress"], frozen=[w.afile], words=("--out",))
    add("run --out read-only", ["run", good, "--out", w.ro, "--no-progress"], words=("--out",))
    add("run --out holds a run", ["run", good, "--out", w.run, "--no-progress"], frozen=[w.run],
        words=("already holds a run",))
    add("run results_dir under a file", ["run", results_under_file, "--no-progress"], words=("results_dir",))
    add("run results_dir read-only", ["run", results_read_only, "--no-progress"], words=("results_dir",))

    # ------------------------------------------------------------------ wall laws and mesh sizes out of range
    for i, (label, (text, words)) in enumerate(MODEL_RANGES.items()):
        cfg = w.config(f"model_range_{i}.yaml", runnable(text))
        for cmd, extra in (("mesh", []), ("simulate", []), ("run", ["--no-progress"])):
            dest = out / f"{cmd}_model_range_{i}"
            add(f"{cmd} {label}", [cmd, cfg, "--out", dest, *extra], absent=[dest], words=words)
        dest = out / f"simulate_model_range_set_{i}"
        add(f"simulate --set {label}", ["simulate", good, *model_range_settings(text), "--out", dest], absent=[dest],
            words=words)


def damaged_run_directories(w: Workspace, add, s: Shared) -> None:
    """Run directories with damaged, missing or unreadable files (resume, report, verify)."""
    out, good, bad_cfgs = s.out, s.good, s.bad_cfgs
    # ------------------------------------------------------------------ damaged run directories
    ck = w.run / "checkpoint.json"
    ck_bytes = ck.read_bytes()
    damaged = {
        "checkpoint truncated": ({"checkpoint.json": ck_bytes[: len(ck_bytes) // 2]}, (), "checkpoint.json"),
        "checkpoint cut by its last character": ({"checkpoint.json": ck_bytes.rstrip()[:-1]}, (), "checkpoint.json"),
        "checkpoint empty": ({"checkpoint.json": b""}, (), "checkpoint.json"),
        "checkpoint garbage": ({"checkpoint.json": GARBAGE}, (), "checkpoint.json"),
        "checkpoint text": ({"checkpoint.json": b"not a checkpoint\n"}, (), "checkpoint.json"),
        "checkpoint a pickle": ({"checkpoint.json": pickle.dumps([1, 2, 3])}, (), "checkpoint.json"),
        "checkpoint other format": ({"checkpoint.json": b'{"format": "whisker-opt GA state", "version": 99}'}, (), "checkpoint.json"),
        "checkpoint missing keys": ({"checkpoint.json": b'{"format": "whisker-opt GA state", "version": 2}'}, (), "checkpoint.json"),
        "checkpoint is a folder": ({"checkpoint.json": None}, (), "checkpoint.json"),
        "optimiser.json garbage": ({"optimiser.json": GARBAGE}, ("checkpoint.json",), "optimiser.json"),
        "optimiser.json truncated": ({"optimiser.json": b'{"seed": 3, "optimiser": {'}, ("checkpoint.json",),
                                     "optimiser.json"),
        "optimiser.json a list": ({"optimiser.json": b"[1, 2]"}, ("checkpoint.json",), "optimiser.json"),
        "optimiser.json no seed": ({"optimiser.json": b'{"optimiser": {}}'}, ("checkpoint.json",), "optimiser.json"),
        "optimiser.json bad value": ({"optimiser.json": b'{"seed": 1, "optimiser": {"ga": {"population": 1}}}'},
                                     ("checkpoint.json",), "optimiser.json"),
        "optimiser.json seed text": ({"optimiser.json": b'{"seed": "x", "optimiser": {}}'}, ("checkpoint.json",),
                                     "optimiser.json"),
        "no checkpoint nor optimiser.json": ({}, ("checkpoint.json", "optimiser.json"), "checkpoint.json"),
        "config.yaml garbage": ({"config.yaml": GARBAGE}, (), "config.yaml"),
        "config.yaml non-UTF-8": ({"config.yaml": NON_UTF8}, (), "config.yaml"),
        "config.yaml a list": ({"config.yaml": b"- 1\n"}, (), "config.yaml"),
        "config.yaml bad key": ({"config.yaml": b"design:\n  alpah: 3\n"}, (), "config.yaml"),
        "config.yaml missing": ({}, ("config.yaml",), "config.yaml"),
        "config.yaml is a folder": ({"config.yaml": None}, (), "config.yaml"),
    }
    runs = {k: w.run_copy(k.replace(" ", "_").replace(".", "_"), dmg, rm) for k, (dmg, rm, _) in damaged.items()}
    needs_config = {"resume", "verify"}
    for cmd in ("resume", "report", "verify"):
        for k, (_, _, word) in damaged.items():
            if k.startswith("config.yaml") and cmd not in needs_config:
                continue
            if k == "no checkpoint nor optimiser.json" and cmd == "resume":
                continue  # a run killed before it wrote anything but config.yaml: resume starts it
            extra = ["--no-progress"] if cmd == "resume" else (["--preset", "coarse", "--top", "1"] if cmd == "verify"
                                                               else [])
            add(f"{cmd} {k}", [cmd, runs[k], *extra], frozen=[runs[k]], words=(word,))
    for cmd in ("resume", "report", "verify"):
        add(f"{cmd} missing dir", [cmd, w.root / "no_such_run"], words=("no_such_run",))
        add(f"{cmd} a file", [cmd, w.afile], frozen=[w.afile], words=("afile.txt",))
        empty = w.root / "runs" / "empty_dir"
        empty.mkdir(parents=True, exist_ok=True)
        add(f"{cmd} empty dir", [cmd, empty], frozen=[empty], words=("empty_dir",))
    # --from-previous
    no_prev = w.run_copy("from_prev_missing", {"checkpoint.json": GARBAGE})
    add("resume --from-previous without one", ["resume", no_prev, "--from-previous", "--no-progress"],
        frozen=[no_prev], words=("checkpoint.prev.json",))
    both = w.run_copy("from_prev_damaged", {"checkpoint.json": GARBAGE, "checkpoint.prev.json": ck_bytes[:100]})
    add("resume --from-previous damaged too", ["resume", both, "--from-previous", "--no-progress"], frozen=[both],
        words=("checkpoint.prev.json",))
    # read-only run directory: resume/report/verify write into it
    add("resume run dir under a file", ["resume", w.afile / "run"], words=("afile.txt",))
    # verify options
    for v in ("0", "-3", "1001", "abc", "nan", "2.5"):
        add(f"verify --top {v!r}", ["verify", w.run, "--top", v], frozen=[w.run], words=("--top",))
    add("verify --preset bogus", ["verify", w.run, "--preset", "bogus"], frozen=[w.run], words=("--preset",))
    add("report extra argument", ["report", w.run, "--top", "3"], frozen=[w.run], words=("--top",))


def studies(w: Workspace, add, s: Shared) -> None:
    """compensate (tables and the map), multi-objective and rubber options, robustness, calibrate."""
    out, good, bad_cfgs = s.out, s.good, s.bad_cfgs
    # ------------------------------------------------------------------ compensate
    comp = w.config("comp.yaml", "fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.1\n  deflection: 5\n"
                    "optimiser:\n  trim: 2.0\noutput:\n  results_dir: {results}\n")
    for opt, values in {
        "--step": ("0", "-1", "nan", "inf", "abc", "101", "1e309"),
        "--delta-ref": ("0", "-1", "nan", "inf", "31", "abc"),
    }.items():
        for v in values:
            add(f"compensate {opt} {v!r}", ["compensate", comp, opt, v, "--out", out / "comp"], absent=[out / "comp"],
                words=(opt,))
    add("compensate --delta-ref past scene.deflection", ["compensate", comp, "--delta-ref", "6", "--out", out / "comp"],
        absent=[out / "comp"], words=("--delta-ref",))
    add("compensate --delta-ref past scene.deflection, no --out", ["compensate", comp, "--delta-ref", "6"],
        frozen=[w.results], words=("--delta-ref",))
    for v in ("0", "1.5", "nan", "-0.5", "abc", "inf"):
        add(f"compensate --compare-a {v!r}", ["compensate", comp, "--compare-a", "0.5", v, "--out", out / "comp"],
            absent=[out / "comp"], words=("--compare-a",))
    for v in ("-0.1", "nan", "inf", "2", "abc"):
        add(f"compensate --compare-Q {v!r}", ["compensate", comp, "--compare-Q", v, "--out", out / "comp"],
            absent=[out / "comp"], words=("--compare-Q",))
    add("compensate --compare-a without values", ["compensate", comp, "--compare-a"], words=("--compare-a",))
    q0 = w.config("comp_q0.yaml", "scene:\n  Q_i: 0\n")
    add("compensate Q_i 0", ["compensate", q0, "--out", out / "comp_q0"], absent=[out / "comp_q0"], words=("Q_i",))
    for k in ("missing", "empty", "non_utf8", "list"):
        cfg, word = bad_cfgs[k]
        add(f"compensate config {k}", ["compensate", cfg, "--out", out / f"comp_{k}"], absent=[out / f"comp_{k}"],
            words=(word,))
    big_trim = w.config("comp_trim.yaml", "scene:\n  Q_i: 0.1\noptimiser:\n  trim: 60\n")
    add("compensate optimiser.trim past the chamber", ["compensate", big_trim, "--out", out / "comp_trim"],
        absent=[out / "comp_trim"], words=("trim",))
    add("compensate --out under a file", ["compensate", comp, "--out", w.afile / "sub"], words=("--out",))
    add("compensate --out is a file", ["compensate", comp, "--out", w.afile], frozen=[w.afile], words=("--out",))
    add("compensate --out read-only", ["compensate", comp, "--out", w.ro], words=("--out",))
    comp_ro = w.config("comp_ro.yaml", f"scene:\n  Q_i: 0.1\noptimiser:\n  trim: 2.0\noutput:\n  results_dir: {w.ro}\n")
    add("compensate results_dir read-only", ["compensate", comp_ro], words=("results_dir",))
    comp_uf = w.config("comp_uf.yaml", f"scene:\n  Q_i: 0.1\noptimiser:\n  trim: 2.0\noutput:\n"
                                        f"  results_dir: {w.afile}/sub\n")
    add("compensate results_dir under a file", ["compensate", comp_uf], words=("results_dir",))
    cfail = w.config("compensate_fails.yaml", COMPENSATE_FAILS)
    add("compensate solve fails", ["compensate", cfail, "--no-compare", "--out", out / "comp_fails"], expect=3,
        words=("Q",), slow=True)
    # the map
    for v in ("0", "1.5", "nan", "abc"):
        add(f"compensate --a {v!r}", ["compensate", comp, "--a", "0.5", v, "--out", out / "map"], absent=[out / "map"],
            words=("--a",))
    add("compensate --a one ratio", ["compensate", comp, "--a", "0.5", "--out", out / "map"], absent=[out / "map"],
        words=("--a",))

    # ------------------------------------------------------------------ multi-objective, rubber options
    for key, value, word in (("optimiser.algorithm", "nsga3", "optimiser.algorithm"),
                             ("optimiser.objectives", "[f1, E]", "optimiser.objectives"),
                             ("optimiser.objectives", "[]", "optimiser.objectives"),
                             ("optimiser.pareto.verify_max", "0", "verify_max"),
                             ("material.rubber", "rubber", "material.rubber"),
                             ("material.cap_rubber", "steel", "material.cap_rubber"),
                             ("material.fibre_model", "lines", "material.fibre_model"),
                             ("scene.base_support", "glued", "scene.base_support"),
                             ("optimiser.stopping.target_strain", "raw", "target_strain")):
        add(f"run --set {key}={value}", ["run", good, "--set", f"{key}={value}", "--out", out / "bad_set"],
            absent=[out / "bad_set"], words=(word,))

    # ------------------------------------------------------------------ robustness
    for opt, v in (("--samples", "1"), ("--samples", "abc"), ("--method", "guess"), ("--top", "0"),
                   ("--genes", "1,2"), ("--genes", "a,b,c,d")):
        add(f"robustness {opt} {v!r}", ["robustness", good, opt, v, "--out", out / "rob"], absent=[out / "rob"],
            words=(opt,))
    rob_bad = w.config("rob_bad.yaml", "robustness:\n  tolerances:\n    t: -0.1\n")
    add("robustness negative tolerance", ["robustness", rob_bad, "--out", out / "rob"], absent=[out / "rob"],
        words=("robustness.tolerances.t",))
    add("robustness not a run directory", ["robustness", w.root / "configs", "--out", out / "rob"],
        absent=[out / "rob"], words=("config.yaml",))

    # ------------------------------------------------------------------ calibrate
    add("calibrate without a calibration section", ["calibrate", good, "--out", out / "cal"], absent=[out / "cal"],
        words=("calibration",))
    bad_csv = w._write("cal_bad.csv", "name,trim_ref,Q_ref,trim,Q,a,delta,sigma\nx,0,0.1,5,abc,1,1,0.005\n")
    cal_base = ("calibration:\n  source: test\n  parameters:\n    - {path: material.C10, lower: 0.1, upper: 0.3, "
                "start: 0.14}\n  measurements:\n    - {file: %s, kind: restore}\n")
    cal_bad = w.config("cal_bad.yaml", cal_base % bad_csv)
    add("calibrate malformed measurement", ["calibrate", cal_bad, "--out", out / "cal"], absent=[out / "cal"],
        words=("row 1", "column Q"))
    cal_missing = w.config("cal_missing.yaml", cal_base % (w.root / "no_such.csv"))
    add("calibrate missing measurement file", ["calibrate", cal_missing, "--out", out / "cal"], absent=[out / "cal"],
        words=("no_such.csv",))
    cal_key = w.config("cal_key.yaml", (cal_base % bad_csv).replace("material.C10", "scene.nope"))
    add("calibrate unknown parameter key", ["calibrate", cal_key, "--out", out / "cal"], absent=[out / "cal"],
        words=("scene.nope",))
    cal_bounds = w.config("cal_bounds.yaml", (cal_base % bad_csv).replace("upper: 0.3", "upper: 0.05"))
    add("calibrate inverted bounds", ["calibrate", cal_bounds, "--out", out / "cal"], absent=[out / "cal"],
        words=("bounds",))


def view_and_file_system(w: Workspace, add, s: Shared) -> None:
    """view of damaged results, then paths the file system refuses."""
    out, good, bad_cfgs = s.out, s.good, s.bad_cfgs
    # ------------------------------------------------------------------ view
    shot = out / "view.png"
    run = w.run
    view_opts = {
        "--window-size": [("0", "0"), ("-1", "100"), ("100000", "100"), ("abc", "100"), ("100", "1.5"), ("49", "600"),
                          ("800",)],
        "--clim-percentile": [("-1",), ("50",), ("nan",), ("inf",), ("abc",)],
        "--delta": [("-1",), ("nan",), ("inf",), ("abc",), ("1000",)],
        "--rank": [("0",), ("-1",), ("abc",), ("1.5",), ("99999",)],
        "--eval": [("-1",), ("abc",), ("99999",), ("",)],
        "--scale": [("-1",), ("nan",), ("inf",), ("abc",), ("1e12",)],
    }
    for opt, values in view_opts.items():
        for vals in values:
            word = "eval_id" if vals == ("99999",) and opt == "--eval" else opt  # a valid id the run lacks
            add(f"view {opt} {' '.join(vals)!r}", ["view", run, opt, *vals, "--screenshot", shot], absent=[shot],
                frozen=[run], words=(word,))
    for name in ("a.xyz", "noext", "a.", ".png", "a.PNG", "a.svg"):
        p = out / name
        add(f"view --screenshot {name}", ["view", run, "--screenshot", p], absent=[p], frozen=[run],
            words=("--screenshot",))
    add("view --screenshot under a file", ["view", run, "--screenshot", w.afile / "x.png"], frozen=[run, w.afile],
        words=("--screenshot",))
    add("view --screenshot read-only", ["view", run, "--screenshot", w.ro / "x.png"], frozen=[run],
        words=("--screenshot",))
    add("view --screenshot is a folder", ["view", run, "--screenshot", w.results], frozen=[run],
        words=("--screenshot",))
    add("view --screenshot empty", ["view", run, "--screenshot", ""], frozen=[run], words=("--screenshot",))
    for opt, val in (("--field", "bogus"), ("--scene", "bogus"), ("--state", "bogus"), ("--group", "bogus"),
                     ("--group", "../.."), ("--cavity", "bogus"), ("--camera", "bogus"), ("--layout", "bogus"), ("--clim", "bogus")):
        add(f"view {opt} {val}", ["view", run, opt, val, "--screenshot", shot], absent=[shot], frozen=[run],
            words=(val if opt not in ("--cavity", "--camera", "--layout", "--clim") else opt,))
    add("view --rank with --eval", ["view", run, "--rank", "1", "--eval", "1", "--screenshot", shot], absent=[shot],
        frozen=[run], words=("--rank",))
    add("view --state with --delta", ["view", run, "--state", "deflected", "--delta", "1", "--screenshot", shot],
        absent=[shot], frozen=[run], words=("--state",))
    add("view missing source", ["view", w.root / "no_such", "--screenshot", shot], absent=[shot], words=("no_such",))
    add("view a non-VTU file", ["view", w.afile, "--screenshot", shot], absent=[shot], words=("afile.txt",))
    add("view an empty folder", ["view", w.root / "runs" / "empty_dir", "--screenshot", shot], absent=[shot],
        words=("empty_dir",))
    vtu = "best/intact_deflected.vtu"
    vtu_bytes = (run / vtu).read_bytes()
    view_damaged = {
        "VTU garbage": ({vtu: GARBAGE}, vtu),
        "VTU empty": ({vtu: b""}, vtu),
        "VTU truncated": ({vtu: vtu_bytes[: len(vtu_bytes) // 2]}, vtu),
        "VTU text": ({vtu: b"<VTKFile>\n"}, vtu),
        "scenes.json garbage": ({"best/scenes.json": GARBAGE}, "scenes.json"),
        "scenes.json a list": ({"best/scenes.json": b"[1]"}, "scenes.json"),
        "best.json garbage": ({"best.json": GARBAGE}, "best.json"),
        "best.json non-UTF-8": ({"best.json": b'{"a": "\xff"}'}, "best.json"),
        "config.yaml non-UTF-8": ({"config.yaml": NON_UTF8}, "config.yaml"),
        "evaluations.csv garbage": ({"evaluations.csv": GARBAGE}, "evaluations.csv"),
        "evaluations.csv empty": ({"evaluations.csv": b""}, "evaluations.csv"),
    }
    for k, (dmg, word) in view_damaged.items():
        d = w.run_copy("view_" + k.replace(" ", "_").replace(".", "_"), dmg)
        extra = ["--rank", "1"] if k.startswith("evaluations") else []
        add(f"view {k}", ["view", d, *extra, "--screenshot", shot], absent=[shot], frozen=[d], words=(word,))
    single = w.root / "single.vtu"
    single.write_bytes(GARBAGE)
    add("view one garbage .vtu", ["view", single, "--screenshot", shot], absent=[shot], frozen=[single],
        words=("single.vtu",))
    # ------------------------------------------------------------------ file-system refusals
    long = "a" * 300  # longer than a file name may be
    loop = w.root / "loop1"
    if not loop.is_symlink():
        (w.root / "loop2").symlink_to(loop)
        loop.symlink_to(w.root / "loop2")
    add("mesh config name too long", ["mesh", w.root / long], words=(long[:50],))
    add("mesh config /dev/null", ["mesh", "/dev/null"], words=("/dev/null",))
    add("mesh --out name too long", ["mesh", good, "--out", w.root / long], words=("--out",))
    add("mesh --out through a symlink loop", ["mesh", good, "--out", loop / "x"], words=("--out",))
    add("report name too long", ["report", w.root / long], words=(long[:50],))
    add("view source name too long", ["view", w.root / long, "--screenshot", shot], absent=[shot],
        words=(long[:50],))
    add("view --screenshot name too long", ["view", run, "--screenshot", w.root / f"{long}.png"], frozen=[run],
        words=("--screenshot",))
    add("view --list with --screenshot .xyz", ["view", run, "--list", "--screenshot", out / "l.xyz"],
        absent=[out / "l.xyz"], frozen=[run], words=("--screenshot",))


def faults(w: Workspace, add, out: Path) -> None:
    """Faults and hostile folders: dask addresses of no scheduler, dangling or hostile links in a run
    directory, JSON nested too deeply, implausible calibration inputs, a display where no X server runs."""
    good = w.good
    # ------------------------------------------------------------------ a dask scheduler that is not one
    for label, port, slow in (("nothing listens", _free_port(), False), ("garbage answers", _listen("garbage"), False),
                              ("a silent service", _listen("silent"), True)):
        add(f"run dask scheduler_address where {label}",
            ["run", good, "--set", "optimiser.executor.kind=dask", "--set",
             f"optimiser.executor.scheduler_address=tcp://127.0.0.1:{port}", "--out", out / "dask", "--no-progress"],
            absent=[out / "dask"], words=("optimiser.executor.scheduler_address", str(port)), slow=slow)
    # ------------------------------------------------------------------ links and deep JSON in run directories
    gone = w.root / "gone"
    deep = ("[" * 100_000 + "]" * 100_000).encode()
    for name in ("checkpoint.json", "checkpoint.pkl"):
        d = w.run_copy("dangling_" + name.replace(".", "_"), remove=("checkpoint.json",))
        (d / name).symlink_to(gone / name)
        for cmd, extra in (("resume", ["--no-progress"]), ("report", []),
                           ("verify", ["--preset", "coarse", "--top", "1"])):
            add(f"{cmd} {name} a dangling link", [cmd, d, *extra], frozen=[d],
                words=(name, "symbolic link", "generation 0"))
    precious = w._write("precious.txt", "a file of the user's\n")
    for name, cmds in (("run.lock", ("resume", "verify")), ("run.log", ("resume",))):
        d = w.run_copy("link_" + name.replace(".", "_"))
        (d / name).unlink(missing_ok=True)  # the fixture run wrote its own run.log
        (d / name).symlink_to(precious)
        for cmd in cmds:
            extra = ["--max-generations", "1", "--no-progress"] if cmd == "resume" else ["--preset", "coarse",
                                                                                        "--top", "1"]
            add(f"{cmd} {name} a link to another file", [cmd, d, *extra], frozen=[precious],
                words=(name, "symbolic link"))
    d = w.run_copy("deep_optimiser_json", {"optimiser.json": b'{"seed": 1, "optimiser": ' + deep + b"}"},
                   remove=("checkpoint.json",))
    for cmd, extra in (("resume", ["--no-progress"]), ("report", []), ("verify", ["--preset", "coarse", "--top", "1"])):
        add(f"{cmd} optimiser.json nested too deeply", [cmd, d, *extra], frozen=[d],
            words=("optimiser.json", "nested too deeply"))
    for rel in ("best.json", "best/scenes.json"):
        d = w.run_copy("deep_" + rel.replace("/", "_").replace(".", "_"), {rel: deep})
        add(f"view {rel} nested too deeply", ["view", d, "--screenshot", out / "deep.png"], absent=[out / "deep.png"],
            frozen=[d], words=(rel.split("/")[-1], "damaged"))
    # ------------------------------------------------------------------ calibrate: implausible inputs
    base = ("calibration:\n  source: test\n  model: beam\n  parameters:\n    - {path: material.C10, lower: %s, "
            "upper: %s, start: 0.14}\n  measurements:\n    - {file: %s, kind: extension}\n")
    for label, sigma in (("1e-300", "1e-300"), ("1e300", "1e300")):
        csv = w._write(f"cal/sigma_{label}.csv", f"Q,dl,sigma\n0.05,0.38,{sigma}\n0.1,0.82,0.01\n")
        cfg = w.config(f"cal_sigma_{label}.yaml", base % (0.05, 0.5, csv))
        add(f"calibrate sigma {label}", ["calibrate", cfg, "--out", out / "cal_sigma"], absent=[out / "cal_sigma"],
            words=("column sigma", sigma, "[1e-12, 1000]"))
    csv = w._write("cal/ok.csv", "Q,dl,sigma\n0.05,0.38,0.01\n0.1,0.82,0.01\n")
    cfg = w.config("cal_span.yaml", base % ("1e-12", 100, csv))
    add("calibrate C10 bounds [1e-12, 100]", ["calibrate", cfg, "--out", out / "cal_span"], absent=[out / "cal_span"],
        words=("calibration.parameters[0]", "material.C10", "at most 6"))
    # ------------------------------------------------------------------ view with a display where no X server runs
    display = _dead_display()
    d = w.run_copy("dead_display")
    add(f"view DISPLAY={display} with no X server", ["view", d, "--window-size", "320", "240"], expect=0,
        env={"DISPLAY": display}, present=[d / "view.png"], words=("no display answers", display, "view.png"))
