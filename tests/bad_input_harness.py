"""The bad-input harness: fixtures, cases and the check of one case through the real command line.

A case is a hand-made bad input (:class:`Case`, listed by :func:`tests.bad_input_cases.build_cases`)
run as ``whisker-opt ...`` in a subprocess (:func:`tests.subprocess_run.run_cli`); :func:`run_case`
checks what it did (:class:`Outcome`): the exit status, one stderr line naming the option or file,
no traceback or abort, and nothing written or changed. Shared by ``tests/test_bad_inputs_sample.py``
(a cheap sample) and ``benchmarks/reliability/bad_inputs.py`` (every case, as a table).
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import socket
import threading
from dataclasses import dataclass, field
from pathlib import Path

from tests.subprocess_run import run_cli, tiny_run_file

logger = logging.getLogger(__name__)

TINY = tiny_run_file("trim: 5.0", 5.0, "{results}")

#: intact solves; trimmed_uncompensated (20 mm long, at 0.35 MPa) fails near δ = 29 mm
SOLVE_FAILS_LATE = """\
fidelity:
  preset: coarse
scene:
  Q_i: 0.35
  trim: 50.0
  deflection: 30.0
output:
  results_dir: {results}
"""

#: compensation at Q_i = 1 MPa: the intact scene cannot be pressurised (fails near 0.42 MPa)
COMPENSATE_FAILS = """\
fidelity:
  preset: coarse
scene:
  Q_i: 1.0
optimiser:
  trim: 2.0
output:
  results_dir: {results}
