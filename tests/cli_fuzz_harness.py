"""Malformed run files through the real command line: the check of one variant of the run-file
fuzzer (:mod:`tests.config_mutations`) run as ``whisker-opt mesh FILE --out DIR``.

A variant that the run-file checks refuse (:func:`needs_cli`) must exit with status 2 before
computing (no output folder appears) and write exactly one line to stderr,
``whisker-opt mesh: error: <what>``, naming the file or the key at fault, and no Python traceback
(:meth:`Outcome.problems`). Shared by ``tests/test_cli_fuzz_sample.py`` (a cheap sample) and
``benchmarks/reliability/fuzz_cli.py`` (hundreds of variants, as counts).
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

from geometry.design import InvalidDesignError
from tests.config_mutations import Variant
from tests.subprocess_run import run_cli
from whisker_opt import wiring
from whisker_opt.config.model import ConfigError, load_config

PREFIX = "whisker-opt mesh: error: "
#: The warning of a renamed key: ``config key 'scene.Q' is deprecated: write 'scene.Q_i'``.
DEPRECATION = re.compile(r"config key '[^']+' is deprecated: write '[^']+'$")


@dataclass
class Outcome:
    """What the command line did with one variant."""

    variant: Variant
    path: Path
    code: int
    seconds: float
    stderr: str
    wrote: bool

    @property
    def lines(self) -> list[str]:
        """Lines on stderr, without the deprecation warnings of renamed keys (which the file uses on purpose)."""
        return [ln for ln in self.stderr.splitlines() if ln.strip() and not DEPRECATION.search(ln)]

    @property
    def deprecations(self) -> int:
        return sum(bool(DEPRECATION.search(ln)) for ln in self.stderr.splitlines())

    @property
    def traceback(self) -> bool:
        return "Traceback (most recent call last)" in self.stderr

    def problems(self) -> list[str]:
        """Why this outcome is not a clean one-line refusal (empty when it is)."""
        out = []
        if self.code != 2:
            out.append(f"exit {self.code}")
        if self.traceback:
            out.append("traceback")
        errors = [ln for ln in self.lines if ln.startswith(PREFIX)]
        if len(errors) != 1:
            out.append(f"{len(errors)} error lines")
        elif str(self.path) not in errors[0] and "design." not in errors[0]:
            out.append("names neither the file nor a design key")
        if self.wrote:
            out.append("wrote output")
        return out


def needs_cli(v: Variant, path: Path) -> bool:
    """True when the run-file checks refuse the variant (so ``mesh`` must fail before computing)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # renamed keys are read on purpose
        try:
            cfg = load_config(path)
        except ConfigError:
            return True
    try:
        wiring.design_from_config(cfg, cfg.scene.trim)
    except InvalidDesignError:
        return True
    return False


def run_one(v: Variant, path: Path, out: Path, timeout: float, cli: list[str] | None = None) -> Outcome:
    """``whisker-opt mesh PATH --out OUT`` in a subprocess (:func:`tests.subprocess_run.run_cli`); its outcome.

    A run stopped at ``timeout`` has the exit code -999."""
    done = run_cli("mesh", path, "--out", out, cli=cli, cwd=path.parent, timeout=timeout)
    return Outcome(v, path, -999 if done.timed_out else done.returncode, done.seconds, done.stderr, out.exists())
