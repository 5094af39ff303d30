"""Command-line interface: ``whisker-opt <command> ...``.

User errors (a bad config, an impossible design) print one line to stderr and exit with
status 2, without a traceback; anything else is a bug and keeps its traceback.
"""

from __future__ import annotations

import argparse
import logging
import sys

from whisker_opt.cli import commands


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
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
    """Entry point of the console script; returns the exit status."""
    args = _parser().parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    _, _, run = commands.REGISTRY[args.command]
    try:
        return int(run(args) or 0)
    except commands.USER_ERRORS as exc:
        msg = str(exc).strip()
        print(f"whisker-opt {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"whisker-opt {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
