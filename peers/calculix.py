"""CalculiX (``ccx``) as an independent peer solver for 10-node tet hyperelastic problems.

The in-house solver is cross-checked by running *the same mesh, material and loads*
through CalculiX: :mod:`whisker_opt.output.calculix_deck` writes the input deck (its docstring
holds the conventions and tolerances), :func:`run_ccx` runs ``ccx`` and parses the
nodal displacements and reaction forces back into our node order.

CalculiX quirks found while pinning this driver (CalculiX 2.20, Debian build)
---------------------------------------------------------------------------
* Convergence (``checkconvergence.c``): an increment converges after >= 2 iterations
  when ``r_max <= R_n q`` and either ``c_max <= C_n du_max`` or an estimate of the next
  correction is small or ``c_max < 1e-8`` *absolute* (length units). The average force
  ``q`` is computed, not seeded, when ``q0`` is left blank (CalculiX's own default 0).
* ``.dat`` values have 7 significant digits (``1.234567E-02``); the ASCII ``.frd``
  only 6, so results are parsed from the ``.dat`` file. Three-digit exponents lose
  their ``E`` (``1.234567-100``), which :func:`parse_dat` handles.
* ``RF`` at unconstrained DOFs is the residual force (round-off, not zero). Loads on
  fully constrained nodes never appear in ``RF``; a model with no free DOF is not
  solved at all (zero output).
* ``*NODE PRINT/FILE, FREQUENCY=k`` still writes the end of the step.
* Failures: exit code 201 with ``*ERROR: solution seems to diverge`` (DIRECT) or
  ``increment size smaller than minimum``; exit code 255 when SPOOLES finds the
  matrix singular after a diverged iteration (``spooles.out``).
* CalculiX factors a *symmetric* system even with follower pressure: under
  compressive pressure Newton converges only linearly and a DIRECT step may
  diverge where a consistent tangent would not; use more increments or
  ``direct=False`` there.
"""

from __future__ import annotations

import logging
import math
import os
import re
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from whisker_opt.output.calculix_deck import (  # noqa: F401  (the deck API, re-exported)
    CcxCase,
    _fmt,
    element_faces,
    write_deck,
)

logger = logging.getLogger(__name__)

#: name of the CalculiX executable searched on PATH
CCX_EXECUTABLE = "ccx"


class CcxError(RuntimeError):
    """CalculiX failed, did not converge, or produced output that cannot be parsed.

    Attributes
    ----------
    workdir : Path or None
        Directory holding the deck and CalculiX's output files.
    log_tail : str
        Last lines of CalculiX's console output.
    """

    def __init__(self, message: str, workdir: Path | None = None, log_tail: str = "") -> None:
        full = message
        if workdir is not None:
            full += f" (workdir: {workdir})"
        if log_tail:
            full += "\n--- ccx log tail ---\n" + log_tail
        super().__init__(full)
        self.workdir = workdir
        self.log_tail = log_tail


def ccx_available() -> bool:
    """Whether the CalculiX executable ``ccx`` is on ``PATH``."""
    return shutil.which(CCX_EXECUTABLE) is not None


@dataclass(frozen=True, eq=False)
class CcxResult:
    """Output of :func:`run_ccx` at the end of the step (load factor 1).

    Attributes
    ----------
    displacements : ndarray, shape (n_nodes, 3)
        Nodal displacements in the input node order (NaN if not converged).
    reactions : ndarray, shape (n_nodes, 3) or None
        Nodal reaction forces ``RF`` (zero at unconstrained DOFs); None if not printed.
    wall_time : float
        Wall-clock seconds of the ``ccx`` process.
    converged : bool
        Whether the step finished at total time 1 without errors.
    n_increments : int
        Converged increments (from the ``.sta`` file).
    n_iterations : int
        Total Newton iterations over all attempts, including cut-back ones (from the
        ``.sta`` file).
    n_cutbacks : int
        Increment attempts that were abandoned and retried smaller (``direct=False``).
    workdir : Path
        Directory with the deck (``<job>.inp``) and CalculiX's output.
    log_path : Path
        CalculiX's console output.
    dat_path : Path
        The ``.dat`` file with the printed nodal results.
    """

    displacements: np.ndarray
    reactions: np.ndarray | None
    wall_time: float
    converged: bool
    n_increments: int
    n_iterations: int
    n_cutbacks: int
    workdir: Path
    log_path: Path
    dat_path: Path


