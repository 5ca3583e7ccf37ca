"""The ``bodyvib`` command line: the parser and the one place where errors become exit codes.

Each sub-command is a module of :mod:`bodyvib_cli` that registers itself through
an ``add_command(subparsers)`` function listed in :data:`COMMAND_MODULES`. Errors a user
can cause (:class:`bodyvib.runtime.errors.BodyvibError`, unreadable files) print one line
and exit with status 2, without a traceback. Ctrl-C ends any command with the single line
``interrupted`` and status 130: the command runs
inside :func:`bodyvib.process.interrupts.deferred`, so the interrupt is taken at a safe point,
never inside an FMU, and outputs are committed all together or not at all.
"""

import signal
import sys
import threading

# SIGINTs that arrive while the modules load (before bodyvib.process.interrupts takes over)
_early = []


def _early_handler(signum, frame):
    _early.append(signum)


__all__ = ["COMMAND_MODULES", "main", "build_parser"]

#: Modules that contribute sub-commands, in help order.
COMMAND_MODULES = (
    "bodyvib_cli.frf",
    "bodyvib_cli.build",
    "bodyvib_cli.cosim",
    "bodyvib_cli.fit",
    "bodyvib_cli.sweep",
    "bodyvib_cli.road",
    "bodyvib_cli.respond",
)


def build_parser():
    """The argument parser with every sub-command registered.

    Returns
    -------
    argparse.ArgumentParser
    """
    import argparse
    import importlib

    from bodyvib import __version__

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
        Arguments (``sys.argv[1:]`` by default: the process's command line, after which
        the process exits, so SIGINT is left ignored; with ``argv`` given, the previous
        SIGINT handler is restored).

    Returns
    -------
    int
        0 on success, 2 on a user error, 130 when interrupted.
    """
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, _early_handler) if main_thread else None
    try:
        from bodyvib.process import interrupts
        from bodyvib.runtime.errors import BodyvibError
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
    command = "bodyvib"
    with interrupts.deferred(exiting=argv is None):  # argv None: the process's own command
        interrupts.pending_from(len(_early))
        _early.clear()
        try:
            interrupts.check()
            parser = build_parser()
            args = parser.parse_args(argv)
            if not getattr(args, "func", None):
                parser.print_help()
                return 2
            command = f"bodyvib {args.command}"
            status = int(args.func(args) or 0)
            interrupts.check()  # pressed during the last step: the outputs are all written
            return status
        except BodyvibError as exc:
            if interrupts.requested():
                print("interrupted", file=sys.stderr)
                return 130
            print(f"{command}: error: {exc}", file=sys.stderr)
            return 2
        except OSError as exc:
            if interrupts.requested():
                print("interrupted", file=sys.stderr)
                return 130
            where = f" '{exc.filename}'" if exc.filename else ""
            print(f"{command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
