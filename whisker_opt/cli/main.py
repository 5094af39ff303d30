"""Command-line interface: ``whisker-opt <command> ...``.

Every error prints one line to stderr, ``whisker-opt <command>: error: <message>``, and no
traceback: a bad input (an option value, a config, an output folder, a run directory) exits
with status 2 before anything is computed, as does a file-system refusal (a name too long,
no permission, a read-only disk); a computation that fails on valid inputs (a scene that does
not converge, a mesh that cannot be made, workers or the dask scheduler lost during a run, a
disk that fills up while results are written: the line names the file) exits with status 3; a calibration that
wrote its outputs but did not converge exits with status 4
(:data:`whisker_opt.cli.calibrate.NOT_CALIBRATED`). Any other exception is a bug and keeps its
traceback.

Progress: on a terminal a bar; when stderr is not a terminal (a batch job, ``nohup``, a
scheduler) one line per generation, design, scene, model evaluation or step with elapsed
time and ETA (:mod:`whisker_opt.output.progress`); ``--no-progress`` turns both off.

``-v/--verbose`` (counted) and ``--no-progress`` are accepted before or after the command
(``whisker-opt -v run CFG`` and ``whisker-opt run CFG -v``; the counts add up). ``-v`` shows
INFO and ``-vv`` DEBUG records while the chatty libraries of :data:`QUIET_LOGGERS` stay at
WARNING (with or without ``-v``: a filter on the console's handlers, so a library that sets its
own loggers' levels when it is imported, as distributed does, stays quiet too); ``-vvv`` lets
every logger through.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import logging
import shlex
import signal
import sys
import threading
from pathlib import Path

from whisker_opt.cli import commands
from whisker_opt.output.progress import show_progress_lines


#: Third-party loggers kept at WARNING at ``-v`` and ``-vv`` (their DEBUG output drowns the program's).
QUIET_LOGGERS = ("matplotlib", "PIL", "numba", "distributed", "asyncio", "urllib3", "fsspec", "tornado")

#: errno values of an OSError the user's file system causes (not a bug of the program).
_FILE_SYSTEM_ERRNOS = frozenset(
    getattr(errno, name) for name in ("EACCES", "EPERM", "EROFS", "ENOSPC", "EDQUOT", "ENAMETOOLONG", "ELOOP",
                                      "ENOTDIR", "EISDIR", "EEXIST", "EMLINK", "EFBIG") if hasattr(errno, name)
)
#: Of those, a disk or quota that ran out while writing: the inputs were valid (exit status 3).
_NO_SPACE_ERRNOS = frozenset(getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EFBIG") if hasattr(errno, name))


def _file_system_message(exc: OSError) -> str:
    names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
    text = f"{' -> '.join(names)}: {exc.strerror}" if names and exc.strerror else str(exc)
    if exc.errno in _NO_SPACE_ERRNOS:
        text += ("; it was not written (files are replaced whole, so the previous version, if any, is intact): free "
                 "some space and run the command again (`whisker-opt resume RUN_DIR` continues a run)")
    return text


class _QuietLibraries(logging.Filter):
    """On a console handler: drops records below WARNING of the loggers in :data:`QUIET_LOGGERS`.

    A filter on the handler, not a level on the loggers, because a library may set its loggers'
    levels when it is first imported (distributed sets its own to INFO), after the console was set up.
    """

    def filter(self, record: logging.LogRecord) -> bool:  # noqa: D102 - logging.Filter.filter
        if record.levelno >= logging.WARNING:
            return True
        return not any(record.name == n or record.name.startswith(n + ".") for n in QUIET_LOGGERS)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (with a pointer to ``--help``), status 2."""

    def error(self, message: str):  # noqa: D102 - argparse.ArgumentParser.error
        self.exit(2, f"{self.prog}: error: {one_line(message)} (see `{self.prog} --help`)\n")


def one_line(message: str) -> str:
    """``message`` with its lines joined by ``; `` and runs of spaces kept as they are.

    Parameters
    ----------
    message : str

    Returns
    -------
    str
    """
    return "; ".join(ln.strip() for ln in str(message).strip().splitlines() if ln.strip())


