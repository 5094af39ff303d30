"""More families of the bad-input harness: wall laws and law sets, genes over wall-law keys, writers into
another command's folder, doctored state files, and studies interrupted with SIGINT and run again.

The first four are :class:`~tests.bad_input_harness.Case` s like those of :mod:`tests.bad_input_cases` (each
refused with exit 2 in one line, nothing written, the folders it reads unchanged), named ``[family] ...``;
:func:`interrupted_studies` runs ``compensate --map`` and ``calibrate`` (the beam model in place of the FE
scenes, :func:`tests.test_study_resume.patch`) in a child, sends SIGINT once the journal holds work, checks
the interrupt (exit 130, one line naming the folder), doctors a copy of the journal (refused, exit 2, the copy
unchanged) and runs the same command again: it must continue in the same folder (exit 0, the result there,
no journal left, no other folder).
"""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from tests.bad_input_harness import Case, Workspace, _tree_digest
from tests.subprocess_run import REPO, child_env

#: The families, by the tag that starts their cases' names.
FAMILIES = ("[laws]", "[genes]", "[writers]", "[state]", "[interrupted]")


def build_family_cases(w: Workspace) -> list[Case]:
    """The cases of the families wall laws, genes, writers and state files."""
    cases: list[Case] = []

    def add(name, argv, expect=2, absent=(), frozen=(), words=()):
        cases.append(Case(name, [str(a) for a in argv], expect, tuple(absent), tuple(frozen), tuple(words)))

    good, out, run = w.good, w.root / "outs", w.run
    sets = lambda *kv: [a for item in kv for a in ("--set", item)]  # noqa: E731
    # ------------------------------------------------------------------ wall laws and law sets
    for label, kv, words in (
            ("wall_slope without the calibrated law", ["material.wall_slope=5"], ("material.wall_slope=5",)),
            ("sliding at design.t 1.5", ["material.wall_law=sliding", "design.t=1.5"], ("design.t=1.5", "sliding")),
            ("sliding, gene t from 1.5", ["material.wall_law=sliding", "optimiser.genes.t=[1.5, 6]"],
             ("t=1.5", "sliding")),
            ("sliding, gene Q_i up to 0.9", ["material.wall_law=sliding", "optimiser.genes.Q_i=[0.01, 0.9]"],
             ("Q_i=0.9", "sliding")),
            ("law set with an unknown law", ["optimiser.wall_laws.laws=[embedded, bogus]"],
             ("optimiser.wall_laws", "bogus")),
            ("law set naming a law twice", ["optimiser.wall_laws.laws=[embedded, embedded]"],
             ("optimiser.wall_laws",)),
            ("law set of one law", ["optimiser.wall_laws.laws=[embedded]"], ("optimiser.wall_laws",)),
            ("law set not a list", ["optimiser.wall_laws.laws=7"], ("optimiser.wall_laws",)),
            ("law set with sliding, gene l up to 40", ["optimiser.wall_laws.laws=[embedded, sliding]",
                                                       "optimiser.genes.l=[10, 40]"], ("optimiser.wall_laws",)),
            ("law set and robust together", ["optimiser.wall_laws.laws=[embedded, sliding]",
                                             "optimiser.robust.k=1"], ("robust", "wall_laws"))):
        for cmd in ("run", "simulate"):
            dest = out / f"laws_{cmd}_{len(cases)}"
            add(f"[laws] {cmd} {label}", [cmd, good, *sets(*kv), "--out", dest], absent=[dest], words=words)
    # ------------------------------------------------------------------ genes over wall-law keys
    for label, kv, words in (
            ("gene wall_slope without the calibrated law", ["optimiser.genes.wall_slope=[-1, 2]"],
             ("optimiser.genes.wall_slope", "calibrated")),
            ("gene wall_slope beyond its key's range", ["material.wall_law=calibrated",
                                                        "optimiser.genes.wall_slope=[-1e9, 2]"],
             ("wall_slope",)),
            ("gene wall_slope inverted", ["material.wall_law=calibrated", "optimiser.genes.wall_slope=[2, -1]"],
             ("wall_slope",)),
            ("gene wall_slope not numbers", ["material.wall_law=calibrated", "optimiser.genes.wall_slope=[a, b]"],
             ("wall_slope",)),
            ("gene wall_law (a word)", ["optimiser.genes.wall_law=[0, 1]"], ("wall_law",)),
            ("gene wall_slope under a law set", ["material.wall_law=calibrated", "optimiser.genes.wall_slope=[-1, 2]",
                                                 "optimiser.wall_laws.laws=[embedded, calibrated]"],
             ("optimiser.genes.wall_slope", "optimiser.wall_laws"))):
        dest = out / f"genes_{len(cases)}"
        add(f"[genes] run {label}", ["run", good, *sets(*kv), "--out", dest, "--no-progress"], absent=[dest],
            words=words)
    # ------------------------------------------------------------------ writers into a folder that is not theirs
    other = w.root / "other_command"
    if not other.exists():
        other.mkdir()
        (other / "config.yaml").write_text("# written by `whisker-opt simulate`: the resolved run file of the "
                                           "results in this folder\nseed: 0\n")
        (other / "scenes.json").write_text("[]\n")
    comp = w.config("families_comp.yaml", "fidelity:\n  preset: coarse\nscene:\n  Q_i: 0.1\n  trim: 5.0\n"
                    "optimiser:\n  trim: 2.0\n")
    for cmd, cfg, extra in (("export", good, []), ("compensate", comp, []),
                            ("compensate --map", comp, ["--a", "0.6", "1"]), ("simulate", good, []),
                            ("mesh", good, [])):
        argv = cmd.split()
        add(f"[writers] {cmd} --out RUN_DIR", [*argv, cfg, *extra, "--out", run], frozen=[run], words=("--out",))
        if cmd != "simulate":
            add(f"[writers] {cmd} --out a simulate folder", [*argv, cfg, *extra, "--out", other], frozen=[other],
                words=("--out",))
    # ------------------------------------------------------------------ state files
    ck = json.loads((run / "checkpoint.json").read_text())

    def doctored(edit) -> bytes:
        doc = json.loads(json.dumps(ck))
        edit(doc)
        return json.dumps(doc).encode()

    def pop0(doc):
        return doc["state"]["population"][0]

    states = {
        "individual with 3 genes": doctored(lambda d: pop0(d).update(genes=pop0(d)["genes"][:3])),
        "individual with 5 genes": doctored(lambda d: pop0(d).update(genes=pop0(d)["genes"] + [1.0])),
        "gene 1e300": doctored(lambda d: pop0(d)["genes"].__setitem__(0, 1e300)),
        "gene a string": doctored(lambda d: pop0(d)["genes"].__setitem__(0, "x")),
        "hall of fame gene 1e300": doctored(lambda d: d["state"]["hof"]["items"][0]["genes"].__setitem__(1, 1e300)),
        "generation of 5000 digits": json.dumps(ck).replace('"generation": 0,', '"generation": ' + "9" * 5000 + ",",
                                                            1).encode(),
        "seed of 5000 digits": json.dumps(ck).replace('"seed": 3', '"seed": ' + "7" * 5000, 1).encode(),
        "another run's config (trim 7)": doctored(lambda d: d["config"].update(trim=7.0)),
        "another run's genes box": doctored(lambda d: d["config"]["genes"].update(alpha={"lo": 1.0, "hi": 2.0})),
        "truncated": (run / "checkpoint.json").read_bytes()[:500],
        "corrupt byte": (run / "checkpoint.json").read_bytes().replace(b'"state"', b'"st\xffte"', 1),
    }
    for label, data in states.items():
        for cmd, extra in (("report", []), ("resume", ["--no-progress"]), ("verify", ["--preset", "coarse",
                                                                                     "--top", "1"])):
            # a copy each: cases run at once, and a command's lock would show in another's folder
            d = w.run_copy(f"state_{cmd}_" + "".join(c if c.isalnum() else "_" for c in label),
                           {"checkpoint.json": data})
            add(f"[state] {cmd} checkpoint {label}", [cmd, d, *extra], frozen=[d], words=("checkpoint.json",))
    return cases


