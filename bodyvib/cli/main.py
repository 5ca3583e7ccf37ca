"""The ``bodyvib`` command line: the parser and the one place where errors become exit codes.

Each sub-command is a module of :mod:`bodyvib.cli` that registers itself through
an ``add_command(subparsers)`` function listed in :data:`COMMAND_MODULES`. Errors a user can cause (:class:`bodyvib.runtime.errors.BodyvibError`,
unreadable files, bad options) print one line and exit with status 2, without a
traceback; a command that needs an optional part of bodyvib names the extra that brings it
(:mod:`bodyvib.process.extras`). Ctrl-C ends any command with the single line ``interrupted`` and status 130,
SIGTERM with ``terminated (SIGTERM)`` and 143, SIGHUP with ``hung up (SIGHUP)`` and 129:
the command runs inside :func:`bodyvib.process.interrupts.deferred`, so the signal is
taken at a safe point, never inside an FMU, temporary files are removed, and outputs are
committed all together or not at all.
"""

import argparse
import contextlib
import gc
import signal
import sys
import threading
import warnings

from .flags import in_flags

# signals that arrive while the modules load (before bodyvib.process.interrupts takes over)
_early = []
_EARLY_SIGNALS = tuple(
    getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, n)
)


def _early_handler(signum, frame):
    _early.append(signum)


class UsageError(Exception):
    """A command line argparse refuses (an unknown option, a value of the wrong type)."""


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors become one line and status 2 like every other error.

    argparse prints the usage (5 to 7 lines) and exits from inside ``parse_args``; here the
    error is raised and :func:`main` prints ``bodyvib CMD: error: MESSAGE`` alone.
    """

    def error(self, message):
        raise UsageError(f"{self.prog}: error: {message} (see {self.prog} --help)")

    def parse_known_args(self, args=None, namespace=None):
        """argparse's parse, then: no argument may be given an empty value.

        ``--seat ""`` was taken as no seat, ``--car ""`` as the default car and ``build
        --cross-check ""`` as a plain build into dist/: an empty (or blank) value is
        refused, as argparse refuses a missing one.
        """
        namespace, extras = super().parse_known_args(args, namespace)
        parsers = [self]
        for action in self._actions:  # and the command's parser (however argparse calls it)
            if isinstance(action, argparse._SubParsersAction):
                parsers.append(action.choices.get(getattr(namespace, action.dest, None)))
        for parser in filter(None, parsers):
            for action in parser._actions:
                value = getattr(namespace, action.dest, None)
                if action.default == value:  # not given (a default is never blank)
                    continue
                values = value if isinstance(value, list) else [value]
                if any(isinstance(v, str) and not v.strip() for v in values):
                    name = "/".join(action.option_strings) or action.metavar or action.dest
                    parser.error(
                        f"argument {name}: empty value; give one or leave the argument out"
                    )
        return namespace, extras


__all__ = ["COMMAND_MODULES", "main", "build_parser"]

#: Modules that contribute sub-commands, in help order.
COMMAND_MODULES = (
    "bodyvib.cli.frf",
    "bodyvib.cli.build",
    "bodyvib.cli.cosim",
    "bodyvib.cli.control",
    "bodyvib.cli.fit",
    "bodyvib.cli.sweep",
    "bodyvib.cli.design",
    "bodyvib.cli.road",
    "bodyvib.cli.respond",
)


def build_parser():
    """The argument parser with every sub-command registered.

    Returns
    -------
    argparse.ArgumentParser
    """
    import importlib

    from bodyvib import __version__

    parser = _Parser(
        prog="bodyvib",
        description="Seated human-body vibration models: frequency responses, FMUs, "
        "quarter-car co-simulation with ISO 2631-1 comfort figures, GA refit.",
    )
    parser.add_argument("--version", action="version", version=f"bodyvib {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_command(sub)
    return parser


@contextlib.contextmanager
def _quick_exit(exiting):
    """Leave the objects of a process about to exit to the exit, not to the garbage collector.

    At exit Python collects every object in a reference cycle, one by one: about a second
    for a co-simulation on a loaded machine, between the command's last line and its
    end (a signal's bound counts it). Frozen (:func:`gc.freeze`), they are skipped; their
    memory goes back with the process. Only for the process's own command (``exiting``).
    """
    try:
        yield
    finally:
        if exiting:
            gc.freeze()


def _one_line(command):
    """A ``warnings.showwarning`` that prints bodyvib's own warnings as one line on stderr,
    each once (a sweep checks its roads before it runs them)."""
    default = warnings.showwarning
    seen = set()

    def show(message, category, filename, lineno, file=None, line=None):
        if category.__module__.startswith("bodyvib"):
            text = in_flags(str(message), getattr(message, "parameters", ()))
            if text not in seen:
                seen.add(text)
                print(f"{command}: warning: {text}", file=sys.stderr)
        else:
            default(message, category, filename, lineno, file, line)

    return show


def main(argv=None) -> int:
    """Run the command line; returns the exit status.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (``sys.argv[1:]`` by default: the process's command line, after which
        the process exits, so SIGINT, SIGTERM and SIGHUP are left ignored; with ``argv``
        given, the previous handlers are restored).

    Returns
    -------
    int
        0 on success, 2 on a user error, 130 when interrupted (Ctrl-C), 143 on SIGTERM,
        129 on SIGHUP.
    """
    main_thread = threading.current_thread() is threading.main_thread()
    previous = {s: signal.signal(s, _early_handler) for s in _EARLY_SIGNALS} if main_thread else {}
    try:
        from bodyvib.process import interrupts
        from bodyvib.process.extras import MissingExtraError
        from bodyvib.process.scratch import private_tempdir
        from bodyvib.runtime.errors import BodyvibError
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)
    command = "bodyvib"

    def stopped():
        print(interrupts.message(), file=sys.stderr)
        return interrupts.exit_status()

    # argv None: the process's own command
    with _quick_exit(argv is None), interrupts.deferred(exiting=argv is None):
        interrupts.pending_from(list(_early))
        _early.clear()
        try:
            interrupts.check()
            parser = build_parser()
            args = parser.parse_args(argv)
            if not getattr(args, "func", None):
                parser.print_help()
                return 2
            command = f"bodyvib {args.command}"
            with private_tempdir(), warnings.catch_warnings():  # temporary files removed at
                warnings.showwarning = _one_line(command)  # the end; warnings in one line
                status = int(args.func(args) or 0)
                interrupts.check()  # pressed during the last step: the outputs are all written
            return status
        except UsageError as exc:
            if interrupts.requested():
                return stopped()
            print(exc, file=sys.stderr)
            return 2
        except MissingExtraError as exc:  # the line names the command when it is the task
            if interrupts.requested():
                return stopped()
            print(exc if exc.task == command else f"{command}: {exc}", file=sys.stderr)
            return 2
        except BodyvibError as exc:
            if interrupts.requested():
                return stopped()
            print(f"{command}: error: {in_flags(str(exc), exc.parameters)}", file=sys.stderr)
            return 2
        except OSError as exc:
            if interrupts.requested():
                return stopped()
            where = f" '{exc.filename}'" if exc.filename else ""
            print(f"{command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            return stopped()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
