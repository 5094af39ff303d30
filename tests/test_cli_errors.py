"""Bad inputs to every command: one stderr line naming the option or file, exit status 2, no traceback,
refused before anything is computed or written.

Runs ``whisker_opt.cli.main.main`` in-process on a table of bad option values, unwritable output
folders and damaged run directories (a tiny run: coarse preset, 2 individuals, generation 0 only);
then the previous-checkpoint fallback (``resume --from-previous``) and a scene that does not
converge (exit status 3, with the scene, the load reached and the reason).
``benchmarks/reliability/bad_inputs.py`` runs many more cases as subprocesses.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import pytest

from tests.subprocess_run import tiny_run_file
from whisker_opt.cli import main as cli
from whisker_opt.optimise.checkpoint import (
    CHECKPOINT_NAME,
    PREVIOUS_NAME,
    RunDirectoryError,
    load_checkpoint,
    save_checkpoint,
)

TINY = tiny_run_file("Q_i: 0.1\ntrim: 5.0", 2.0, "{results}")


class Workspace:
    """Fixture files: a good config, a regular file, a finished tiny run."""

    def __init__(self, root: Path) -> None:
        self.root = root
        self.results = root / "results"
        self.afile = root / "afile.txt"
        self.afile.write_text("a regular file\n")
        self.good = root / "good.yaml"
        self.good.write_text(TINY.format(results=self.results))
        self.run = root / "run"

    def config(self, name: str, data: str | bytes) -> Path:
        p = self.root / name
        p.write_bytes(data if isinstance(data, bytes) else data.encode())
        return p

    def run_copy(self, name: str, files: dict[str, bytes | None]) -> Path:
        """A copy of the tiny run with files replaced (``None``: removed)."""
        d = self.root / "copies" / name
        shutil.copytree(self.run, d)
        for rel, data in files.items():
            if data is None:
                (d / rel).unlink()
            else:
                (d / rel).write_bytes(data)
        return d


@pytest.fixture(scope="module")
def ws(tmp_path_factory) -> Workspace:
    w = Workspace(tmp_path_factory.mktemp("cli_errors"))
    assert cli.main(["run", str(w.good), "--out", str(w.run), "--no-progress"]) == 0
    assert (w.run / CHECKPOINT_NAME).is_file()
    return w


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(path.rglob("*")) if path.is_dir() else [path]:
        h.update(str(p).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def _one_line(capsys, rc: int, command: str, expect: int = 2) -> str:
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == expect, err
    assert "Traceback" not in err, err
    assert len(lines) == 1, err
    assert lines[0].startswith(f"whisker-opt {command}: error: "), err
    return lines[0]


# (argv with {good}/{afile}/{run}/{out}/{root} placeholders, words the line must hold)
OPTION_CASES = [
    (["mesh", "{good}", "--trim", "nan", "--out", "{out}"], ["--trim", "not a finite number"]),
    (["mesh", "{good}", "--trim", "inf", "--out", "{out}"], ["--trim", "not a finite number"]),
    (["mesh", "{good}", "--trim", "-1", "--out", "{out}"], ["--trim", "-1", "[0, 100] mm"]),
    (["mesh", "{good}", "--trim", "101", "--out", "{out}"], ["--trim", "101", "[0, 100] mm"]),
    (["mesh", "{good}", "--trim", "abc", "--out", "{out}"], ["--trim", "'abc' is not a number"]),
    (["mesh", "{good}", "--method", "bogus"], ["--method", "bogus"]),
    (["mesh", "{good}", "--out", "{afile}/sub"], ["--out", "afile.txt is a file"]),
    (["mesh", "{good}", "--out", "{afile}"], ["--out", "exists and is a file"]),
    (["mesh", "{good}", "--out", ""], ["--out", "empty path"]),
    (["simulate", "{good}", "--out", "{afile}/sub"], ["--out", "afile.txt"]),
    (["run", "{good}", "--out", "{out}", "--verify", "coarse", "--verify-top", "0"], ["--verify-top", "1..1000"]),
    (["run", "{good}", "--out", "{out}", "--verify-top", "abc"], ["--verify-top", "not an integer"]),
    (["run", "{good}", "--out", "{afile}/sub", "--no-progress"], ["--out", "afile.txt"]),
    (["verify", "{run}", "--top", "0"], ["--top", "top=0 is outside the allowed range 1..1000"]),
    (["verify", "{run}", "--top", "nan"], ["--top", "not an integer"]),
    (["verify", "{run}", "--preset", "bogus"], ["--preset", "bogus"]),
    (["compensate", "{good}", "--step", "0", "--out", "{out}"], ["--step: 0 is outside the allowed range (0, 100] mm"]),
    (["compensate", "{good}", "--step", "nan", "--out", "{out}"], ["--step", "nan is not a finite number"]),
    (["compensate", "{good}", "--step", "1e309", "--out", "{out}"], ["--step", "not a finite number"]),
    (["compensate", "{good}", "--delta-ref", "0", "--out", "{out}"], ["--delta-ref", "(0, 30] mm"]),
    (["compensate", "{good}", "--delta-ref", "6", "--out", "{out}"], ["--delta-ref", "6", "scene.deflection = 5"]),
    (["compensate", "{good}", "--delta-ref", "6"], ["--delta-ref", "scene.deflection"]),  # no run dir made
    (["compensate", "{good}", "--compare-a", "0.5", "1.5", "--out", "{out}"], ["--compare-a", "1.5", "(0, 1]"]),
    (["compensate", "{good}", "--compare-a", "0", "--out", "{out}"], ["--compare-a", "(0, 1]"]),
    (["compensate", "{good}", "--compare-Q", "-0.1", "--out", "{out}"], ["--compare-Q", "[0, 1] MPa"]),
    (["compensate", "{good}", "--compare-Q", "inf", "--out", "{out}"], ["--compare-Q", "not a finite number"]),
    (["compensate", "{good}", "--out", "{afile}/sub"], ["--out", "afile.txt"]),
    (["view", "{run}", "--window-size", "0", "0", "--screenshot", "{out}/v.png"], ["--window-size", "50..10000"]),
    (["view", "{run}", "--window-size", "-1", "100", "--screenshot", "{out}/v.png"], ["--window-size", "-1"]),
    (["view", "{run}", "--window-size", "100000", "100", "--screenshot", "{out}/v.png"], ["--window-size", "100000"]),
    (["view", "{run}", "--window-size", "800"], ["--window-size", "2 arguments"]),
    (["view", "{run}", "--screenshot", "{out}/v.xyz"], ["--screenshot", "'.xyz'", ".png"]),
    (["view", "{run}", "--screenshot", "{out}/noext"], ["--screenshot", "no extension"]),
    (["view", "{run}", "--screenshot", "{out}/v.PNG"], ["--screenshot", "'.PNG'", "lower case"]),
    (["view", "{run}", "--screenshot", "{root}"], ["--screenshot", "is a folder"]),
    (["view", "{run}", "--screenshot", "{afile}/v.png"], ["--screenshot", "afile.txt: exists and is a file"]),
    (["view", "{run}", "--clim-percentile", "50", "--screenshot", "{out}/v.png"], ["--clim-percentile", "[0, 50) %"]),
    (["view", "{run}", "--clim-percentile", "nan", "--screenshot", "{out}/v.png"], ["--clim-percentile", "finite"]),
    (["view", "{run}", "--delta", "-1", "--screenshot", "{out}/v.png"], ["--delta", "[0, 30] mm"]),
    (["view", "{run}", "--delta", "inf", "--screenshot", "{out}/v.png"], ["--delta", "finite"]),
    (["view", "{run}", "--rank", "0", "--screenshot", "{out}/v.png"], ["--rank", "1..1000000"]),
    (["view", "{run}", "--rank", "1.5", "--screenshot", "{out}/v.png"], ["--rank", "not an integer"]),
    (["view", "{run}", "--eval", "abc", "--screenshot", "{out}/v.png"], ["--eval", "not an integer"]),
    (["view", "{run}", "--scale", "-1", "--screenshot", "{out}/v.png"], ["--scale", "[0, 1000]"]),
    (["view", "{run}", "--scale", "1e12", "--screenshot", "{out}/v.png"], ["--scale", "1e12"]),
    (["report", "{afile}"], ["afile.txt", "not a folder"]),
    (["report", "{root}/no_such_run"], ["no_such_run", "no such run directory"]),
]


@pytest.mark.parametrize(("argv", "words"), OPTION_CASES, ids=[" ".join(a[:1] + a[2:4]) for a, _ in OPTION_CASES])
def test_bad_option_is_one_line_before_anything_is_done(ws, tmp_path, capsys, argv, words):
    out = tmp_path / "out"
    subs = {"good": ws.good, "afile": ws.afile, "run": ws.run, "out": out, "root": ws.root}
    args = [a.format(**subs) for a in argv]
    before_run, before_results = _digest(ws.run), sorted(ws.results.glob("*")) if ws.results.exists() else []
    line = _one_line(capsys, cli.main(args), args[0])
    for w in words:
        assert w in line, line
    assert not out.exists()  # nothing written
    assert _digest(ws.run) == before_run
    assert (sorted(ws.results.glob("*")) if ws.results.exists() else []) == before_results


def test_unreadable_configs_name_the_file(ws, capsys):
    cases = {
        "non_utf8.yaml": (b"design:\n  D: \xff\xfe\n", "not UTF-8"),
        "empty.yaml": (b"", "empty"),
        "binary.yaml": (bytes(range(256)), "binary.yaml"),
    }
    for name, (data, word) in cases.items():
        cfg = ws.config(name, data)
        for cmd in ("mesh", "simulate", "run", "compensate"):
            line = _one_line(capsys, cli.main([cmd, str(cfg), "--out", str(ws.root / "never")]), cmd)
            assert name in line and word in line, line
    assert not (ws.root / "never").exists()


def test_results_dir_under_a_file(ws, capsys):
    cfg = ws.config("results_under_file.yaml", TINY.format(results=f"{ws.afile}/sub"))
    for cmd in ("mesh", "simulate", "run", "compensate"):
        line = _one_line(capsys, cli.main([cmd, str(cfg)]), cmd)
        assert "output.results_dir" in line and "afile.txt is a file" in line, line


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0,
                    reason="as root, a read-only mode does not stop writes (a path under a file is tested instead)")
def test_read_only_folder(ws, tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        line = _one_line(capsys, cli.main(["compensate", str(ws.good), "--out", str(ro / "sub")]), "compensate")
        assert "--out" in line and "not writable" in line, line
    finally:
        ro.chmod(0o755)


CK_DAMAGE = {
    "truncated": lambda b: b[: len(b) // 2],
    "empty": lambda b: b"",
    "garbage": lambda b: bytes(range(256)) * 8,
}


@pytest.mark.parametrize("damage", sorted(CK_DAMAGE))
@pytest.mark.parametrize("command", ["resume", "report", "verify"])
def test_damaged_checkpoint(ws, capsys, damage, command):
    data = (ws.run / CHECKPOINT_NAME).read_bytes()
    d = ws.run_copy(f"{command}_{damage}", {CHECKPOINT_NAME: CK_DAMAGE[damage](data)})
    before = _digest(d)
    extra = {"resume": ["--no-progress"], "verify": ["--preset", "coarse", "--top", "1"]}.get(command, [])
    line = _one_line(capsys, cli.main([command, str(d), *extra]), command)
    assert f"{CHECKPOINT_NAME}: not a whisker-opt checkpoint" in line, line
    assert ("empty file" if damage == "empty" else "truncated or damaged") in line, line
    assert _digest(d) == before


@pytest.mark.parametrize(("name", "data", "command", "words"), [
    ("optimiser.json", b'{"seed": 3, "optimiser": {', "report", ["optimiser.json", "not valid JSON"]),
    ("optimiser.json", b"[1, 2]", "resume", ["optimiser.json", "top level is a list"]),
    ("config.yaml", bytes(range(256)), "resume", ["config.yaml"]),
    ("config.yaml", b"design:\n  alpah: 3\n", "verify", ["config.yaml", "alpah"]),
])
def test_damaged_run_files(ws, capsys, name, data, command, words):
    files = {name: data}
    if name == "optimiser.json":
        files[CHECKPOINT_NAME] = None  # optimiser.json is read when there is no checkpoint
    d = ws.run_copy(f"{command}_{name}_{len(data)}", files)
    before = _digest(d)
    line = _one_line(capsys, cli.main([command, str(d)]), command)
    for w in words:
        assert w in line, line
    assert _digest(d) == before


def test_checkpoint_keeps_the_previous_one(ws, tmp_path):
    d = tmp_path / "run"
    shutil.copytree(ws.run, d)
    state, config = load_checkpoint(d)
    assert not (d / PREVIOUS_NAME).exists()  # one generation: one checkpoint
    state.generation += 1
    save_checkpoint(d, state, config)
    assert load_checkpoint(d, previous=True)[0].generation == state.generation - 1
    assert load_checkpoint(d)[0].generation == state.generation
    assert not list(d.glob(".*.tmp"))
    # a damaged current checkpoint never replaces an intact previous one
    (d / CHECKPOINT_NAME).write_bytes(b"\x80\x05garbage")
    save_checkpoint(d, state, config)
    assert load_checkpoint(d, previous=True)[0].generation == state.generation - 1
    with pytest.raises(RunDirectoryError, match="empty file"):
        (d / CHECKPOINT_NAME).write_bytes(b"")
        load_checkpoint(d)


def test_resume_from_previous(ws, tmp_path, capsys):
    d = tmp_path / "run"
    shutil.copytree(ws.run, d)
    state, config = load_checkpoint(d)
    save_checkpoint(d, state, config)  # the second save keeps the first as checkpoint.prev.json
    good = (d / CHECKPOINT_NAME).read_bytes()
    (d / CHECKPOINT_NAME).write_bytes(good[:-7])
    line = _one_line(capsys, cli.main(["resume", str(d), "--no-progress"]), "resume")
    assert "truncated or damaged" in line and "--from-previous" in line and "generation 0" in line, line
    assert cli.main(["resume", str(d), "--no-progress", "--from-previous"]) == 0
    out = capsys.readouterr().out
    assert "previous checkpoint (generation 0)" in out and "status         finished" in out, out
    assert (d / "checkpoint.damaged.json").read_bytes() == good[:-7]
    assert load_checkpoint(d)[0].generation == 0
    # nothing to fall back on
    (d / PREVIOUS_NAME).unlink()
    (d / CHECKPOINT_NAME).write_bytes(b"")
    line = _one_line(capsys, cli.main(["resume", str(d), "--from-previous"]), "resume")
    assert PREVIOUS_NAME in line and "no previous checkpoint" in line, line


def _fake_pressurise_failure(s: float):
    """A ``pressurise`` step that stops at load fraction ``s`` (the real scene meshes first)."""
    from fem.newton import IncrementReport, SolveFailed

    def pressurise(spec, wm):
        last = IncrementReport(s, s + 0.01, False, iterations=20, reason="no convergence in 20 iterations")
        raise SolveFailed(f"load path failed at s={s:.4g}", [], last)

    return pressurise


def test_solve_failure_is_one_line_with_status_3(ws, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("whisker_opt.experiment.scene.pressurise", _fake_pressurise_failure(0.5))
    out = tmp_path / "sim"
    line = _one_line(capsys, cli.main(["simulate", str(ws.good), "--out", str(out)]), "simulate", expect=3)
    for w in ("scene intact", "Q=0.1 MPa", "while pressurising", "reached Q = 0.05 MPa of 0.1 MPa",
              "no convergence in 20 iterations", "nothing kept"):
        assert w in line, line
    out = tmp_path / "comp"
    line = _one_line(capsys, cli.main(["compensate", str(ws.good), "--out", str(out), "--no-compare"]),
                     "compensate", expect=3)
    for w in ("Q=0.1 MPa", "trim 0 mm", "reached Q = 0.05 MPa", "table (or map) was not written"):
        assert w in line, line
    assert not out.exists()


def test_mesher_failure_is_one_line_with_status_3(ws, tmp_path, capsys, monkeypatch):
    from geometry.tetrahedralize import MeshingError

    def build_mesh(*args, **kwargs):
        raise MeshingError("fTetWild returned no tetrahedra")

    monkeypatch.setattr("geometry.mesh.build_mesh", build_mesh)
    line = _one_line(capsys, cli.main(["mesh", str(ws.good), "--out", str(tmp_path / "m")]), "mesh", expect=3)
    assert "meshing failed (MeshingError: fTetWild returned no tetrahedra)" in line, line


def test_a_contact_that_finds_no_node_is_one_line_with_status_3(ws, tmp_path, capsys, monkeypatch):
    from whisker_opt.experiment.contact import ContactPlacementError

    def contact_band(*args, **kwargs):
        raise ContactPlacementError("contact band of width 1 mm at x = 70.000 mm holds no node "
                                    "(nearest node at x = 70.907 mm)")

    monkeypatch.setattr("whisker_opt.experiment.scene.contact_band", contact_band)
    line = _one_line(capsys, cli.main(["simulate", str(ws.good), "--out", str(tmp_path / "sim")]), "simulate",
                     expect=3)
    assert "holds no node" in line and "nearest node at x = 70.907 mm" in line, line
