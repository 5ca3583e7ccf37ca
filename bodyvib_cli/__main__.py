"""``python -m bodyvib_cli``: the same as the ``bodyvib`` command."""

import sys

from .main import main

sys.exit(main())
