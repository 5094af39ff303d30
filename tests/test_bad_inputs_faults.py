"""Faults of the machine and hostile run directories: one line each, the right exit status, no hang.

* A dask scheduler address where a service that is not dask listens (one that never answers,
  one that answers garbage, one that closes at once): refused within the connection timeout,
  one line naming ``optimiser.executor.scheduler_address``, exit status 2, nothing written.
* The dask scheduler killed during a run: one line, exit status 3, the last checkpoint kept;
  distributed's own tracebacks of the loss are not shown. A local cluster says nothing at
  INFO unless ``-vvv``.
* ``calibrate`` with an uncertainty of 1e-300 or 1e300, or bounds [1e-12, 100] on C10:
  refused in one line naming the file or key, the value and the allowed range; legal but
  implausible values (σ a billionth of the value, bounds over 4 decades) are warnings.
* A full disk (``ENOSPC``) while a run writes its results: one line naming the file, exit
  status 3, no temporary left, the previous checkpoint intact and the run resumable.
* ``view`` with a ``DISPLAY`` where no X server runs: off-screen rendering to a named file.
* A run directory whose ``checkpoint.json`` or ``checkpoint.pkl`` is a dangling symbolic link
  (refused, never restarted from generation 0), whose ``run.lock`` or ``run.log`` is a symbolic
  link (refused, the file it leads to untouched), or whose JSON files are nested too deeply to
  read (one line, not a RecursionError); the Python API's ``load_run``, ``resume`` and
  ``verify`` with a run directory of no path type or a damaged ``best.json``.

The GA runs on the analytic fitness (:mod:`tests.analytic_fitness`), so each case takes seconds.
"""

from __future__ import annotations

import errno
import logging
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.analytic_fitness import AnalyticFitness
from tests.folder_helpers import folder_contents as _digest, use_analytic_fitness
from whisker_opt import wiring
from whisker_opt.cli import main as cli
from whisker_opt.config.model import dump_config, load_config
from whisker_opt.optimise import dask_executor
from whisker_opt.optimise.checkpoint import CHECKPOINT_NAME, OLDER_NAME, RunDirectoryError, load_checkpoint
from whisker_opt.optimise.runner import run_optimisation
from whisker_opt.output import storage

REPO = Path(__file__).resolve().parents[1]

RUN_FILE = """\
fidelity:
  preset: coarse
optimiser:
  trim: 2.0
  ga:
    population: 6
    n_elite: 1
  stopping:
    max_generations: {generations}
    target_fp: 0.0
    stall_generations: 100
  executor:
    kind: {kind}
seed: 5
output:
  results_dir: {results}
"""

DEEP = "[" * 100_000 + "]" * 100_000


def _run(capsys, *argv) -> tuple[int, list[str]]:
    code = cli.main([str(a) for a in argv])
    err = capsys.readouterr().err
    return code, [ln for ln in err.splitlines() if ln.strip()]


def _one_line(code: int, lines: list[str], expect: int, command: str, words=()) -> str:
    assert code == expect, (code, lines)
    assert len(lines) == 1 and "Traceback" not in lines[0], lines
    assert lines[0].startswith(f"whisker-opt {command}: error: "), lines
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    return lines[0]


def _run_file(tmp_path: Path, generations: int = 2, kind: str = "serial", extra: str = "") -> Path:
    path = tmp_path / "run.yaml"
    path.write_text(RUN_FILE.format(generations=generations, kind=kind, results=tmp_path / "results") + extra)
    return path


@pytest.fixture
def analytic(monkeypatch):
    """In this process: the commands evaluate the analytic fitness and do not re-solve the best design."""
    use_analytic_fitness(monkeypatch, sleep_s=0.05)


@pytest.fixture
def run_dir(tmp_path) -> Path:
    """A finished run directory of the analytic fitness, with its config.yaml."""
    cfg = load_config(_run_file(tmp_path))
    d = tmp_path / "run"
    d.mkdir()
    (d / "config.yaml").write_text(dump_config(cfg))
    run_optimisation(wiring.optimiser_of(cfg), d, AnalyticFitness(), seed=5, progress=False,
                     run_config=cfg.model_dump(mode="json"))
    return d