# --------------------------------------------------------------------------- output

_HEADER = re.compile(r"^\s*(displacements|forces)\s*\(.*\)\s*for set\s+(\S+)\s+and time\s+(\S+)", re.I)
# Fortran drops the 'E' for three-digit exponents: 0.123456-100
_FORTRAN_EXP = re.compile(r"(?<=[0-9.])([+-]\d{3})$")


def _to_float(tok: str) -> float:
    try:
        return float(tok)
    except ValueError:
        fixed = _FORTRAN_EXP.sub(r"E\1", tok)
        return float(fixed)


def parse_dat(path: str | os.PathLike, n_nodes: int) -> dict[str, tuple[float, np.ndarray]]:
    """Parse the last printed displacement and force blocks of a CalculiX ``.dat`` file.

    Parameters
    ----------
    path : path-like
        The ``.dat`` file.
    n_nodes : int
        Number of nodes; values of nodes that are not printed stay NaN.

    Returns
    -------
    dict
        ``{"U": (time, (n_nodes, 3)), "RF": (time, (n_nodes, 3))}`` for the blocks present
        (the last block of each kind).

    Raises
    ------
    CcxError
        If a data line cannot be parsed.
    """
    out: dict[str, tuple[float, np.ndarray]] = {}
    key = None
    rows: list[tuple[int, float, float, float]] = []
    t = math.nan

    def flush() -> None:
        if key is None:
            return
        arr = np.full((n_nodes, 3), np.nan)
        if rows:
            ids = np.array([r[0] for r in rows], dtype=np.int64) - 1
            vals = np.array([r[1:] for r in rows], dtype=np.float64)
            ok = (ids >= 0) & (ids < n_nodes)
            arr[ids[ok]] = vals[ok]
        out[key] = (t, arr)

    with open(path) as f:
        for lineno, line in enumerate(f, 1):
            m = _HEADER.match(line)
            if m:
                flush()
                key = "U" if m.group(1).lower() == "displacements" else "RF"
                t = _to_float(m.group(3))
                rows = []
                continue
            if key is None:
                continue
            parts = line.split()
            if not parts:
                continue
            if len(parts) != 4 or not parts[0].isdigit():
                # another kind of block (totals, stresses, ...) ends this one
                flush()
                key = None
                continue
            try:
                rows.append((int(parts[0]), *(_to_float(p) for p in parts[1:])))
            except ValueError as exc:
                raise CcxError(f"parse_dat: cannot parse line {lineno} of {path}: {line!r}") from exc
    flush()
    return out


def _parse_sta(path: Path) -> tuple[int, int, int, float]:
    """Parse a ``.sta`` file.

    Returns converged increments, Newton iterations of all attempts, cut-back
    attempts (``ATT`` marked ``U``) and the total time of the last converged increment.
    """
    n_inc = n_it = n_cut = 0
    t_end = 0.0
    if not path.exists():
        return 0, 0, 0, 0.0
    for line in path.read_text(errors="replace").splitlines():
        parts = line.split()
        if len(parts) < 7 or not (parts[0].isdigit() and parts[1].isdigit() and parts[3].isdigit()):
            continue
        if parts[2].isdigit():
            try:
                t_end = _to_float(parts[4])
            except ValueError:
                continue
            n_inc += 1
        elif parts[2].rstrip("U").isdigit():
            n_cut += 1
        else:
            continue
        n_it += int(parts[3])
    return n_inc, n_it, n_cut, t_end


def _tail(path: Path, n_lines: int = 30) -> str:
    if not path.exists():
        return ""
    lines = path.read_text(errors="replace").splitlines()
    return "\n".join(lines[-n_lines:])


