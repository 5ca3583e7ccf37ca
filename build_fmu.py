#!/usr/bin/env python3
"""Build the FMUs into dist/: HumanBody3DOF.fmu, HumanBodyISO7962.fmu, QuarterCar.fmu.

    python build_fmu.py [--params FILE] [--dest DIR] [--fmus NAME ...]

The same as ``bodyvib build`` (:mod:`bodyvib.cli.build`).
"""

import sys

from bodyvib.cli.build import main

if __name__ == "__main__":
    sys.exit(main())