# ============================================================================ a dask scheduler that is not one
def _listener(mode: str) -> tuple[socket.socket, threading.Event]:
    """A TCP service on localhost that is not dask: ``silent`` accepts and says nothing, ``garbage`` answers
    bytes that are no dask message, ``close`` closes each connection at once, ``http`` answers as a web server."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    srv.settimeout(0.2)
    stop = threading.Event()
    held = []

    def serve():
        while not stop.is_set():
            try:
                conn, _ = srv.accept()
            except OSError:
                continue
            held.append(conn)
            try:
                if mode == "garbage":
                    conn.sendall(bytes(range(256)) * 8)
                elif mode == "http":
                    conn.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n")
                elif mode == "close":
                    conn.close()
            except OSError:
                pass
        for c in held:
            c.close()

    threading.Thread(target=serve, daemon=True).start()
    return srv, stop


@pytest.mark.parametrize("mode", ["nothing", "silent", "garbage", "close", "http"])
def test_a_scheduler_address_where_no_dask_scheduler_answers_is_one_line(tmp_path, capsys, monkeypatch, mode):
    """Was: ``silent`` hung without end (distributed waits for the handshake without a limit) and ``garbage``
    ended in a MemoryError traceback (a frame length of exabytes)."""
    monkeypatch.setattr(dask_executor, "CONNECT_TIMEOUT_S", 1.5)
    srv, stop = _listener(mode)
    try:
        port = _free_port() if mode == "nothing" else srv.getsockname()[1]
        out = tmp_path / "out"
        t0 = time.monotonic()
        code, lines = _run(capsys, "run", _run_file(tmp_path), "--set", "optimiser.executor.kind=dask", "--set",
                           f"optimiser.executor.scheduler_address=tcp://127.0.0.1:{port}", "--out", out,
                           "--no-progress")
        assert time.monotonic() - t0 < 8.0
    finally:
        stop.set()
        srv.close()
    _one_line(code, lines, 2, "run", ("optimiser.executor.scheduler_address", f"127.0.0.1:{port}"))
    assert not out.exists()


def test_the_probe_is_bounded_where_an_event_loop_runs(monkeypatch):
    """The probe has a thread and a loop of its own: it works inside a running event loop (a notebook)."""
    import asyncio

    srv, stop = _listener("silent")
    try:
        address = f"tcp://127.0.0.1:{srv.getsockname()[1]}"

        async def inside():
            with pytest.raises(dask_executor.SchedulerUnreachable, match="no dask scheduler answered within 1 s"):
                dask_executor.probe_scheduler(address, 1.0)

        t0 = time.monotonic()
        asyncio.run(inside())
        assert time.monotonic() - t0 < 5.0
    finally:
        stop.set()
        srv.close()


# ============================================================================ the dask scheduler killed in a run
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dask(*args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "OMP_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_" + args[0], *args[1:]], cwd=REPO, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)


def test_a_scheduler_killed_during_a_run_ends_it_in_one_line_and_keeps_its_state(tmp_path, capsys, caplog,
                                                                                   monkeypatch, analytic):
    """Was: a FuturesCancelledError traceback after distributed's own ERROR record with a traceback of its
    reconnection (76 lines), exit status 1."""
    pytest.importorskip("distributed")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    scheduler = _dask("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    worker = _dask("worker", address, "--nthreads", "1", "--no-dashboard", "--no-nanny")
    out = tmp_path / "out"
    try:
        deadline = time.monotonic() + 20
        while True:  # the scheduler and a worker are up
            try:
                with dask_executor.connect_scheduler(address, 2.0) as client:
                    if client.scheduler_info().get("workers"):
                        break
            except dask_executor.SchedulerUnreachable:
                pass
            assert time.monotonic() < deadline, "no dask scheduler with a worker came up"
            time.sleep(0.3)

        def kill_after_first_checkpoint():
            while not (out / CHECKPOINT_NAME).exists() and scheduler.poll() is None:
                time.sleep(0.01)
            scheduler.send_signal(signal.SIGKILL)

        threading.Thread(target=kill_after_first_checkpoint, daemon=True).start()
        caplog.set_level(logging.WARNING)
        t0 = time.monotonic()
        code, lines = _run(capsys, "run", _run_file(tmp_path, generations=50), "--set", "optimiser.executor.kind=dask",
                           "--set", f"optimiser.executor.scheduler_address={address}", "--out", out, "--no-progress")
        assert time.monotonic() - t0 < 30
    finally:
        for p in (scheduler, worker):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    _one_line(code, lines, 3, "run", ("dask scheduler", address, "was lost", "last checkpoint"))
    assert not [r for r in caplog.records if r.name.startswith("distributed") and r.exc_info]
    state, _ = load_checkpoint(out)  # the state is kept: the run resumes from it
    assert state.generation >= 0 and not (out / "run.lock").exists()
    assert not [p.name for p in out.iterdir() if storage.is_temporary(p.name)]


# ============================================================================ a quiet local cluster
QUIET_CHILD = """
import logging, sys
from whisker_opt.cli.main import _set_up_logging
from whisker_opt.optimise.dask_executor import DaskExecutor
from tests.analytic_fitness import AnalyticFitness
_set_up_logging(int(sys.argv[1]))
with DaskExecutor(AnalyticFitness(), n_workers=1, processes=False) as ex:
    ex.map([{"alpha": 3.0, "l": 12.0, "t": 4.0, "Q_i": 0.05}], [1])