def run_ccx(
    case: CcxCase,
    workdir: str | os.PathLike | None = None,
    threads: int = 1,
    timeout: float | None = None,
    job: str = "job",
    raise_on_failure: bool = True,
    cleanup: bool = False,
) -> CcxResult:
    """Write the deck of ``case``, run CalculiX and read the final nodal results.

    Parameters
    ----------
    case : CcxCase
    workdir : path-like, optional
        Directory for the deck and output (created if missing). Default: a new
        temporary directory, which is kept so the logs stay available.
    threads : int
        Threads for CalculiX (``OMP_NUM_THREADS`` and ``CCX_NPROC_*``), >= 1.
    timeout : float, optional
        Seconds before the ``ccx`` process is killed (raises :class:`CcxError`).
    job : str
        Job name (deck ``<job>.inp``); letters, digits, ``_`` and ``-`` only.
    raise_on_failure : bool
        If True (default) raise :class:`CcxError` when CalculiX fails or does not
        converge; if False return a result with ``converged=False`` and NaN fields.
    cleanup : bool
        Delete ``workdir`` after a converged run (for benchmarks running many
        solves; the paths in the result then no longer exist). Failed runs are kept.

    Returns
    -------
    CcxResult

    Raises
    ------
    CcxError
        ``ccx`` missing, killed by the timeout, exited with an error, did not reach
        the end of the step, or printed unparsable results.
    """
    if not ccx_available():
        raise CcxError(f"run_ccx: executable {CCX_EXECUTABLE!r} not found on PATH")
    if not (isinstance(threads, (int, np.integer)) and threads >= 1):
        raise ValueError(f"run_ccx.threads: {threads!r}, expected an int >= 1")
    if not re.fullmatch(r"[A-Za-z0-9_-]+", job):
        raise ValueError(f"run_ccx.job: {job!r}, expected letters, digits, '_' or '-'")
    if timeout is not None and not timeout > 0:
        raise ValueError(f"run_ccx.timeout: {timeout!r}, expected > 0 seconds or None")

    wd = Path(tempfile.mkdtemp(prefix="ccx_")) if workdir is None else Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)
    for suffix in (".dat", ".sta", ".frd", ".cvg"):
        (wd / f"{job}{suffix}").unlink(missing_ok=True)
    write_deck(case, wd / f"{job}.inp")
    log_path = wd / f"{job}.log"
    dat_path = wd / f"{job}.dat"

    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "CCX_NPROC_EQUATION_SOLVER", "CCX_NPROC_RESULTS", "CCX_NPROC_STIFFNESS"):
        env[var] = str(int(threads))
    exe = shutil.which(CCX_EXECUTABLE)
    logger.info(
        "running CalculiX: %d nodes, %d elements, %d increments, %d thread(s) in %s",
        case.n_nodes, len(case.cells), case.n_increments, threads, wd,
    )
    rc, wall = _execute(exe, job, wd, env, timeout, log_path)

    n_inc, n_it, n_cut, t_end = _parse_sta(wd / f"{job}.sta")
    problems, disp, reac = _read_results(case, log_path, dat_path, rc, t_end)
    n = case.n_nodes

    converged = not problems
    if not converged:
        spooles = wd / "spooles.out"
        if spooles.exists() and spooles.read_text(errors="replace").strip():
            problems.append(f"spooles.out: {spooles.read_text(errors='replace').strip()[:200]!r}")
        msg = f"run_ccx: CalculiX did not converge or failed: {'; '.join(problems)}"
        if case.direct:
            msg += (
                f". A DIRECT increment cannot be cut back: raise n_increments "
                f"(now {case.n_increments}) or use CcxCase(direct=False)"
            )
        if raise_on_failure:
            raise CcxError(msg, wd, _tail(log_path))
        logger.warning("%s (workdir %s)", msg, wd)
        disp = np.full((n, 3), np.nan)
        reac = np.full((n, 3), np.nan) if case.print_reactions else None
    else:
        logger.info(
            "CalculiX finished in %.2f s: %d increments, %d iterations, %d cut-backs",
            wall, n_inc, n_it, n_cut,
        )
        if cleanup:
            shutil.rmtree(wd, ignore_errors=True)
    return CcxResult(
        displacements=disp, reactions=reac, wall_time=wall, converged=converged,
        n_increments=n_inc, n_iterations=n_it, n_cutbacks=n_cut,
        workdir=wd, log_path=log_path, dat_path=dat_path,
    )


