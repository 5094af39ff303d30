"""Progress of the long jobs: a bar on a terminal, one log line per step with elapsed time and ETA.

Every long job (``run``, ``resume``, ``verify``, ``compensate``, ``robustness``, ``calibrate``,
``mesh``) reports through :class:`Progress`:

- a tqdm bar on stderr, drawn only when stderr is a terminal and progress is enabled
  (:func:`progress_bar`);
- one INFO record per step (a generation, a design, a scene, a model evaluation, a cell) on the
  logger :data:`PROGRESS_LOGGER`, written whether or not a bar is drawn:

      <job>: <unit> <done>/<total> <detail>; elapsed <t>, ETA <t>

  The ETA is the time per step so far (steps of this invocation) times the steps left; where the
  total is an upper bound (a run that a stopping rule may end early, a fit that may converge
  before its budget) it is stated as ``ETA ≤``.

The records reach a run's ``run.log`` and the console at ``-v``. The command line shows them
without ``-v`` when stderr is not a terminal (a batch job, ``nohup``, a scheduler), where no bar
is drawn, unless ``--no-progress`` is given (:func:`show_progress_lines`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import sys
import time
from typing import Iterator

#: The logger of the progress lines (INFO).
PROGRESS_LOGGER = "whisker_opt.progress"

logger = logging.getLogger(PROGRESS_LOGGER)


def stderr_is_terminal() -> bool:
    """True when ``sys.stderr`` is a terminal (a bar can be drawn on it)."""
    return bool(getattr(sys.stderr, "isatty", lambda: False)())


def progress_bar(total: int | None, desc: str, unit: str, enabled: bool = True, initial: int = 0):
    """A tqdm bar on stderr, shown only when ``enabled`` and stderr is a terminal.

    Parameters
    ----------
    total : int or None
        Expected count.
    desc, unit : str
        Label and unit of the count.
    enabled : bool
        False hides it (``progress=False`` / ``--no-progress``).
    initial : int
        Count already done (a resumed job).

    Returns
    -------
    tqdm.tqdm
    """
    from tqdm import tqdm

    shown = bool(enabled) and stderr_is_terminal()
    return tqdm(total=total, initial=initial, desc=desc, unit=unit, disable=not shown, dynamic_ncols=True,
                file=sys.stderr)


def format_duration(seconds: float) -> str:
    """``"42 s"``, ``"3 min 05 s"``, ``"2 h 07 min"``; ``"?"`` when not finite.

    Parameters
    ----------
    seconds : float

    Returns
    -------
    str
    """
    if not math.isfinite(seconds):
        return "?"
    s = int(round(max(seconds, 0.0)))
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


class Progress:
    """A long job's progress: a bar on a terminal and a log line per step (see the module docstring).

    Parameters
    ----------
    total : int
        Steps expected.
    desc : str
        Names the job in the bar and the log lines (``"verify at fine"``).
    unit : str
        What a step is (``"design"``, ``"scene"``, ``"generation"``).
    enabled : bool
        False draws no bar (the log lines are written either way).
    initial : int
        Steps done before (a resumed job); the ETA counts only the steps of this invocation.
    bar : bool
        False: log lines only (another bar already counts finer steps).
    at_most : bool
        ``total`` is an upper bound: the ETA is stated as ``ETA ≤``.
    """

    def __init__(self, total: int, desc: str, unit: str, enabled: bool = True, initial: int = 0, bar: bool = True,
                 at_most: bool = False) -> None:
        self.total, self.desc, self.unit, self.at_most = int(total), desc, unit, at_most
        self.done = self.initial = int(initial)
        self.t0 = time.perf_counter()
        self.bar = progress_bar(self.total, desc, unit, enabled and bar, initial=self.initial)

    @property
    def elapsed(self) -> float:
        """Seconds since the start of this invocation."""
        return time.perf_counter() - self.t0

    def eta(self) -> float:
        """Seconds left at the rate so far (inf before the first step of this invocation)."""
        steps = self.done - self.initial
        if steps <= 0:
            return math.inf
        return max(self.total - self.done, 0) * self.elapsed / steps

    def line(self, detail: str = "") -> str:
        """The log line of the count as it stands."""
        of = f"{self.done}/{self.total}" if not self.at_most else f"{self.done} of at most {self.total}"
        left = "ETA ≤" if self.at_most and self.done < self.total else "ETA"
        more = f" {detail}" if detail else ""
        return (f"{self.desc}: {self.unit} {of}{more}; elapsed {format_duration(self.elapsed)}, "
                f"{left} {format_duration(self.eta())}")

    def step(self, detail: str = "", n: int = 1) -> None:
        """Count ``n`` steps done, move the bar and log a line (``detail`` says what was done)."""
        self.done += int(n)
        self.total = max(self.total, self.done)
        self.bar.total = self.total
        self.bar.update(int(n))
        logger.info("%s", self.line(detail))

    def close(self) -> None:
        """Close the bar."""
        self.bar.close()

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@contextlib.contextmanager
def show_progress_lines(enabled: bool = True) -> Iterator[bool]:
    """Let the progress lines through to the console for the duration, when ``enabled`` and stderr
    is not a terminal (where no bar is drawn).

    The logger :data:`PROGRESS_LOGGER` is set to INFO (a console at WARNING then shows its records
    and no other INFO record); its level is restored on exit.

    Parameters
    ----------
    enabled : bool
        False (``--no-progress``) leaves the logger as it is.

    Yields
    ------
    bool
        Whether the lines are shown.
    """
    shown = bool(enabled) and not stderr_is_terminal()
    old = logger.level
    if shown and (old == logging.NOTSET or old > logging.INFO):
        logger.setLevel(logging.INFO)
    try:
        yield shown
    finally:
        logger.setLevel(old)
