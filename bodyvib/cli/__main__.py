"""``python -m bodyvib.cli``: the same as the ``bodyvib`` command."""

import sys

from .main import main

sys.exit(main())
