"""``python -m glmls``: the ``glmls`` command line."""

import sys

from .cli import main

sys.exit(main())
