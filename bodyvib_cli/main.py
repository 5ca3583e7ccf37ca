"""The ``bodyvib`` command line: the parser and the one place where errors become exit codes.

Each sub-command is a module of :mod:`bodyvib_cli` that registers itself through
an ``add_command(subparsers)`` function listed in :data:`COMMAND_MODULES`. Errors a user can cause (:class:`BodyvibError`,
unreadable files) print one line and exit with status 2, without a traceback.
"""

import argparse
import importlib
import sys

from bodyvib import __version__
from bodyvib.runtime.errors import BodyvibError

__all__ = ["COMMAND_MODULES", "main", "build_parser"]

#: Modules that contribute sub-commands, in help order.
COMMAND_MODULES = (
    "bodyvib_cli.frf",
    "bodyvib_cli.build",
    "bodyvib_cli.cosim",
    "bodyvib_cli.fit",
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every sub-command registered."""
    parser = argparse.ArgumentParser(
        prog="bodyvib",
        description="Seated human-body vibration models: frequency responses, FMUs, "
        "quarter-car co-simulation with ISO 2631-1 comfort figures, GA refit.",
    )
    parser.add_argument("--version", action="version", version=f"bodyvib {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_command(sub)
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        0 on success, 2 on a user error, 130 when interrupted.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except BodyvibError as exc:
        print(f"bodyvib {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        where = f" '{exc.filename}'" if exc.filename else ""
        print(f"bodyvib {args.command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"bodyvib {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