@dataclass
class StudyOutcome:
    """What one interrupted study did: its steps, each ``(label, exit, expected, stderr)``, and problems."""

    name: str
    steps: list = field(default_factory=list)
    problems: list = field(default_factory=list)
    seconds: float = 0.0
    wrote_refused: bool = False

    @property
    def traceback(self) -> bool:
        return any("Traceback (most recent call last)" in s[3] for s in self.steps)

    @property
    def wrong_exits(self) -> int:
        return sum(s[1] != s[2] for s in self.steps)


def _child(kind: str, root: Path, sleep_s: float, journal: Path | None = None, hold_at: int = 0) -> subprocess.Popen:
    """The study ``kind`` in a child process on the beam model; with ``hold_at`` > 0 it blocks (until signalled)
    at its first model call once ``journal`` holds that many finished pieces."""
    from tests.test_study_resume import CHILD

    return subprocess.Popen([sys.executable, "-c", CHILD.format(repo=str(REPO)), kind, str(root), str(sleep_s),
                             str(journal or ""), str(hold_at)],
                            cwd=root, env=child_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            stdin=subprocess.DEVNULL)


def _pieces(path: Path) -> int:
    try:
        return len(json.loads(path.read_text())["done"])
    except (OSError, ValueError, KeyError, TypeError):
        return 0


