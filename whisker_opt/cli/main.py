"""Command-line interface: ``whisker-opt <command> ...``.

Every error prints one line to stderr, ``whisker-opt <command>: error: <message>``, and no
traceback: a bad input (an option value, a config, an output folder, a run directory) exits
with status 2 before anything is computed, as does a file-system refusal (a name too long,
no permission, a read-only or full disk); a computation that fails on valid inputs (a scene
that does not converge, a mesh that cannot be made) exits with status 3. Any other
exception is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import errno
import logging
import sys

from whisker_opt.cli import commands


#: errno values of an OSError the user's file system causes (not a bug of the program).
_FILE_SYSTEM_ERRNOS = frozenset(
    getattr(errno, name) for name in ("EACCES", "EPERM", "EROFS", "ENOSPC", "EDQUOT", "ENAMETOOLONG", "ELOOP",
                                      "ENOTDIR", "EISDIR", "EEXIST", "EMLINK", "EFBIG") if hasattr(errno, name)
)


def _file_system_message(exc: OSError) -> str:
    names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
    return f"{' -> '.join(names)}: {exc.strerror}" if names and exc.strerror else str(exc)


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


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="whisker-opt",
        description="Design optimiser for soft, pneumatically tunable whisker sensors.",
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (helptext, add_args, _) in commands.REGISTRY.items():
        sp = sub.add_parser(name, help=helptext, description=helptext)
        add_args(sp)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``whisker-opt`` (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0; 2 for a bad input; 3 for a failed computation; 130 when interrupted.
    """
    try:
        args = _parser().parse_args(argv)
    except SystemExit as exc:  # --help, or an argparse error already printed
        return int(exc.code or 0) if isinstance(exc.code, int) or exc.code is None else 2
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    _, _, run = commands.REGISTRY[args.command]
    try:
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
        return 2
    except KeyboardInterrupt:
        print(f"whisker-opt {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
