"""The ``bodyvib`` command line, the top layer: argparse and exit codes, one module per command.

It builds on :mod:`vehicle` (the application) and :mod:`bodyvib` (the physics
library); neither imports it. :func:`bodyvib_cli.main.main` is the entry point.
"""
