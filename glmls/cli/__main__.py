"""``python -m glmls.cli``: the ``glmls`` command line."""

import sys

from .main import main

sys.exit(main())
