"""A run killed with SIGKILL at any moment, then resumed, is complete and equals an uninterrupted one.

* The GA and checkpoint layer (:mod:`tests.kill_harness`): a child run of the analytic
  evaluator is killed at seeded moments (right after ``optimiser.json``, during generation 0,
  during the checkpoint writes of generation 0 and of the last generation, after the last
  generation, random ones), resumed here; population, hall of fame, best design and
  ``evaluations.csv`` (but ``time_s``) equal the uninterrupted run, every output is written
  and no temporary is left.
* The workflow layer: ``whisker-opt run`` of a tiny FE config killed while the best design's
  meshes are written, then ``whisker-opt resume``: ``best/`` and ``best_curves.*`` as
  an uninterrupted run writes them.
* ``run --out`` into a directory of another config is refused; VTU files get ordinary modes.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests import kill_harness as kh
from tests.subprocess_run import tiny_run_file
from whisker_opt.output import storage

REPO = kh.REPO
#: Kill moments of the GA layer (the five fixed ones and five seeded ones).
MOMENTS = kh.moments(10, seed=1)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    d = tmp_path_factory.mktemp("ref") / "run"
    return d, kh.reference_run(d)


@pytest.mark.parametrize("moment", MOMENTS, ids=[m.label() for m in MOMENTS])
def test_killed_ga_run_resumes_to_the_uninterrupted_result(tmp_path, reference, moment):
    ref_dir, ref = reference
    run_dir = tmp_path / "killed"
    got = kh.kill_at(run_dir, moment)
    print(moment.label(), got)
    if moment.kind != "time":  # the fixed kinds always find the child running
        assert got["killed"]
    if moment.kind == "metadata":
        assert not got["environment"] and got["generation"] == -1
    if moment.kind == "checkpoint":
        assert any(n.startswith(".checkpoint.json.") for n in got["temporaries"])  # killed inside the write
        assert got["generation"] == moment.generation - 1
    if moment.kind == "finish":
        assert got["finished"]
    summary = kh.resume(run_dir)
    assert kh.differences(ref_dir, ref, run_dir, summary) == []


# ----------------------------------------------------------------------------- workflow layer
TINY = tiny_run_file(trim=5.0)


def _cli(*args, umask: int = 0o022) -> subprocess.Popen:
    old = os.umask(umask)
    try:
        return subprocess.Popen([sys.executable, "-m", "whisker_opt.cli", *map(str, args)], cwd=REPO,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    finally:
        os.umask(old)


def _finish(proc: subprocess.Popen, timeout: float = 300) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_run_killed_while_writing_best_then_resumed_is_complete(tmp_path):
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY)
    ref, cut = tmp_path / "ref", tmp_path / "cut"
    rc, _, err = _finish(_cli("run", cfg, "--out", ref, "--no-progress"))
    assert rc == 0, err
    proc = _cli("run", cfg, "--out", cut, "--no-progress")
    partial = cut / ".best.partial"
    try:
        deadline = time.monotonic() + 300
        while not (partial.is_dir() and any(partial.glob("*.vtu"))):  # the first mesh of best/ is written
            assert proc.poll() is None, proc.communicate()[1]
            assert time.monotonic() < deadline
            time.sleep(0.002)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
    assert proc.returncode == -signal.SIGKILL
    left = _names(cut)
    assert "best" not in left and "best_curves.csv" not in left and ".best.partial" in left
    # what older versions left after such a kill: a partial best/ with a temporary VTU
    (cut / "best").mkdir()
    (cut / "best" / "tmpab12cd34.vtu").write_bytes(b"torn")
    (cut / "best" / "intact_pressurised.vtu").write_bytes(b"torn")

    rc, out, err = _finish(_cli("resume", cut, "--no-progress"))
    assert rc == 0, err
    assert "finished" in out
    assert _names(cut) == _names(ref)
    assert _names(cut / "best") == _names(ref / "best")
    assert any(n.endswith(".vtu") for n in _names(cut / "best")) and "scenes.json" in _names(cut / "best")
    for folder in (cut, cut / "best"):
        assert not [n for n in _names(folder) if storage.is_temporary(n)]
    a, b = (np.loadtxt(d / "best_curves.csv", delimiter=",", skiprows=1) for d in (ref, cut))
    assert a.shape == b.shape and a.shape[0] > 2
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-14)
    sa, sb = (json.loads((d / "best" / "scenes.json").read_text()) for d in (ref, cut))
    assert sa.keys() == sb.keys()
    for name in sa:
        assert sa[name]["genes"] == sb[name]["genes"]
        np.testing.assert_allclose(sb[name]["eps_line"], sa[name]["eps_line"], rtol=1e-9, atol=1e-14)
    for p in (cut / "best").glob("*.vtu"):
        assert p.stat().st_mode & 0o777 == 0o644, p  # written under umask 022
    # the run's evaluations are those of the uninterrupted run (the same designs; f1 to the
    # rounding of multi-threaded sparse solves, which differs between processes)
    ea, eb = (storage.read_csv(d / storage.EVALUATIONS_CSV) for d in (ref, cut))
    assert len(ea) == len(eb) == 2
    for ra, rb in zip(ea, eb):
        assert ra.keys() == rb.keys()
        for k in ra.keys() - {"time_s"}:
            if ra[k] != rb[k]:
                np.testing.assert_allclose(float(rb[k]), float(ra[k]), rtol=1e-9, err_msg=k)
    # resuming a complete run solves nothing again
    before = {p.name: p.stat().st_mtime_ns for p in (cut / "best").iterdir()}
    rc, _, err = _finish(_cli("resume", cut, "--no-progress"))
    assert rc == 0, err
    assert {p.name: p.stat().st_mtime_ns for p in (cut / "best").iterdir()} == before


# ----------------------------------------------------------------------------- refusals and modes
def test_run_into_a_directory_of_another_config_is_refused(tmp_path, capsys):
    from whisker_opt import workflows
    from whisker_opt.cli import main as cli
    from whisker_opt.config.model import WhiskerConfig, dump_config

    cfg = tmp_path / "tiny.yaml"
    cfg.write_text(TINY)
    run = tmp_path / "run"
    run.mkdir()
    other = dump_config(WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}, "seed": 4}))
    (run / "config.yaml").write_text(other)
    (run / "optimiser.json").write_text("{}")  # a run killed before its first checkpoint
    assert cli.main(["run", str(cfg), "--out", str(run), "--no-progress"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert len(err) == 1 and f"whisker-opt resume {run}" in err[0] and "config" in err[0], err
    assert (run / "config.yaml").read_text() == other
    assert _names(run) == ["config.yaml", "optimiser.json"]
    # the same config, written by hand in another layout, is the same config
    same = WhiskerConfig.model_validate({"fidelity": {"preset": "coarse"}, "seed": 4})
    (run / "config.yaml").write_text("seed: 4\nfidelity: {preset: coarse}\n")
    workflows.check_run_config(run, same)
    with pytest.raises(FileExistsError, match="whisker-opt resume"):
        workflows.check_run_config(run, WhiskerConfig.model_validate({"seed": 5}))


@pytest.mark.parametrize("umask, mode", [(0o022, 0o644), (0o027, 0o640)])
def test_vtu_files_have_ordinary_modes(tmp_path, umask, mode):
    from fem.io import write_vtu
    from fem.mesh import TetMesh, p1_to_p2

    pts = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    p2 = p1_to_p2(pts, np.array([[0, 1, 2, 3]]))
    mesh = TetMesh(p2[0], p2[1])
    old = os.umask(umask)
    try:
        path = write_vtu(tmp_path / "one.vtu", mesh, point_data={"displacement": np.zeros((mesh.n_nodes, 3))})
        storage.write_json(tmp_path / "one.json", {"a": 1})
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == mode
    assert (tmp_path / "one.json").stat().st_mode & 0o777 == mode
    assert _names(tmp_path) == ["one.json", "one.vtu"]  # no temporary left
    import meshio

    assert meshio.read(path).points.shape == (mesh.n_nodes, 3)


def test_temporaries_are_recognised():
    for name in (".checkpoint.json.x1y2.tmp", ".tmpab12", "tmpab12cd34.vtu", ".best.partial", ".eval_3.partial",
                 ".intact_deflected.vtu.k2j3.tmp"):
        assert storage.is_temporary(name), name
    for name in ("best", "checkpoint.json", "run.lock", "intact_deflected.vtu", "tmp.vtu", "scenes.json", "eval_3"):
        assert not storage.is_temporary(name), name