def interrupted_study(kind: str, root: Path, timeout: float = 300.0) -> StudyOutcome:
    """SIGINT ``kind`` (``compensate`` with ``--map`` or ``calibrate``) once its journal holds work, doctor a copy
    of the journal (refused), then run it again: it must end in the same folder."""
    from tests.test_study_resume import STUDIES

    journal_name, result_name = STUDIES[kind]
    o = StudyOutcome(f"[interrupted] {kind}{' --map' if kind == 'compensate' else ''} SIGINT, then again")
    t0 = time.monotonic()
    root.mkdir(parents=True, exist_ok=True)
    folder, journal = root / "out", root / "out" / journal_name
    proc = _child(kind, root, 0.0, journal, hold_at=3)  # held once 3 pieces are kept: the signal cannot come late
    deadline = time.monotonic() + timeout
    while proc.poll() is None and _pieces(journal) < 3 and time.monotonic() < deadline:
        time.sleep(0.02)
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.wait(60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(30)
    err = proc.stderr.read().decode(errors="replace")
    proc.stderr.close()
    o.steps.append(("SIGINT", proc.returncode, 130, err))
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("INFO", "WARNING"))]
    if len(lines) != 1 or str(folder) not in lines[0]:
        o.problems.append(f"the interrupt said {len(lines)} lines, not one naming {folder}")
    if not journal.is_file():
        o.problems.append("no journal kept")
    # a doctored journal (one piece changed by hand) is refused and left as it was; then put back
    kept = journal.read_bytes() if journal.is_file() else b""
    doc = json.loads(kept or b"{}")
    if doc.get("done"):
        key = next(iter(doc["done"]))
        doc["done"][key] = 12345.0 if not isinstance(doc["done"][key], (int, float)) else doc["done"][key] + 1.0
        journal.write_text(json.dumps(doc))
        before = _tree_digest(folder)
        again = _child(kind, root, 0.0)
        _, err2 = again.communicate(timeout=timeout)
        err2 = err2.decode(errors="replace")
        o.steps.append(("doctored journal", again.returncode, 2, err2))
        if _tree_digest(folder) != before:
            o.problems.append("the folder of the doctored journal was changed")
            o.wrote_refused = True
        if journal_name not in err2:
            o.problems.append("the refusal does not name the journal")
        journal.write_bytes(kept)
    # the same command again continues in the same folder
    again = _child(kind, root, 0.0)
    _, err3 = again.communicate(timeout=timeout)
    o.steps.append(("again", again.returncode, 0, err3.decode(errors="replace")))
    if not (folder / result_name).is_file():
        o.problems.append(f"no {result_name} in {folder}")
    if journal.exists():
        o.problems.append("the journal was left")
    folders = sorted(p.name for p in root.iterdir() if p.is_dir() and p.name != "data")  # data: the measurements
    if folders != ["out"]:
        o.problems.append(f"folders: {folders}, expected only out")
    o.problems += [f"{label}: exit {rc}, expected {exp}" for label, rc, exp, _ in o.steps if rc != exp]
    o.problems += [f"{label}: traceback" for label, _, _, e in o.steps if "Traceback (most recent" in e]
    o.seconds = time.monotonic() - t0
    return o


def interrupted_studies(root: Path) -> list[StudyOutcome]:
    """:func:`interrupted_study` of ``compensate --map`` and ``calibrate``."""
    return [interrupted_study(kind, Path(root) / f"interrupted_{kind}") for kind in ("compensate", "calibrate")]
