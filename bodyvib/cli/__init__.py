"""The ``bodyvib`` command line, the top layer: argparse and exit codes, one module per command.

It builds on :mod:`bodyvib.vehicle` (the application) and :mod:`bodyvib` (the physics
library); neither imports it. :func:`main` is the entry point (the ``bodyvib`` console
script) and :func:`~bodyvib.cli.main.build_parser` the argument parser of every command.

The command line is the public interface of this package; its modules (one per command)
are internal and may move.
"""

from .main import build_parser, main

__all__ = ["main", "build_parser"]
