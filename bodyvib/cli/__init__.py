"""The ``bodyvib`` command line, the top layer: argparse and exit codes, one module per command.

It builds on :mod:`bodyvib.vehicle` (the application) and :mod:`bodyvib` (the physics
library); neither imports it. :func:`bodyvib.cli.main.main` is the entry point.
"""

from .main import main

__all__ = ["main"]