"""


@pytest.mark.parametrize("verbose, shown", [(0, False), (1, False), (3, True)])
def test_a_local_dask_cluster_is_quiet_unless_vvv(verbose, shown):
    """Was: ~30 INFO lines of distributed (scheduler, nanny, worker) on every run, -v or not: importing
    distributed set its loggers to INFO after the console was set up."""
    pytest.importorskip("distributed")
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.run([sys.executable, "-c", QUIET_CHILD, str(verbose)], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    info = [ln for ln in proc.stderr.splitlines() if ln.startswith("INFO distributed")]
    assert bool(info) == shown, proc.stderr


# ============================================================================ calibrate: implausible inputs
def _calibration(tmp_path: Path) -> Path:
    from tests.test_calibration import _config, _write_data

    _write_data(tmp_path)
    return _config(tmp_path)


@pytest.mark.parametrize("sigma", ["1e-300", "1e300", "0", "-1e-3"])
def test_calibrate_refuses_an_uncertainty_out_of_range(tmp_path, capsys, sigma):
    """Was (1e-300): overflow warnings, then a ValueError traceback from scipy (infs in the Jacobian);
    (1e300): RuntimeWarnings of a division by zero and a 'converged' fit that the data did not move."""
    path = _calibration(tmp_path)
    ext = tmp_path / "data" / "ext.csv"
    ext.write_text(ext.read_text().replace(",0.01\n", f",{sigma}\n", 1))
    code, lines = _run(capsys, "calibrate", path, "--out", tmp_path / "out", "--no-progress")
    _one_line(code, lines, 2, "calibrate", ("ext.csv", "row 1", "column sigma", sigma, "[1e-12, 1000]"))
    assert not (tmp_path / "out").exists()


def test_calibrate_refuses_bounds_over_six_decades(tmp_path, capsys):
    """Was: C10 in [1e-12, 100] 'converged' to 0.265 (0.2 made the data) with a Jacobian step of 2 MPa."""
    path = _calibration(tmp_path)
    code, lines = _run(capsys, "calibrate", path, "--set",
                       "calibration.parameters=[{path: material.C10, lower: 1e-12, upper: 100, start: 0.14}]",
                       "--out", tmp_path / "out", "--no-progress")
    _one_line(code, lines, 2, "calibrate", ("calibration.parameters[0]", "material.C10", "[1e-12, 100]",
                                            "at most 6"))
    assert not (tmp_path / "out").exists()


def test_calibrate_warns_of_legal_but_implausible_inputs(tmp_path, caplog):
    from whisker_opt.calibration.job import prepare

    path = _calibration(tmp_path)
    ext = tmp_path / "data" / "ext.csv"
    ext.write_text(ext.read_text().replace(",0.01\n", ",1e-9\n"))
    text = path.read_text().replace("lower: 0.05", "lower: 0.01").replace("upper: 0.5", "upper: 100.0")
    path.write_text(text)
    with caplog.at_level(logging.WARNING):
        prepare(load_config(path), path)
    messages = [r.getMessage() for r in caplog.records]
    assert any("column sigma" in m and "relative uncertainty below" in m for m in messages), messages
    assert any("material.C10" in m and "span 4.0 decades" in m for m in messages), messages


# ============================================================================ a full disk
def test_a_full_disk_during_the_ga_is_one_line_naming_the_file(tmp_path, capsys, monkeypatch, analytic):
    """ENOSPC from every write once the first checkpoint is on disk: exit 3, the file named, no temporary
    left, the checkpoint intact; freed, the run resumes to its end. Was: exit 2 and
    '[Errno 28] No space left on device' naming no file."""
    out = tmp_path / "out"
    real_fsync = os.fsync
    full = {"on": False}

    def fsync(fd):
        if full["on"] or (out / CHECKPOINT_NAME).exists():
            full["on"] = True
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    code, lines = _run(capsys, "run", _run_file(tmp_path, generations=3), "--out", out, "--no-progress")
    line = _one_line(code, lines, 3, "run", ("No space left on device", str(out)))
    assert any(name in line for name in ("checkpoint", ".csv", ".json", ".png")), line
    assert not [p.name for p in out.iterdir() if storage.is_temporary(p.name)]
    state, _ = load_checkpoint(out)
    full["on"] = False
    monkeypatch.setattr(os, "fsync", real_fsync)
    code, lines = _run(capsys, "resume", out, "--no-progress")
    assert code == 0, lines
    assert load_checkpoint(out)[0].generation == 3 > state.generation


def test_an_atomic_write_that_fails_names_its_file_and_leaves_nothing(tmp_path, monkeypatch):
    from fem.io import atomic_write
    from geometry.mesh import WhiskerMesh

    target = tmp_path / "a.json"
    target.write_text("old")
    real = os.fdopen

    class Full:
        def __init__(self, fh):
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fdopen", lambda fd, *a, **k: Full(real(fd, *a, **k)))
    with pytest.raises(OSError) as err:
        storage.atomic_write_text(target, "new")
    monkeypatch.setattr(os, "fdopen", real)
    assert err.value.errno == errno.ENOSPC and err.value.filename == str(target)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["a.json"]

    def produce(tmp):
        Path(tmp).write_bytes(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(OSError) as err:
        atomic_write(tmp_path / "m.vtu", produce)
    assert err.value.filename == str(tmp_path / "m.vtu") and [p.name for p in tmp_path.iterdir()] == ["a.json"]

    import numpy as np
    from types import SimpleNamespace

    def savez(path, **arrays):
        Path(path).write_bytes(b"half")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(np, "savez_compressed", savez)
    as_dict = SimpleNamespace(as_dict=dict)  # just enough of a WhiskerMesh for save() to reach its write
    mesh = SimpleNamespace(mesh=SimpleNamespace(points=np.zeros((1, 3)), cells=np.zeros((1, 10), int)),
                           design=as_dict, sizing=as_dict, report=as_dict, fibres=(), node_sets={}, face_sets={})
    with pytest.raises(OSError) as err:
        WhiskerMesh.save(mesh, tmp_path / "c.npz")
    assert err.value.filename == str(tmp_path / "c.npz") and [p.name for p in tmp_path.iterdir()] == ["a.json"]


# ============================================================================ view with a dead display
def _dead_display() -> str:
    """``:N`` where no X server runs (no socket, no TCP port 6000 + N)."""
    for n in range(87, 200):
        if os.path.exists(f"/tmp/.X11-unix/X{n}"):
            continue
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", 6000 + n)) != 0:
                return f":{n}"
    pytest.skip("no free X display number")


def test_view_with_a_display_where_no_x_server_runs_renders_off_screen(tmp_path, capsys, monkeypatch):
    """Was: exit 0 and nothing drawn (VTK: 'bad X server connection. DISPLAY=:99'), no file written."""
    pytest.importorskip("pyvista")
    from fem.io import write_vtu
    from fem.meshgen import box_mesh

    display = _dead_display()
    monkeypatch.setenv("DISPLAY", display)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    vtu = tmp_path / "scene_deflected.vtu"
    write_vtu(vtu, box_mesh(10.0, 2.0, 2.0, 3, 1, 1))
    code = cli.main(["view", str(vtu), "--window-size", "200", "160"])
    out, err = capsys.readouterr()
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 0 and len(lines) == 1 and "Traceback" not in err, err
    assert f"no display answers at DISPLAY='{display}'" in lines[0] and str(tmp_path / "view.png") in lines[0]
    assert (tmp_path / "view.png").stat().st_size > 1000 and str(tmp_path / "view.png") in out


def test_display_detection_probes_the_display(tmp_path):
    from whisker_opt.viewer import guard

    display = _dead_display()
    assert guard.is_headless({"DISPLAY": display}, "linux", probe=True)
    assert not guard.is_headless({"DISPLAY": display}, "linux")  # the variables alone, as before
    assert "DISPLAY=" in guard.display_problem({"DISPLAY": f"127.0.0.1{display}"}, "linux", probe=True)
    assert guard.is_headless({"WAYLAND_DISPLAY": "wayland-9", "XDG_RUNTIME_DIR": str(tmp_path)}, "linux", probe=True)
    with socket.socket(socket.AF_UNIX) as srv:  # something that answers at the display's socket path
        srv.bind(str(tmp_path / "X0"))
        srv.listen(1)
        assert not guard.is_headless({"DISPLAY": f"{tmp_path / 'X0'}:0"}, "linux", probe=True)
        (tmp_path / "wayland-9").touch()
        assert not guard.is_headless({"WAYLAND_DISPLAY": "wayland-9", "XDG_RUNTIME_DIR": str(tmp_path)}, "linux",
                                     probe=True)


# ============================================================================ hostile run directories
@pytest.mark.parametrize("name", [CHECKPOINT_NAME, OLDER_NAME])
@pytest.mark.parametrize("command", ["resume", "report", "verify"])
def test_a_dangling_state_link_is_refused_not_restarted(run_dir, capsys, name, command):
    """Was, for a dangling checkpoint.pkl: the refusal of a pickle of an earlier version (with
    --trust-pickle: 'no checkpoint to convert'); for checkpoint.json: 'not a regular file'."""
    if name == OLDER_NAME:
        (run_dir / CHECKPOINT_NAME).unlink()
    else:
        (run_dir / name).unlink()
    (run_dir / name).symlink_to(run_dir.parent / "gone" / name)
    before = _digest(run_dir)
    extra = {"resume": ["--no-progress"], "verify": ["--preset", "coarse", "--top", "1"]}.get(command, [])
    code, lines = _run(capsys, command, run_dir, *extra)
    _one_line(code, lines, 2, command, (str(run_dir / name), "symbolic link", "does not exist",
                                        "not started again from generation 0"))
    assert _digest(run_dir) == before


@pytest.mark.parametrize("command", ["resume", "verify"])
def test_a_run_lock_that_is_a_link_is_refused_and_its_target_untouched(run_dir, tmp_path, capsys, command):
    """Was: taking the lock wrote the holder's PID over the file the link led to (any file of the user's)."""
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me\n")
    (run_dir / "run.lock").symlink_to(precious)
    extra = ["--no-progress"] if command == "resume" else ["--preset", "coarse", "--top", "1"]
    code, lines = _run(capsys, command, run_dir, *extra)
    _one_line(code, lines, 2, command, (str(run_dir / "run.lock"), "symbolic link", "remove the link"))
    assert precious.read_text() == "keep me\n" and (run_dir / "run.lock").is_symlink()


def test_a_run_log_that_is_a_link_is_refused_and_its_target_untouched(run_dir, tmp_path, capsys, analytic):
    """Was: the run's log was appended to the file the link led to (e.g. a shell's start-up file)."""
    precious = tmp_path / "precious.txt"
    precious.write_text("keep me\n")
    (run_dir / "run.log").symlink_to(precious)
    code, lines = _run(capsys, "resume", run_dir, "--max-generations", "4", "--no-progress")
    _one_line(code, lines, 2, "resume", (str(run_dir / "run.log"), "symbolic link"))
    assert precious.read_text() == "keep me\n"
    assert load_checkpoint(run_dir)[0].generation == 2  # nothing ran


@pytest.mark.parametrize("command", ["resume", "report", "verify"])
def test_an_optimiser_json_nested_too_deeply_is_one_line(run_dir, capsys, command):
    """Was: a RecursionError traceback from the JSON decoder (27 lines)."""
    (run_dir / CHECKPOINT_NAME).unlink()
    (run_dir / storage.OPTIMISER_JSON).write_text('{"seed": 1, "optimiser": ' + DEEP + "}")
    extra = {"resume": ["--no-progress"], "verify": ["--preset", "coarse", "--top", "1"]}.get(command, [])
    code, lines = _run(capsys, command, run_dir, *extra)
    _one_line(code, lines, 2, command, ("optimiser.json", "nested too deeply"))


@pytest.mark.parametrize("name", ["best.json", "best/scenes.json"])
def test_view_of_a_json_nested_too_deeply_is_one_line(run_dir, capsys, name):
    """Was: a RecursionError traceback (29 lines)."""
    pytest.importorskip("pyvista")
    (run_dir / name).parent.mkdir(exist_ok=True)
    (run_dir / name).write_text(DEEP)
    code, lines = _run(capsys, "view", run_dir, "--screenshot", run_dir.parent / "v.png")
    _one_line(code, lines, 2, "view", (name.split("/")[-1], "damaged"))
    assert not (run_dir.parent / "v.png").exists()


def test_a_study_journal_nested_too_deeply_is_set_aside_with_a_warning(tmp_path, caplog):
    """Was: a RecursionError traceback when compensate --map, robustness or calibrate continued a study."""
    from whisker_opt.output.journal import StudyJournal

    (tmp_path / "study.partial.json").write_text(DEEP)
    with caplog.at_level(logging.WARNING):
        journal = StudyJournal(tmp_path, "study.partial.json", "robustness", {"a": 1})
    assert journal.done == {} and "unreadable (RecursionError)" in caplog.text


# ============================================================================ the Python API
@pytest.mark.parametrize("value", [None, 42, 3.5, True, "", ["run"]])
def test_the_api_refuses_a_run_directory_of_no_path_type(value):
    """Was: TypeError 'expected str, bytes or os.PathLike object, not int' from deep inside pathlib."""
    import whisker_opt as wo

    for function in (wo.load_run, wo.resume, wo.verify):
        with pytest.raises(ValueError, match=rf"{function.__name__}: run_dir is .*expected the path of a folder"):
            function(value)


@pytest.mark.parametrize("text, words", [(DEEP, "nested too deeply"), (b"\xff\xfe{", "not UTF-8"),
                                         ("[1, 2]", "top level is a list"), ("{", "not valid JSON")],
                         ids=["deep", "not-utf8", "a-list", "truncated"])
def test_load_run_refuses_a_damaged_best_json_in_one_line(run_dir, text, words):
    """Was: RecursionError, UnicodeDecodeError, AttributeError ('list' has no 'get') and JSONDecodeError."""
    import whisker_opt as wo

    path = run_dir / storage.BEST_JSON
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    with pytest.raises(RunDirectoryError, match=words) as err:
        wo.load_run(run_dir)
    assert str(path) in str(err.value) and "\n" not in str(err.value)