def _execute(exe: str, job: str, wd: Path, env: dict, timeout: float | None, log_path: Path) -> tuple[int, float]:
    """Run ``ccx -i job`` in ``wd`` with its output in ``log_path``: (exit code, wall time [s]).

    Raises
    ------
    CcxError
        Killed by the timeout.
    """
    t0 = time.perf_counter()
    with open(log_path, "w") as log:
        try:
            proc = subprocess.run(
                [exe, "-i", job], cwd=wd, env=env, stdout=log, stderr=subprocess.STDOUT,
                timeout=timeout, check=False,
            )
            rc = proc.returncode
        except subprocess.TimeoutExpired:
            wall = time.perf_counter() - t0
            raise CcxError(
                f"run_ccx: ccx killed after timeout={timeout} s (ran {wall:.1f} s)", wd, _tail(log_path)
            ) from None
    wall = time.perf_counter() - t0
    return rc, wall


def _read_results(case: CcxCase, log_path: Path, dat_path: Path, rc: int, t_end: float) -> tuple:
    """(problems, displacements, reactions) of a finished ``ccx`` run: what the exit code, the log and the
    status file's end time say went wrong, and the last printed nodal blocks (NaN where missing)."""
    log_text = log_path.read_text(errors="replace")
    problems = []
    if rc != 0:
        problems.append(f"exit code {rc}")
    if "*ERROR" in log_text:
        lines = log_text.splitlines()
        k = next(i for i, ln in enumerate(lines) if "*ERROR" in ln)
        msg = " ".join(ln.strip() for ln in lines[k : k + 2] if ln.strip())
        problems.append(f"reported {msg!r}")
    if "Job finished" not in log_text:
        problems.append("no 'Job finished' in the log")
    if not abs(t_end - 1.0) < 1e-6:
        problems.append(f"step reached total time {t_end:g} of 1")

    n = case.n_nodes
    disp = np.full((n, 3), np.nan)
    reac = np.full((n, 3), np.nan) if case.print_reactions else None
    if not problems:
        blocks = parse_dat(dat_path, n) if dat_path.exists() else {}
        if "U" not in blocks:
            problems.append(f"no displacement block in {dat_path.name}")
        else:
            t_u, disp = blocks["U"]
            if not abs(t_u - 1.0) < 1e-6:
                problems.append(f"last printed displacements at time {t_u:g}, expected 1")
            if np.isnan(disp).any():
                problems.append(f"{int(np.isnan(disp).any(axis=1).sum())} nodes missing or NaN in U")
        if case.print_reactions:
            if "RF" not in blocks:
                problems.append(f"no reaction-force block in {dat_path.name}")
            else:
                reac = blocks["RF"][1]
    return problems, disp, reac


# --------------------------------------------------------------------------- exported scene decks

_TOTALS = re.compile(r"^\s*total force \(fx,fy,fz\) for set\s+(\S+)\s+and time\s+(\S+)", re.I)
_FRD_STEP = re.compile(r"^\s*100C\S*\s+\S+\s+(\S+)")


def parse_dat_totals(path: str | os.PathLike) -> dict[str, dict[float, np.ndarray]]:
    """The ``*NODE PRINT, TOTALS=ONLY`` blocks of a ``.dat`` file: ``{set: {time: (fx, fy, fz)}}``.

    Raises
    ------
    CcxError
        A totals header without its line of three numbers.
    """
    out: dict[str, dict[float, np.ndarray]] = {}
    lines = Path(path).read_text(errors="replace").splitlines()
    for k, line in enumerate(lines):
        m = _TOTALS.match(line)
        if not m:
            continue
        row = next((ln.split() for ln in lines[k + 1:k + 4] if ln.strip()), [])
        try:
            out.setdefault(m.group(1).upper(), {})[_to_float(m.group(2))] = np.array([_to_float(v) for v in row])
        except ValueError as exc:
            raise CcxError(f"parse_dat_totals: cannot parse the totals after line {k + 1} of {path}: {row!r}") from exc
        if len(row) != 3:
            raise CcxError(f"parse_dat_totals: line {k + 2} of {path} holds {len(row)} numbers, expected 3")
    return out