"""


@dataclass
class Case:
    """One bad input.

    Attributes
    ----------
    name : str
    argv : list of str
        Arguments after ``whisker-opt``.
    expect : int
        Expected exit status (2: refused input, 3: computation failed).
    absent : tuple of Path
        Paths that must not exist after the case.
    frozen : tuple of Path
        Files or folders that must be unchanged by the case.
    words : tuple of str
        Words the stderr line must contain (the option or file name).
    slow : bool
        Computes before failing (skipped with ``--skip-slow``).
    env : dict
        Variables set for the case (e.g. a ``DISPLAY`` where no X server runs).
    present : tuple of Path
        Paths that must exist after the case (what a fallback wrote).
    """

    name: str
    argv: list
    expect: int = 2
    absent: tuple = ()
    frozen: tuple = ()
    words: tuple = ()
    slow: bool = False
    env: dict = field(default_factory=dict)
    present: tuple = ()


@dataclass
class Outcome:
    """What a case did."""

    case: Case
    rc: int | None
    stderr: str
    seconds: float
    problems: list = field(default_factory=list)

    @property
    def lines(self) -> list:
        return [ln for ln in self.stderr.splitlines() if ln.strip()]

    @property
    def traceback(self) -> bool:
        return "Traceback (most recent call last)" in self.stderr

    @property
    def timed_out(self) -> bool:
        return self.rc is None

    @property
    def aborted(self) -> bool:
        return self.rc is not None and self.rc < 0 or self.rc in (134, 139) or any(
            w in self.stderr for w in ("Segmentation fault", "Aborted", "core dumped", "vtkOutputWindow", "ERROR: In "))


# ============================================================================ fixtures
def _tree_digest(path: Path) -> str:
    """Digest of a file or of a folder's names, sizes and contents (what 'unchanged' means)."""
    h = hashlib.sha256()
    path = Path(path)
    if not path.exists():
        return "absent"
    items = [path] if path.is_file() else sorted(p for p in path.rglob("*"))
    for p in items:
        h.update(str(p.relative_to(path.parent)).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def _listen(mode: str) -> int:
    """A TCP service on localhost that is not dask, for the life of this process; its port.

    ``silent`` accepts and says nothing; ``garbage`` answers bytes that are no dask message."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(16)
    held = []

    def serve():
        while True:
            conn, _ = srv.accept()
            held.append(conn)
            if mode == "garbage":
                try:
                    conn.sendall(bytes(range(256)) * 8)
                except OSError:
                    pass

    threading.Thread(target=serve, daemon=True).start()
    return srv.getsockname()[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _dead_display() -> str:
    """``:N`` where no X server runs (no socket, nothing on TCP port 6000 + N)."""
    for n in range(87, 200):
        if Path(f"/tmp/.X11-unix/X{n}").exists():
            continue
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", 6000 + n)) != 0:
                return f":{n}"
    return ":199"


class FixtureError(RuntimeError):
    """The fixture run could not be made."""


class Workspace:
    """The fixture files of the cases, in ``root``.

    ``cli`` is the command line of ``whisker-opt`` (default: this checkout's, see
    :func:`tests.subprocess_run.run_cli`); ``env`` holds variables set for every child on top of
    :func:`tests.subprocess_run.child_env` (e.g. ``PYTHONPATH`` of another checkout)."""

    def __init__(self, root: Path, cli: list[str] | None = None, env: dict | None = None) -> None:
        self.root = Path(root)
        self.cli = cli
        self.env = dict(env or {})
        self.results = self.root / "results"
        self.results.mkdir(parents=True, exist_ok=True)
        self.afile = self.root / "afile.txt"
        self.afile.write_text("a regular file\n")
        self.good = self._write("good.yaml", TINY.format(results=self.results))
        # the fixture run's file sets no key that run, resume or verify leave unread (scene.trim is simulate's):
        # such a key is warned about in a line of its own, before a damaged run directory is refused
        self.good_run = self._write("good_run.yaml", TINY.replace("scene:\n  trim: 5.0\n", "").format(
            results=self.results))
        self.ro = self._read_only_dir()
        self.run = self.root / "run"

    def _write(self, name: str, text: str | bytes) -> Path:
        p = self.root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(text, bytes):
            p.write_bytes(text)
        else:
            p.write_text(text)
        return p

    def _read_only_dir(self) -> Path:
        """A folder nothing can be created in (as root, chmod does not stop writes: /sys then)."""
        if hasattr(os, "geteuid") and os.geteuid() == 0 and Path("/sys").is_dir():
            return Path("/sys/whisker-opt-bad-inputs")
        d = self.root / "readonly"
        d.mkdir(exist_ok=True)
        d.chmod(0o555)
        return d / "out"

    def config(self, name: str, text: str | bytes) -> Path:
        """A config file ``name`` holding ``text`` (``{results}`` filled in)."""
        if isinstance(text, str):
            text = text.replace("{results}", str(self.results))
        return self._write(f"configs/{name}", text)

    def make_run(self) -> None:
        """The tiny run all run-directory cases start from."""
        if (self.run / "checkpoint.json").is_file():
            return
        done = run_cli("run", self.good_run, "--out", self.run, "--no-progress", cli=self.cli, cwd=self.root,
                       env=self.env, timeout=600)
        if done.returncode != 0:
            raise FixtureError(f"cannot make the fixture run: {done.stderr}")
        logger.info("fixture run made in %.1f s: %s", done.seconds, self.run)

    def run_copy(self, name: str, damage: dict | None = None, remove: tuple = ()) -> Path:
        """A copy of the fixture run with files replaced (``damage``: relative path -> bytes, or
        None for a folder in place of the file) or removed."""
        d = self.root / "runs" / name
        if d.exists():
            shutil.rmtree(d)
        shutil.copytree(self.run, d)
        for rel in remove:
            p = d / rel
            shutil.rmtree(p) if p.is_dir() else p.unlink()
        for rel, data in (damage or {}).items():
            p = d / rel
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
            if data is None:
                p.mkdir(parents=True)
            else:
                p.parent.mkdir(parents=True, exist_ok=True)
                p.write_bytes(data)
        return d


GARBAGE = bytes(range(256)) * 4
NON_UTF8 = b"design:\n  D: 18\n  name: \xff\xfe\xfa\n"


def run_case(case: Case, w: Workspace, timeout: float) -> Outcome:
    """Run one case as ``whisker-opt ...`` in the workspace ``w``; check its exit status, stderr and the files."""
    before = {p: _tree_digest(p) for p in case.frozen}
    done = run_cli(*case.argv, cli=w.cli, cwd=w.root, timeout=timeout, env={**w.env, **case.env})
    rc, err = done.returncode, done.stderr
    if done.timed_out:
        err = err.replace("\n", " (computing?)\n", 1)
    o = Outcome(case, rc, err, done.seconds)
    if rc != case.expect:
        o.problems.append(f"exit {rc}, expected {case.expect}")
    if len(o.lines) != 1:
        o.problems.append(f"{len(o.lines)} stderr lines")
    if o.traceback:
        o.problems.append("traceback")
    if o.aborted:
        o.problems.append("abort")
    if o.timed_out:
        o.problems.append("timed out")
    first = o.lines[0] if o.lines else ""
    missing = [wd for wd in case.words if wd.lower() not in first.lower()]
    if missing:
        o.problems.append(f"message lacks {missing}")
    for p in case.absent:
        if Path(p).exists():
            o.problems.append(f"wrote {p}")
            if Path(p).is_dir():
                shutil.rmtree(p, ignore_errors=True)
            else:
                Path(p).unlink()
    for p, digest in before.items():
        if _tree_digest(p) != digest:
            o.problems.append(f"changed {p}")
    for p in case.present:
        if not Path(p).is_file() or Path(p).stat().st_size == 0:
            o.problems.append(f"did not write {p}")
    return o
