"""``python -m glmls.cli.bench``: the benchmark, and each case's worker process."""

import sys

from .runner import main

sys.exit(main())