def parse_frd_displacements(path: str | os.PathLike, n_nodes: int) -> dict[float, np.ndarray]:
    """Every ``DISP`` block of an ASCII ``.frd`` file: ``{time: (n_nodes, 3)}``, NaN for nodes not written.

    The data lines are ``-1``, the node id in 10 columns and 12-column values with 6 significant digits
    (CalculiX's ASCII format); nodes beyond ``n_nodes`` (the fibres' nodes of a scene deck) are left out.
    """
    out: dict[float, np.ndarray] = {}
    t, arr = math.nan, None
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith(" -1") and arr is not None:
                node = int(line[3:13]) - 1
                if node < n_nodes:
                    arr[node] = [_to_float(line[13 + 12 * i:25 + 12 * i]) for i in range(3)]
                continue
            m = _FRD_STEP.match(line)
            if m:
                t = _to_float(m.group(1))
            elif line.startswith(" -4"):
                arr = np.full((n_nodes, 3), np.nan) if line.split()[1] == "DISP" else None
                if arr is not None:
                    out[t] = arr
            elif line.startswith(" -3"):
                arr = None
    return out


def run_deck(deck: str | os.PathLike, threads: int = 1, timeout: float | None = None) -> tuple[int, float, Path]:
    """Run ``ccx`` on an existing deck in its folder: (exit code, wall time [s], console log).

    Raises
    ------
    CcxError
        ``ccx`` missing, or killed by the timeout.
    """
    if not ccx_available():
        raise CcxError(f"run_deck: executable {CCX_EXECUTABLE!r} not found on PATH")
    deck = Path(deck)
    env = dict(os.environ)
    for var in ("OMP_NUM_THREADS", "CCX_NPROC_EQUATION_SOLVER", "CCX_NPROC_RESULTS", "CCX_NPROC_STIFFNESS"):
        env[var] = str(int(threads))
    log = deck.with_suffix(".log")
    rc, wall = _execute(shutil.which(CCX_EXECUTABLE), deck.stem, deck.parent, env, timeout, log)
    return rc, wall, log


@dataclass(frozen=True)
class SceneDeckResult:
    """What CalculiX computed for an exported scene deck (:mod:`whisker_opt.output.scene_deck`), read as the
    in-house scene reads its own solution.

    Attributes
    ----------
    times : tuple of float
        The phase ends written (1: pressurised, 2: deflected; 1 alone for a vented scene).
    delta_l : float
        Tip extension Δl [mm] at the end of the pressurise phase: mean axial displacement of the mesh's
        ``tip`` nodes (as ``SceneResult.delta_l``); 0 for a vented scene.
    contact_force : float
        Force of the pusher on the whisker at the largest deflection [N]: −F_y of the ``CONTACT`` set's
        reactions.
    eps : dict of str -> float
        Every registered gauge reading at the largest deflection relative to the pressurised state (calibrated,
        :class:`whisker_opt.experiment.gauge.GaugeReader` on the ``.frd`` displacements of the rubber's nodes).
    """

    times: tuple
    delta_l: float
    contact_force: float
    eps: dict


def read_scene_deck(deck: str | os.PathLike, wm, spec) -> SceneDeckResult:
    """Read the ``.dat`` and ``.frd`` files CalculiX wrote for the scene deck ``deck`` of ``spec`` on ``wm``.

    Raises
    ------
    CcxError
        A phase end missing from the ``.dat`` or the ``.frd`` file (CalculiX stopped before the end).
    """
    from whisker_opt.experiment.gauge import GaugedMesh, GaugeReader
    from whisker_opt.experiment.scene import reading_context

    deck = Path(deck)
    n, phases = wm.mesh.n_nodes, (spec.Q > 0) + 1
    want = tuple(float(k) for k in range(1, phases + 1))
    totals = parse_dat_totals(deck.with_suffix(".dat")).get("CONTACT", {})
    disp = parse_frd_displacements(deck.with_suffix(".frd"), n)
    missing = [t for t in want if t not in totals or t not in disp]
    if missing:
        raise CcxError(f"read_scene_deck: {deck.name}: no results at step time(s) {missing} of {list(want)}",
                       deck.parent)
    u_end, u_onset = disp[want[-1]], (disp[1.0] if phases == 2 else np.zeros((n, 3)))
    reader = GaugeReader(wm.mesh, GaugedMesh.locate(wm, spec.design).gauge, spec.calibration,
                         reading_context(spec))
    reader.zero(u_onset)
    dl = float(u_onset[wm.node_sets["tip"], 0].mean())
    return SceneDeckResult(want, dl, -float(totals[want[-1]][1]), reader.read(u_end))