class _Version(argparse.Action):
    """``--version``: print ``whisker-opt <version>`` and exit (the version is looked up only then)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):  # noqa: D102 - argparse.Action
        import whisker_opt

        print(f"whisker-opt {whisker_opt.__version__}")
        parser.exit()


_VERBOSE_HELP = "more log output: -v info, -vv debug, -vvv also the debug output of libraries (matplotlib, numba, ...)"


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="whisker-opt",
        description="Design optimiser for soft, pneumatically tunable whisker sensors.",
        epilog="Exit status: 0 done; 2 a bad input (nothing computed); 3 a computation failed; 4 a calibration did "
               "not converge (its outputs say so); 130 interrupted.",
    )
    p.add_argument("--version", action=_Version, help="print the version and exit")
    p.add_argument("-v", "--verbose", action="count", default=0, help=_VERBOSE_HELP)
    p.add_argument("--no-progress", action="store_true", default=False,
                   help="no progress bar on a terminal, no progress lines elsewhere")
    # after the command: counted apart (a subparser's namespace replaces the top-level value) and added up
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-v", "--verbose", dest="verbose_after", action="count", default=argparse.SUPPRESS,
                        help=_VERBOSE_HELP)
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (helptext, add_args, _) in commands.REGISTRY.items():
        sp = sub.add_parser(name, help=helptext, description=helptext, parents=[common])
        add_args(sp)
        if "--no-progress" not in sp._option_string_actions:  # after any command, as before it
            sp.add_argument("--no-progress", action="store_true", default=argparse.SUPPRESS,
                            help="no progress bar on a terminal, no progress lines elsewhere")
    return p


def _set_up_logging(verbose: int) -> None:
    """Console logging at WARNING, INFO (``-v``), DEBUG (``-vv``, :data:`QUIET_LOGGERS` kept at WARNING)
    or DEBUG of every logger (``-vvv``)."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    root = logging.getLogger()
    root.setLevel(level)  # also when a handler was installed before (basicConfig then does nothing)
    for name in QUIET_LOGGERS:
        logging.getLogger(name).setLevel(logging.WARNING if verbose <= 2 else logging.NOTSET)
    for handler in root.handlers:  # one filter per handler, also when main() runs again in this process
        for old in [f for f in handler.filters if isinstance(f, _QuietLibraries)]:
            handler.removeFilter(old)
        if verbose <= 2:
            handler.addFilter(_QuietLibraries())


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, raised in the main thread as Ctrl-C is, so a run ends the same way."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextlib.contextmanager
def _termination_as_interrupt():
    """While a command runs, SIGTERM and SIGHUP (a scheduler's stop, a closed terminal) end it as SIGINT does:
    the same clean-up, a message and exit status 128 + the signal's number."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, _frame):
        raise Terminated(signum)

    names = [n for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    old = {n: signal.signal(getattr(signal, n), handler) for n in names}
    try:
        yield
    finally:
        for n, h in old.items():
            signal.signal(getattr(signal, n), h)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``whisker-opt`` (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0; 2 for a bad input; 3 for a failed computation; 4 for a calibration that did not converge;
        130 when interrupted (128 + the signal for SIGTERM and SIGHUP).
    """
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # --help, or an argparse error already printed
        return int(exc.code or 0) if isinstance(exc.code, int) or exc.code is None else 2
    args.verbose += getattr(args, "verbose_after", 0)
    _set_up_logging(args.verbose)
    _, _, run = commands.REGISTRY[args.command]
    try:
        with show_progress_lines(not getattr(args, "no_progress", False)), _termination_as_interrupt():
            return int(run(args) or 0)
    except commands.USER_ERRORS as exc:
        print(f"whisker-opt {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except commands.COMPUTATION_ERRORS as exc:
        print(f"whisker-opt {args.command}: error: {one_line(exc)}", file=sys.stderr)
        return 3
    except OSError as exc:
        if exc.errno not in _FILE_SYSTEM_ERRNOS:
            raise
        print(f"whisker-opt {args.command}: error: {one_line(_file_system_message(exc))}", file=sys.stderr)
        return 3 if exc.errno in _NO_SPACE_ERRNOS else 2
    except KeyboardInterrupt as exc:
        signum = getattr(exc, "signum", signal.SIGINT)
        print(f"whisker-opt {args.command}: interrupted by {signal.Signals(signum).name}{_continue_hint(args, argv)}",
              file=sys.stderr)
        return 128 + int(signum)


def _continue_hint(args: argparse.Namespace, argv: list[str] | None) -> str:
    """What the interrupt line adds: how to continue. A run or resume continues from its last checkpoint; a study
    with a journal (``compensate --map``, ``calibrate``, ``robustness``), whose command stored its folder in
    ``args.study_out``, continues there when the same command runs again (given that folder as ``--out``)."""
    out = getattr(args, "study_out", None)
    if args.command in ("run", "resume"):
        where = shlex.quote(str(out)) if out is not None else "RUN_DIR"
        return (f"; continue from its last checkpoint with `whisker-opt resume {where}` (or run it again if no "
                "generation had finished)")
    if out is None or not Path(out).is_dir():
        return ""
    words = list(sys.argv[1:] if argv is None else argv)
    source = getattr(args, "source", None)  # robustness RUN_DIR writes into RUN_DIR
    if getattr(args, "out", None) is None and not (source is not None and Path(source).resolve() == Path(out).resolve()):
        words += ["--out", str(out)]
    return f"; its finished work is kept in {out}: continue with `whisker-opt {shlex.join(words)}`"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
